"""Many captions at once (one reasoner serving many drones): each answer equals the one the
caption would get alone (``pipeline.run_*``), with the work that batches done in batches.

For ``rag`` and ``retrieval``, in order:

1. retrieval for every caption, their query vectors in one MiniLM call;
2. the mentions of every caption, and one MiniLM call for every window not seen before
   (the windows rag's pointer can choose and the windows of mentions not in the mention cache);
3. rag: the captions whose spec no answer of the LLM can change are answered by the rules
   (:func:`~.rag.unanimous_answer`); the LLM pointer for all the others in one request to the
   LLM (one round trip to the worker process; :func:`~.llm.score_many`);
4. the rest caption by caption (grounding from the mention cache, the decider, the most
   careful mention): cheap once 1–3 are done.

A failure in a shared step (retrieval, the LLM: a worker crash mid-batch) fails every caption
of the batch that needed it; a failure in step 4 fails its caption only. The caller turns
each failure into the conservative fallback spec. ``llm`` (the baseline) runs one by one.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from functools import partial

from . import deadline
from .decide import Decider
from .kb import KbEntry
from .llm import score_many
from .mention import caption_words, choose_mention, content_positions
from .mentions import Found
from .pipeline import Outcome, run_llm, run_retrieval
from .rag import finish_rag, prefetch_windows, rag_request, unanimous_or_none
from .resources import Resources
from .safety import uncached_windows
from .settings import Mode, ReasonerSettings

log = logging.getLogger(__name__)

Result = Outcome | Exception


def run_many(mode: Mode, captions: Sequence[str], res: Resources, settings: ReasonerSettings,
             decider: Decider | None) -> list[Result]:
    """One :class:`~.pipeline.Outcome` or the exception that stopped it, per (normalised) caption."""
    if mode == "llm":
        return [_guard(partial(run_llm, c, res, settings.max_new_tokens, settings.temperature)) for c in captions]
    if res.retriever is None or res.names is None:
        return [RuntimeError("retrieval is not loaded")] * len(captions)
    try:
        hits = res.retriever.retrieve_many(captions)
    except Exception as exc:  # noqa: BLE001 - every caption of the batch falls back
        log.warning("batched retrieval failed for %d captions: %s", len(captions), exc)
        return [exc] * len(captions)
    pointer = settings.rag_pointer
    asks_llm = mode == "rag" and pointer == "llm"
    when_needed = asks_llm and settings.every_mention and settings.rag_llm_when_needed
    found = _find_and_prefetch(captions, hits, res, settings.every_mention, when_needed)
    logprobs: list[list[float] | None] = [None] * len(captions)
    known: list[Outcome | None] = [None] * len(captions)
    if asks_llm:
        if res.backend is None:
            return [RuntimeError("rag needs the LLM")] * len(captions)
        if when_needed:
            known = [unanimous_or_none(captions[k], hits[k], res, found[k]) if found[k] is not None else None
                     for k in range(len(captions))]
        asked = [k for k, h in enumerate(hits) if h and known[k] is None]
        deadline.check()  # before the batch's LLM call: not for a caller that stopped waiting
        try:
            answers = score_many(res.backend, [rag_request(captions[k], hits[k], settings.rag_context_in_prompt)
                                               for k in asked]) if asked else []
        except Exception as exc:  # noqa: BLE001 - a worker lost mid-batch: every caption that asked falls back
            log.warning("batched LLM call failed for %d captions: %s", len(asked), exc)
            return [done if done is not None else exc for done in known]
        for k, a in zip(asked, answers, strict=True):
            logprobs[k] = a
        if not when_needed:
            _prefetch_chosen(captions, logprobs, res)
    out: list[Result] = []
    for k, caption in enumerate(captions):
        done = known[k]
        if done is not None:
            out.append(done)
        elif mode == "retrieval":
            out.append(_guard(partial(run_retrieval, caption, res, settings.every_mention, hits[k], found[k])))
        else:
            out.append(_guard(partial(finish_rag, caption, hits[k], logprobs[k], res, pointer, settings.every_mention,
                                      decider, found[k])))
    return out


def _prefetch_chosen(captions: Sequence[str], logprobs: list[list[float] | None], res: Resources) -> None:
    """One embedding call for the window the LLM chose in every caption (when every pointer
    window was not embedded beforehand)."""
    windows: list[str] = []
    for caption, lp in zip(captions, logprobs, strict=True):
        if lp is not None:
            try:
                words = caption_words(caption)
                windows.append(choose_mention(words, content_positions(words), lp).window)
            except Exception as exc:  # noqa: BLE001 - that caption's own step 4 meets it again
                log.debug("no window to prefetch for %r: %s", caption, exc)
    _embed_once(windows, res)


def _find_and_prefetch(captions: Sequence[str], hits: list[list[tuple[KbEntry, float]]], res: Resources,
                       every_mention: bool, with_pointer_windows: bool) -> list[list[Found] | None]:
    """Each caption's mentions (None where finding failed: step 4 then finds them itself and
    reports the error), and one embedding call for every window steps 3 and 4 will need
    (``with_pointer_windows``: every window rag's LLM pointer can choose)."""
    found: list[list[Found] | None] = [None] * len(captions)
    windows: list[str] = []
    for k, caption in enumerate(captions):
        try:
            if every_mention and res.finder is not None:
                found[k] = mentions = res.finder.find(caption)
                windows += (prefetch_windows(caption, mentions, res) if with_pointer_windows and hits[k]
                            else uncached_windows(caption, mentions, res.kb, res.mention_cache))
        except Exception as exc:  # noqa: BLE001 - that caption's own step 4 meets it again
            log.debug("prefetch skipped for %r: %s", caption, exc)
    _embed_once(windows, res)
    return found


def _embed_once(windows: list[str], res: Resources) -> None:
    """One MiniLM call for every window not embedded yet (each once); a failure is logged, and
    step 4 embeds what it needs itself."""
    if windows and res.names is not None:
        try:
            res.names.phrases(list(dict.fromkeys(windows)))
        except Exception as exc:  # noqa: BLE001 - step 4 embeds them itself
            log.warning("batched window embedding failed: %s", exc)


def _guard(fn: Callable[[], Outcome]) -> Result:
    try:
        return fn()
    except Exception as exc:  # noqa: BLE001 - that caption falls back
        return exc
