"""Turning one normalised caption into spec fields (no caching, may raise): the outcome, the
every-mention safety layer, and the ``retrieval`` and ``llm`` modes (``rag``, LLM-Land, is in
:mod:`.rag`).

Each ``run_*`` returns an :class:`Outcome`; :mod:`.extractor` wraps them with the cache,
the timeout and the conservative fallback.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, field, replace

from llmland_schemas.messages import MentionResult
from pydantic import BaseModel, ConfigDict, Field

from . import prompts
from .decide import Decider
from .kb import KbEntry
from .mentions import Found
from .resources import Resources
from .safety import Alternative, Grounded, Numbers, ground_mentions, most_careful
from .words import fold_text


def normalize_caption(caption: str) -> str:
    """Letters folded (:func:`.words.fold_text`), lower-case, single spaces, no surrounding
    punctuation: the cache key and model input."""
    text = re.sub(r"\s+", " ", fold_text(str(caption))).strip().lower()
    return text.strip(" .,;:!?\"'")


@dataclass(frozen=True)
class Outcome:
    is_dynamic: bool
    z_min: float
    buffer_m: float
    label: str
    model: str
    evidence: list[tuple[str, float]] = field(default_factory=list)
    phrase: str = ""
    retrieval_top1: str = ""
    mentions: list[MentionResult] = field(default_factory=list)
    #: a person (True) or not (False), from the KB entry the spec is grounded in; None: unknown
    #: (the llm baseline has no KB; an unknown noun has no entry)
    is_human: bool | None = None
    #: how many mentions had another reading to decide, and how many the decider changed
    decisions: int = 0
    changed: int = 0
    #: whether the LLM was asked (rag: not when no answer it could give changes the spec)
    asked_llm: bool = False

    @classmethod
    def from_entry(cls, entry: KbEntry, model: str, evidence: list[tuple[str, float]], phrase: str = "",
                   retrieval_top1: str = "") -> Outcome:
        return cls(entry.is_dynamic, entry.z_min, entry.buffer_m, entry.label, model, evidence, phrase,
                   retrieval_top1, is_human=entry.is_human)


def _result(text: str, source: str, n: Numbers) -> MentionResult:
    return MentionResult.model_validate(
        {"text": text, "source": source, "label": n.label, "kb_id": n.kb_id, "is_dynamic": n.is_dynamic,
         "z_min": n.z_min, "buffer_m": n.buffer_m}
    )


def _at_least(a: Numbers, b: Numbers) -> bool:
    """``a`` is at least as careful as ``b`` in every respect (human, moving, buffer)."""
    return a.is_human >= b.is_human and a.is_dynamic >= b.is_dynamic and a.buffer_m >= b.buffer_m


def _most_careful(grounded: list[Grounded], chosen: list[Alternative | None], answer_entry: KbEntry,
                  answer_source: str, pointed: str, decider: Decider | None) -> tuple[int, list[Numbers], list[str]]:
    """The most careful mention (index), every mention's numbers and sources, after the
    decider's readings (``chosen``) and the mode's own answer (see below)."""
    options = [c.numbers if c is not None else g.numbers for g, c in zip(grounded, chosen, strict=True)]
    sources: list[str] = [g.found.source if c is None or decider is None else decider.source
                          for g, c in zip(grounded, chosen, strict=True)]
    allowed = [k for k, g in enumerate(grounded) if answer_entry.id in g.pool and chosen[k] is None]
    named = [k for k in allowed if pointed and pointed in grounded[k].found.text.split()]
    target = (named or allowed or [-1])[0]
    order = list(range(len(grounded)))
    if target >= 0:
        options[target] = Numbers.of(answer_entry)
        sources[target] = answer_source
        order = [target, *[k for k in order if k != target]]  # the mode's answer wins a tie
    return order[most_careful([options[k] for k in order])], options, sources


def most_careful_of_mentions(caption: str, answer: Outcome, answer_entry: KbEntry, answer_source: str,
                             res: Resources, pointed: str = "", decider: Decider | None = None,
                             found: list[Found] | None = None) -> Outcome:
    """The safety layer: every mention of the caption grounded in the KB; the spec is the most
    careful present mention. A mention with other readings (``safety.other_readings``) takes
    the one ``decider`` chooses (rag: the LLM; none in retrieval: the rules' reading). The mode's
    own answer (the LLM's pick in rag, the top-1 entry in retrieval) chooses the entry of the
    mention it names (the one holding ``pointed``, else the first that may take that entry)
    when that entry is allowed for it (same class, parked only when said); it is the spec as it
    stands only when the caption names nothing at all. The decider's readings stand only if the
    caption's spec is then at least as careful as the rules' own (:func:`_at_least`). ``found``:
    the caption's mentions when the caller has already found them (a batch)."""
    if res.finder is None or res.names is None:
        raise RuntimeError("the mention layer needs retrieval (embedder and WordNet)")
    if found is None:
        found = res.finder.find(caption)
    grounded = ground_mentions(caption, found, res.kb, res.names, res.wordnet, res.mention_cache)
    absent = [MentionResult(text=f.text, status=f.status, source=f.source, label=f.word_class)
              for f in found if f.status != "present"]
    if not grounded:
        return replace(answer, mentions=[_result(answer.phrase or caption, answer_source, Numbers.of(answer_entry)),
                                         *absent])
    none: list[Alternative | None] = [None] * len(grounded)
    chosen = decider.decide(caption, grounded) if decider is not None else none
    best, options, sources = _most_careful(grounded, chosen, answer_entry, answer_source, pointed, decider)
    if any(c is not None for c in chosen):
        rules = _most_careful(grounded, none, answer_entry, answer_source, pointed, None)
        if not _at_least(options[best], rules[1][rules[0]]):
            # a raised mention that wins by the living-first order but with a smaller buffer
            # ("the dump truck and the crane": a bird, 4 m, over the truck's 5 m): the caption's
            # spec may only gain care, so the rules' answer stands
            chosen = none
            best, options, sources = rules
    results = [_result(g.found.text, sources[k], options[k]) for k, g in enumerate(grounded)] + absent
    n = options[best]
    evidence = [(n.kb_id, 1.0)] if n.kb_id else []
    evidence += [(kb_id, score) for kb_id, score in answer.evidence if kb_id != n.kb_id]
    return replace(answer, is_dynamic=n.is_dynamic, z_min=n.z_min, buffer_m=n.buffer_m, label=n.label,
                   evidence=evidence, mentions=results, is_human=n.is_human if n.kb_id else None,
                   decisions=sum(bool(g.alternatives) for g in grounded), changed=sum(c is not None for c in chosen))


class PaperAnswer(BaseModel):
    """The JSON the paper's prompt asks for (plus ``buffer``)."""

    model_config = ConfigDict(extra="forbid")

    is_dynamic: str = Field(pattern=r"^(yes|no)$")
    z_min: float = Field(ge=0.0, le=200.0)
    buffer: float = Field(ge=0.0, le=200.0)


def retrieve_hits(caption: str, res: Resources) -> list[tuple[KbEntry, float]]:
    """Retrieval's top-k (entry, fused score), best first; RuntimeError when there is none."""
    if res.retriever is None:
        raise RuntimeError("retrieval is not loaded")
    hits = res.retriever.retrieve(caption)
    if not hits:
        raise RuntimeError("retrieval returned nothing")
    return hits


def embed_name(res: Resources) -> str:
    """The embedder's model name ("" when none is loaded), for the spec's ``model`` field."""
    return res.embed.model_name if res.embed is not None else ""


def run_retrieval(caption: str, res: Resources, every_mention: bool = True,
                  hits: list[tuple[KbEntry, float]] | None = None, found: list[Found] | None = None) -> Outcome:
    """``hits``, ``found``: retrieval's answer and the caption's mentions when a batch has them."""
    hits = hits if hits is not None else retrieve_hits(caption, res)
    if not hits:
        raise RuntimeError("retrieval returned nothing")
    evidence = [(entry.id, score) for entry, score in hits]
    answer = Outcome.from_entry(hits[0][0], embed_name(res), evidence, retrieval_top1=hits[0][0].id)
    if not every_mention:
        return answer
    return most_careful_of_mentions(caption, answer, hits[0][0], "retrieval", res, found=found)


#: The label of the paper's LLM-only answer, which names no class (not "unknown": that is the
#: careful spec's label, 5 m, and this answer's numbers are the LLM's own, as small as it says).
LLM_ONLY_LABEL = "unlabelled"


def run_llm(caption: str, res: Resources, max_tokens: int, temperature: float) -> Outcome:
    if res.backend is None:
        raise RuntimeError("no LLM backend loaded")
    text = res.backend.complete(
        prompts.paper_prefix(), prompts.paper_suffix(caption), prompts.SPEC_GRAMMAR, max_tokens, temperature
    )
    answer = PaperAnswer.model_validate(json.loads('{"is_dynamic": "' + text))
    return Outcome(  # is_human stays None: the baseline has no KB to say
        is_dynamic=answer.is_dynamic == "yes",
        z_min=answer.z_min,
        buffer_m=answer.buffer,
        label=LLM_ONLY_LABEL,
        model=res.backend.name,
    )
