"""Caption -> SafetySpec, in one of three modes (DESIGN §5).

- ``rag`` (LLM-Land): hybrid retrieval proposes the top-3 KB entries; the LLM points at the
  obstacle's mention in the caption (``mention.py``: one forward pass, no generation); the
  retrieved entry that the mention names supplies ``is_dynamic``, ``z_min`` and
  ``buffer_m`` (``grounding.py``).
- ``llm`` (the LLM-MPC baseline): the same LLM, the paper's typed prompt, no retrieval;
  the numbers are whatever the model writes (JSON forced by grammar).
- ``retrieval``: the top-1 retrieved KB entry, no LLM.

Specs are cached by (normalised caption, KB version, mode). Any failure — timeout, model
error, unparseable output, empty caption — gives ``SafetySpec.conservative`` with source
``"fallback"``; :meth:`SpecExtractor.extract` never raises. All of a caption's model work runs
on one worker thread, so a slow call cannot block the caller beyond ``timeout_s`` (a KB write
embeds its entries on the writer's thread and only swaps the new KB in on the worker). The work goes on
only to its next step (:mod:`.deadline`: the mention loops, before an LLM call); a result that
was already past its last step (one LLM call in ``llm`` mode) still lands in the cache. A caption
longer than ``max_caption_words`` tokens is answered with the fallback at once.
"""

from __future__ import annotations

import logging
import threading
import time
from collections import OrderedDict
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ThreadPoolExecutor
from concurrent.futures import TimeoutError as FutureTimeout
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, ParamSpec, TypeVar

from llmland_schemas.messages import Evidence, SafetySpec

from . import deadline
from .batch import run_many
from .decide import Decider, LlmDecider
from .kb import KbEntry
from .mention import caption_words
from .pipeline import Outcome, normalize_caption, run_llm, run_retrieval
from .rag import rag_decider, run_rag, warm_pointer
from .resources import Resources
from .settings import Mode, ReasonerSettings

log = logging.getLogger(__name__)

_P = ParamSpec("_P")
_R = TypeVar("_R")

#: what :meth:`SpecExtractor.warm_up` asks about
WARM_UP_CAPTION = "a person standing on a grass field"
#: (normalised caption, KB version, mode): what a cached spec depends on
CacheKey = tuple[str, str, str]


@dataclass(frozen=True)
class Extraction:
    """A spec plus how it was made (for evaluation and logs)."""

    spec: SafetySpec
    cached: bool = False
    phrase: str = ""  # rag: the obstacle mention the LLM pointed at
    retrieval_top1: str = ""  # kb id retrieval alone would have chosen
    error: str = ""
    #: a person, not one, or unknown (None): what ``SafetySpec.is_human`` says where the schema has it
    is_human: bool | None = None
    decisions: int = 0  # mentions with another reading to decide (rag: the LLM's decisions)
    changed: int = 0  # of those, how many the decider moved off the rules' reading
    asked_llm: bool = False  # rag: whether the LLM's pointer was asked (``rag.py``)


class SpecExtractor:
    """Turns captions into safety specs; thread-safe; never raises from :meth:`extract`."""

    def __init__(
        self,
        mode: Mode = "rag",
        settings: ReasonerSettings | None = None,
        resources: Resources | None = None,
    ) -> None:
        self.mode: Mode = mode
        self.settings = settings or (resources.settings if resources else ReasonerSettings())
        needs_llm = mode == "llm" or (mode == "rag" and self.settings.rag_pointer == "llm")
        self.resources = resources or Resources.load(self.settings, retrieval=mode != "llm", llm=needs_llm)
        self._cache: OrderedDict[CacheKey, Extraction] = OrderedDict()
        self._cache_lock = threading.Lock()
        self._worker = ThreadPoolExecutor(max_workers=1, thread_name_prefix=f"reasoner-{mode}")
        self._llm_decider: LlmDecider | None = None  # kept: it caches the calibration scores

    # ------------------------------------------------------------------ public
    def extract(self, caption: str) -> SafetySpec:
        return self.extract_detailed(caption).spec

    def extract_detailed(self, caption: str) -> Extraction:
        started = time.perf_counter()
        if not isinstance(caption, str):
            return self._fallback("", started, f"caption must be a string, not {type(caption).__name__}")
        try:
            key = (normalize_caption(caption), self.resources.kb.version, self.mode)
            hit = self._cache_get(key)
            if hit is not None:
                spec = hit.spec.model_copy(update={"caption": caption, "latency_ms": _ms(started)})
                return replace(hit, spec=spec, cached=True)
            if not key[0]:
                raise ValueError("empty caption")
            if (refused := self._refused(key[0])) is not None:
                return self._fallback(caption, started, refused)
            future = self._worker.submit(self._under_deadline(self._compute), key, caption)
            return future.result(timeout=self.settings.timeout_s)
        except Exception as exc:  # noqa: BLE001 - the contract is: never raise, fall back
            return self._fallback(caption, started, self._error_text(exc))

    def extract_many(self, captions: Sequence[str]) -> list[Extraction]:
        """:meth:`extract_detailed` for several captions at once (``batch.py``): cache hits
        answered at once, the rest (each distinct caption once) computed as one batch within
        ``timeout_s``; any failure gives that caption, or every caption of a failed shared
        step, the conservative fallback. Never raises."""
        started = time.perf_counter()
        out: list[Extraction | None] = [None] * len(captions)
        todo: dict[CacheKey, list[int]] = {}
        for i, caption in enumerate(captions):
            if not isinstance(caption, str):
                out[i] = self._fallback("", started, f"caption must be a string, not {type(caption).__name__}")
                continue
            key: CacheKey = (normalize_caption(caption), self.resources.kb.version, self.mode)
            hit = self._cache_get(key)
            if hit is not None:
                out[i] = replace(hit, spec=hit.spec.model_copy(update={"caption": caption, "latency_ms": _ms(started)}),
                                 cached=True)
            elif not key[0]:
                out[i] = self._fallback(caption, started, "ValueError: empty caption")
            elif (refused := self._refused(key[0])) is not None:
                out[i] = self._fallback(caption, started, refused)
            else:
                todo.setdefault(key, []).append(i)
        if todo:
            keys = list(todo)
            first = [str(captions[todo[k][0]]) for k in keys]
            try:
                done = self._worker.submit(self._under_deadline(self._compute_many), keys, first).result(
                    timeout=self.settings.timeout_s)
            except Exception as exc:  # noqa: BLE001 - the contract is: never raise, fall back
                done = [self._fallback(c, started, self._error_text(exc)) for c in first]
            for key, result in zip(keys, done, strict=True):
                for i in todo[key]:
                    spec = result.spec.model_copy(update={"caption": captions[i], "latency_ms": _ms(started)})
                    out[i] = replace(result, spec=spec)
        return [x for x in out if x is not None]

    def cached(self, captions: Sequence[str]) -> list[Extraction] | None:
        """Every caption's spec from the cache, or None when one is not there (no model work)."""
        started = time.perf_counter()
        out: list[Extraction] = []
        for caption in captions:
            key = (normalize_caption(caption), self.resources.kb.version, self.mode)
            hit = self._cache_get(key)
            if hit is None:
                return None
            spec = hit.spec.model_copy(update={"caption": caption, "latency_ms": _ms(started)})
            out.append(replace(hit, spec=spec, cached=True))
        return out

    def warm_up(self) -> None:
        """Load what a first call would (the fixed prompt prefix evaluated once, so the first
        real call pays only its suffix; rag asks the LLM itself, since the rules settle the
        warm-up caption)."""
        self.extract_detailed(WARM_UP_CAPTION)
        if self.mode == "rag" and self.settings.rag_pointer == "llm" and self.resources.backend is not None:
            try:
                self._worker.submit(warm_pointer, WARM_UP_CAPTION, self.resources,
                                    self.settings.rag_context_in_prompt).result()
            except Exception as exc:  # noqa: BLE001 - like any call: the first caption that needs it pays
                log.warning("LLM warm-up failed: %s", exc)
        self.clear_cache()

    def add_entry(self, entry: KbEntry | dict[str, object], save_to: str | Path | None = None,
                  *, replace: bool = True) -> KbEntry:
        """Add a KB entry (validated, version bumped) and rebuild the index, on the calling thread
        while captions go on being answered with the KB in use (the rebuild embeds every entry:
        3.5 s on a quiet 2-core machine, up to ≈ 10 s beside flights, and it held every spec of
        every drone back as long when it ran on this extractor's worker); the new KB is then put
        in use between two extractions. One write at a time (``Resources.write_lock``), so two
        concurrent adds of one id cannot both succeed (``replace=False``:
        :class:`~.kb.KbEntryExistsError` for an existing id). Other extractors sharing the
        resources: :meth:`.engine.ReasonerEngine.add_entry` pauses them all."""
        return add_entry_paused(self.resources, [self], entry, save_to, replace=replace)

    @contextmanager
    def paused(self) -> Iterator[None]:
        """Hold this extractor's worker between two extractions (after the one in progress, if
        any) for the block: a KB swap no extraction of this mode straddles."""
        parked, release = threading.Event(), threading.Event()

        def park() -> None:
            parked.set()
            release.wait()

        self._worker.submit(park)
        try:
            parked.wait()
            yield
        finally:
            release.set()

    def clear_cache(self) -> None:
        """Forget cached specs and grounded mentions (after a KB write)."""
        with self._cache_lock:
            self._cache.clear()
        if self.resources.mention_cache is not None:
            self.resources.mention_cache.clear()

    def close(self) -> None:
        self._worker.shutdown(wait=True, cancel_futures=True)

    # ---------------------------------------------------------------- internal
    def _refused(self, normalized: str) -> str | None:
        """Why a caption is refused before any work, or None: no word the pipeline reads (only
        emoji or another script: "🐕", "狗"; the LLM's scoring failed on them and its internal
        error was the reason sent back), or too long (its cost grows with its length)."""
        words = len(caption_words(normalized))  # the tokens the pipeline works on ("a/b/c" is three)
        if not words:
            return "the caption has no word the reasoner reads (letters a-z or digits)"
        limit = self.settings.max_caption_words
        return None if words <= limit else f"caption of {words} words is longer than max_caption_words ({limit})"

    def _under_deadline(self, job: Callable[_P, _R]) -> Callable[_P, _R]:
        """``job`` run on the worker under the caller's deadline (:mod:`.deadline`): taken now,
        when the caller starts waiting ``timeout_s``, so work the caller no longer waits for stops
        at the next check instead of holding the worker for everyone else."""
        at = time.monotonic() + self.settings.timeout_s

        def run(*args: _P.args, **kwargs: _P.kwargs) -> _R:
            with deadline.deadline_at(at):
                deadline.check()  # it waited in the queue past its caller's time: nothing to do
                return job(*args, **kwargs)

        return run

    def _compute(self, key: CacheKey, caption: str) -> Extraction:
        started = time.perf_counter()
        try:
            outcome = self._run(key[0])
        except Exception as exc:  # noqa: BLE001
            log.warning("spec extraction failed (%s) for %r: %s", self.mode, caption, exc)
            return self._fallback(caption, started, self._error_text(exc))
        return self._finish(key, caption, outcome, started)

    def _compute_many(self, keys: list[CacheKey], captions: list[str]) -> list[Extraction]:
        started = time.perf_counter()
        outcomes = run_many(self.mode, [k[0] for k in keys], self.resources, self.settings, self._decider())
        out: list[Extraction] = []
        for key, caption, outcome in zip(keys, captions, outcomes, strict=True):
            if isinstance(outcome, Exception):
                log.warning("spec extraction failed (%s) for %r: %s", self.mode, caption, outcome)
                out.append(self._fallback(caption, started, self._error_text(outcome)))
            else:
                out.append(self._finish(key, caption, outcome, started))
        return out

    def _finish(self, key: CacheKey, caption: str, outcome: Outcome, started: float) -> Extraction:
        human: dict[str, Any] = {"is_human": outcome.is_human} if _HAS_IS_HUMAN else {}
        spec = SafetySpec(
            **human,
            is_dynamic=outcome.is_dynamic,
            z_min=outcome.z_min,
            buffer_m=outcome.buffer_m,
            label=outcome.label,
            caption=caption,
            evidence=[Evidence(kb_id=kb_id, score=score) for kb_id, score in outcome.evidence],
            source=self.mode,
            model=outcome.model,
            latency_ms=_ms(started),
            mentions=outcome.mentions,
        )
        result = Extraction(spec=spec, phrase=outcome.phrase, retrieval_top1=outcome.retrieval_top1,
                            is_human=outcome.is_human, decisions=outcome.decisions, changed=outcome.changed,
                            asked_llm=outcome.asked_llm)
        self._cache_put(key, result)
        log.debug("spec %s for %r: %s", self.mode, caption, spec.model_dump(exclude={"caption"}))
        return result

    def _decider(self) -> Decider | None:
        if self.mode != "rag":
            return None
        decider = rag_decider(self.resources, self.settings.rag_pointer, self._llm_decider)
        if isinstance(decider, LlmDecider):
            self._llm_decider = decider
        return decider

    def _run(self, caption: str) -> Outcome:
        res, s = self.resources, self.settings
        if self.mode == "retrieval":
            return run_retrieval(caption, res, s.every_mention)
        if self.mode == "llm":
            return run_llm(caption, res, s.max_new_tokens, s.temperature)
        return run_rag(caption, res, s.rag_context_in_prompt, s.rag_pointer, s.every_mention, self._decider(),
                       s.rag_llm_when_needed)

    def _error_text(self, exc: BaseException) -> str:
        """The fallback's reason. The caller's time limit reads the same whichever side saw it
        first: the caller's wait (``FutureTimeout``) or the work's own deadline check
        (:class:`.deadline.DeadlineExceededError`), which race by microseconds at ``timeout_s``."""
        if isinstance(exc, FutureTimeout | deadline.DeadlineExceededError):
            return f"timeout after {self.settings.timeout_s} s"
        return f"{type(exc).__name__}: {exc}"

    def _fallback(self, caption: str, started: float, error: str) -> Extraction:
        log.warning("conservative fallback for %r: %s", caption, error)
        name = self.resources.backend.name if self.resources.backend is not None else ""
        spec = SafetySpec.conservative(caption, model=name, latency_ms=_ms(started), reason=error)
        return Extraction(spec=spec, error=error)

    def _cache_get(self, key: CacheKey) -> Extraction | None:
        with self._cache_lock:
            hit = self._cache.get(key)
            if hit is not None:
                self._cache.move_to_end(key)
            return hit

    def _cache_put(self, key: CacheKey, value: Extraction) -> None:
        if self.settings.cache_size <= 0:
            return
        with self._cache_lock:
            self._cache[key] = value
            self._cache.move_to_end(key)
            while len(self._cache) > self.settings.cache_size:
                self._cache.popitem(last=False)


#: ``SafetySpec.is_human`` (None = unknown: the llm baseline, fallbacks) where the schema has it
_HAS_IS_HUMAN = "is_human" in SafetySpec.model_fields


def _ms(started: float) -> float:
    return round(1e3 * (time.perf_counter() - started), 3)


def add_entry_paused(resources: Resources, extractors: Sequence[SpecExtractor], entry: KbEntry | dict[str, object],
                     save_to: str | Path | None = None, *, replace: bool = True) -> KbEntry:
    """A KB write (:meth:`Resources.prepare_entry`, on the calling thread) put in use while every
    one of ``extractors`` (all those sharing ``resources``) is paused between two extractions,
    so no extraction, in any mode, reads parts of two KB versions."""
    with resources.write_lock:
        added, parts = resources.prepare_entry(entry, save_to, replace=replace)
        if parts is not None:
            with ExitStack() as stack:
                for ex in extractors:
                    stack.enter_context(ex.paused())
                resources.install(parts)
    return added
