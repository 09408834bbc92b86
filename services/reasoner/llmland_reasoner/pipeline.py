"""The three ways of turning one normalised caption into spec fields (no caching, may raise).

Each ``run_*`` returns an :class:`Outcome`; :mod:`.extractor` wraps them with the cache,
the timeout and the conservative fallback.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, field

from pydantic import BaseModel, ConfigDict, Field

from . import prompts
from .grounding import ground
from .kb import KbEntry
from .mention import caption_words, choose_mention, content_positions
from .resources import Resources


def normalize_caption(caption: str) -> str:
    """Lower-case, single spaces, no surrounding punctuation: the cache key and model input."""
    text = re.sub(r"\s+", " ", str(caption)).strip().lower()
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

    @classmethod
    def from_entry(cls, entry: KbEntry, model: str, evidence: list[tuple[str, float]], **kw: str) -> Outcome:
        return cls(entry.is_dynamic, entry.z_min, entry.buffer_m, entry.label, model, evidence, **kw)


class PaperAnswer(BaseModel):
    """The JSON the paper's prompt asks for (plus ``buffer``)."""

    model_config = ConfigDict(extra="forbid")

    is_dynamic: str = Field(pattern=r"^(yes|no)$")
    z_min: float = Field(ge=0.0, le=200.0)
    buffer: float = Field(ge=0.0, le=200.0)


def _retrieve(caption: str, res: Resources) -> list[tuple[KbEntry, float]]:
    if res.retriever is None:
        raise RuntimeError("retrieval is not loaded")
    hits = res.retriever.retrieve(caption)
    if not hits:
        raise RuntimeError("retrieval returned nothing")
    return hits


def _embed_name(res: Resources) -> str:
    return res.embed.model_name if res.embed is not None else ""


def run_retrieval(caption: str, res: Resources) -> Outcome:
    hits = _retrieve(caption, res)
    evidence = [(entry.id, score) for entry, score in hits]
    return Outcome.from_entry(hits[0][0], _embed_name(res), evidence, retrieval_top1=hits[0][0].id)


def run_llm(caption: str, res: Resources, max_tokens: int, temperature: float) -> Outcome:
    if res.backend is None:
        raise RuntimeError("no LLM backend loaded")
    text = res.backend.complete(
        prompts.paper_prefix(), prompts.paper_suffix(caption), prompts.SPEC_GRAMMAR, max_tokens, temperature
    )
    answer = PaperAnswer.model_validate(json.loads('{"is_dynamic": "' + text))
    return Outcome(
        is_dynamic=answer.is_dynamic == "yes",
        z_min=answer.z_min,
        buffer_m=answer.buffer,
        label="unknown",
        model=res.backend.name,
    )


def run_rag(caption: str, res: Resources, context_in_prompt: bool, pointer: str = "llm") -> Outcome:
    """LLM-Land. ``pointer="first_word"`` is the no-LLM ablation: the mention simply starts
    at the caption's first content word."""
    if res.names is None:
        raise RuntimeError("rag needs retrieval")
    hits = _retrieve(caption, res)
    words = caption_words(caption)
    positions = content_positions(words)
    if pointer == "first_word":
        logprobs = [0.0] + [-1.0] * (len(positions) - 1)
        name = "first-word"
    else:
        if res.backend is None:
            raise RuntimeError("rag needs the LLM")
        labels = [entry.label for entry, _ in hits] if context_in_prompt else None
        logprobs = res.backend.score(
            prompts.rag_prefix(context_in_prompt),
            prompts.rag_suffix(caption, labels),
            [words[i] for i in positions],
            first_token_only=True,
        )
        name = res.backend.name
    mention = choose_mention(words, positions, logprobs)
    chosen = ground(mention.window, hits, res.names)
    evidence = [(entry.id, round(score, 4)) for entry, score in chosen.ranked]
    model = f"{name}+{_embed_name(res)}"
    return Outcome.from_entry(chosen.entry, model, evidence, phrase=mention.window, retrieval_top1=hits[0][0].id)
