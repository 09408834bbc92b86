"""``rag`` mode (LLM-Land): retrieval, the LLM's pointer at the obstacle, grounding, and the
every-mention safety layer (:func:`~.pipeline.most_careful_of_mentions`).

**When the LLM is asked.** With the safety layer on, the LLM's pointer moves the caption's
spec only through the mention it names: that mention takes the entry grounded from the
pointed window (when its class allows that entry), and the spec is the most careful mention.
Often no answer the LLM could give changes the outcome ("two people walking past a parked
car": whichever word it points at, a person is in the caption and the person's spec wins).
:func:`unanimous_answer` decides this exactly, before the LLM runs: the pointer is the argmax
over the caption's content words (:func:`~.mention.choose_mention`), so there are only
``len(content_positions)`` answers it can give; each is played through the same code as a
real answer (:func:`finish_rag` with a one-hot pointer). When all of them give the same safety
fields (``is_dynamic``, ``z_min``, ``buffer_m``, ``is_human``), that is the spec whatever answer
the LLM would give, and the LLM is not asked; otherwise it is. (An LLM that fails — a dead
worker, non-finite scores — gave such a caption the conservative fallback before; now the
caption keeps the spec every valid answer gives.) The report fields of a settled spec (label,
evidence, the mention list) are those of the first content word's candidate. Captions with a mention of another
reading (``decide.py``) and captions that name nothing the KB knows always go to the LLM.
``rag_llm_when_needed=False`` asks it for every caption (the paper's flow; latency comparisons).
"""

from __future__ import annotations

import logging
from dataclasses import replace

from . import deadline, prompts
from .decide import Decider, LlmDecider, RetrievalDecider
from .grounding import ground
from .kb import KbEntry
from .llm import ScoreRequest
from .mention import caption_words, choose_mention, content_positions, window_at
from .mentions import Found
from .pipeline import Outcome, embed_name, most_careful_of_mentions, retrieve_hits
from .resources import Resources
from .safety import ground_mentions, uncached_windows

log = logging.getLogger(__name__)

#: The one-hot pointer's log-probability for the words not pointed at (any finite value below 0).
_NOT_POINTED = -1.0


def rag_decider(res: Resources, pointer: str, llm: LlmDecider | None = None) -> Decider | None:
    """Who chooses between a mention's readings: the LLM (``llm``, or a new one), or retrieval
    in the no-LLM ablations."""
    if res.names is None or res.wordnet is None:
        return None
    if pointer == "llm" and res.backend is not None:
        return llm or LlmDecider(res.backend, res.wordnet)
    return RetrievalDecider(res.kb, res.names)


def rag_request(caption: str, hits: list[tuple[KbEntry, float]], context_in_prompt: bool) -> ScoreRequest:
    """The LLM call of rag's pointer: the first-token log-probability of each content word."""
    words = caption_words(caption)
    labels = [entry.label for entry, _ in hits] if context_in_prompt else None
    return (prompts.rag_prefix(context_in_prompt), prompts.rag_suffix(caption, labels),
            [words[i] for i in content_positions(words)], True)


def pointer_windows(caption: str) -> list[str]:
    """Every window the LLM's pointer can choose (one per content word; may repeat): what
    :func:`unanimous_answer` grounds, so a batch embeds them in one call beforehand."""
    words = caption_words(caption)
    return [window_at(words, i) for i in content_positions(words)]


def _care(o: Outcome) -> tuple[bool, float, float, bool | None]:
    """The fields the planner acts on (the label, evidence and mention list are reports)."""
    return (o.is_dynamic, o.z_min, o.buffer_m, o.is_human)


def unanimous_answer(caption: str, hits: list[tuple[KbEntry, float]], res: Resources,
                     found: list[Found] | None = None) -> Outcome | None:
    """rag's outcome when every answer the LLM's pointer could give leads to the same safety
    fields (the outcome of the first content word, labelled as the rules', ``asked_llm`` False,
    no ``phrase``), else None: the LLM must be asked. Needs the every-mention layer (without it the pointer's
    answer *is* the spec). ``found``: the caption's mentions when the caller has them. Raises
    what the mention layer raises."""
    if res.finder is None or res.names is None or not hits:
        return None
    found = res.finder.find(caption) if found is None else found
    grounded = ground_mentions(caption, found, res.kb, res.names, res.wordnet, res.mention_cache)
    if not grounded or any(g.alternatives for g in grounded):
        return None  # the LLM's answer is the spec / the decider asks the LLM anyway
    n = len(content_positions(caption_words(caption)))
    first: Outcome | None = None
    for k in range(n):
        deadline.check()  # one full finish per content word: stop once the caller gave up
        one_hot = [_NOT_POINTED] * n
        one_hot[k] = 0.0
        out = finish_rag(caption, hits, one_hot, res, "llm", True, None, found, asked=False)
        if first is None:
            first = out
        elif _care(out) != _care(first):
            return None
    return None if first is None else replace(first, phrase="")  # nothing was pointed at


def unanimous_or_none(caption: str, hits: list[tuple[KbEntry, float]], res: Resources,
                      found: list[Found] | None) -> Outcome | None:
    """:func:`unanimous_answer`, or None (ask the LLM) where it fails: the steps after the LLM
    then meet the error again and report it. One policy for one caption and for a batch."""
    try:
        return unanimous_answer(caption, hits, res, found)
    except deadline.DeadlineExceededError:
        raise  # the caller stopped waiting: no LLM call either
    except Exception as exc:  # noqa: BLE001 - the LLM is asked instead
        log.debug("no rules answer for %r: %s", caption, exc)
        return None


def prefetch_windows(caption: str, found: list[Found], res: Resources) -> list[str]:
    """The windows :func:`unanimous_answer` will embed for ``caption`` (every pointer window and
    the windows of mentions not in the mention cache), for one embedding call beforehand."""
    return pointer_windows(caption) + uncached_windows(caption, found, res.kb, res.mention_cache)


def warm_pointer(caption: str, res: Resources, context_in_prompt: bool) -> None:
    """Ask the LLM's pointer about ``caption`` (its answer unused): the prompt prefix is then
    evaluated and kept (``llm.py``), so the first caption that needs the LLM pays only its suffix."""
    if res.backend is None:
        raise RuntimeError("rag needs the LLM")
    res.backend.score(*rag_request(caption, retrieve_hits(caption, res), context_in_prompt))


def run_rag(
    caption: str, res: Resources, context_in_prompt: bool, pointer: str = "llm", every_mention: bool = True,
    decider: Decider | None = None, llm_when_needed: bool = True,
) -> Outcome:
    """LLM-Land. ``pointer="first_word"`` / ``"retrieval"`` are the no-LLM ablations: the mention
    simply starts at the caption's first content word, or the answer is retrieval's top-1
    entry; ``decider`` then is retrieval's (:func:`rag_decider`). ``llm_when_needed``: skip the
    LLM when :func:`unanimous_answer` has the spec."""
    if res.names is None:
        raise RuntimeError("rag needs retrieval")
    hits = retrieve_hits(caption, res)
    logprobs: list[float] | None = None
    if pointer == "llm":
        if res.backend is None:
            raise RuntimeError("rag needs the LLM")
        if every_mention and llm_when_needed and res.finder is not None:
            found = res.finder.find(caption)
            res.names.phrases(list(dict.fromkeys(prefetch_windows(caption, found, res))))  # one embedding call
            known = unanimous_or_none(caption, hits, res, found)
            if known is not None:
                return known
        logprobs = res.backend.score(*rag_request(caption, hits, context_in_prompt))
    return finish_rag(caption, hits, logprobs, res, pointer, every_mention, decider)


def finish_rag(
    caption: str, hits: list[tuple[KbEntry, float]], logprobs: list[float] | None, res: Resources, pointer: str,
    every_mention: bool, decider: Decider | None, found: list[Found] | None = None, *, asked: bool = True,
) -> Outcome:
    """Everything of rag after retrieval (``hits``) and the LLM's pointer (``logprobs``, the
    answer to :func:`rag_request`; None in the ablations). ``asked=False`` (``pointer="llm"``
    only): ``logprobs`` are one answer the LLM could give, played through by
    :func:`unanimous_answer`; the outcome then names the rules as its model, and the candidate
    mention's source is ``retrieval`` (its entry is the retrieved candidate its window names)."""
    if res.names is None:
        raise RuntimeError("rag needs retrieval")
    if not hits:
        raise RuntimeError("retrieval returned nothing")
    words = caption_words(caption)
    positions = content_positions(words)
    if pointer == "retrieval":
        answer = Outcome.from_entry(hits[0][0], f"retrieval+{embed_name(res)}", [(e.id, s) for e, s in hits],
                                    retrieval_top1=hits[0][0].id)
        if not every_mention:
            return answer
        return most_careful_of_mentions(caption, answer, hits[0][0], "retrieval", res, decider=decider, found=found)
    if pointer == "first_word":
        logprobs = [0.0] + [_NOT_POINTED] * (len(positions) - 1)
        name = "first-word"
    elif not asked:
        if logprobs is None:
            raise ValueError("a candidate answer needs its log-probabilities")
        name = "rules"
    else:
        if res.backend is None or logprobs is None:
            raise RuntimeError("rag needs the LLM")
        name = res.backend.name
    mention = choose_mention(words, positions, logprobs)
    chosen = ground(mention.window, hits, res.names)
    evidence = [(entry.id, round(score, 4)) for entry, score in chosen.ranked]
    model = f"{name}+{embed_name(res)}"
    answer = Outcome.from_entry(chosen.entry, model, evidence, phrase=mention.window, retrieval_top1=hits[0][0].id)
    asked_llm = pointer == "llm" and asked
    answer = replace(answer, asked_llm=asked_llm)
    if not every_mention:
        return answer
    return most_careful_of_mentions(caption, answer, chosen.entry, "llm" if asked_llm else "retrieval", res,
                                    pointed=mention.word, decider=decider, found=found)
