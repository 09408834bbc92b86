from __future__ import annotations

import threading
import time
from collections.abc import Sequence
from dataclasses import replace

import pytest
from llmland_reasoner import deadline
from llmland_reasoner.extractor import SpecExtractor
from llmland_reasoner.pipeline import LLM_ONLY_LABEL, normalize_caption
from llmland_reasoner.resources import Resources
from llmland_schemas.messages import CONSERVATIVE_BUFFER_M, SafetySpec


class BrokenBackend:
    name = "broken"

    def complete(self, prefix: str, suffix: str, grammar: str | None, max_tokens: int, temperature: float) -> str:
        raise RuntimeError("model crashed")

    def score(
        self, prefix: str, suffix: str, continuations: Sequence[str], first_token_only: bool = False
    ) -> list[float]:
        raise RuntimeError("model crashed")


class GarbageBackend(BrokenBackend):
    name = "garbage"

    def complete(self, prefix: str, suffix: str, grammar: str | None, max_tokens: int, temperature: float) -> str:
        return "I think it is a person, z_min maybe 3"

    def score(
        self, prefix: str, suffix: str, continuations: Sequence[str], first_token_only: bool = False
    ) -> list[float]:
        return [float("nan")] * len(continuations)


class SlowBackend(BrokenBackend):
    """Answers only once the test releases it (or after 30 s)."""

    name = "slow"

    def __init__(self) -> None:
        self.release = threading.Event()

    def complete(self, prefix: str, suffix: str, grammar: str | None, max_tokens: int, temperature: float) -> str:
        self.release.wait(30.0)
        return 'yes", "z_min": 3.0, "buffer": 3}'


#: a caption only the LLM can read ("crane": the machine or the bird; ``decide.py``)
NEEDS_LLM = "a white crane flying over the water"


@pytest.fixture(scope="module")
def rag(resources: Resources) -> SpecExtractor:
    return SpecExtractor("rag", resources=resources)


@pytest.fixture(scope="module")
def rag_asking(resources: Resources) -> SpecExtractor:
    """rag that asks the LLM for every caption (the paper's flow)."""
    always = resources.settings.model_copy(update={"rag_llm_when_needed": False})
    return SpecExtractor("rag", settings=always, resources=resources)


def test_rag_spec_is_grounded_in_the_kb(rag_asking: SpecExtractor) -> None:
    result = rag_asking.extract_detailed("a man walking on a grass field")
    spec = result.spec
    assert isinstance(spec, SafetySpec)
    assert spec.source == "rag" and spec.is_dynamic and spec.buffer_m == 3.0
    assert spec.label in ("pedestrian", "person")
    assert result.phrase.startswith("man")  # the LLM pointed at the man, not the field
    assert 1 <= len(spec.evidence) <= 3 and spec.evidence[0].kb_id in ("pedestrian", "person")
    assert "SmolLM2" in spec.model and "MiniLM" in spec.model
    assert spec.latency_ms > 0 and spec.caption == "a man walking on a grass field"
    assert result.asked_llm


def test_rag_answers_a_caption_the_rules_settle_without_the_llm(rag: SpecExtractor,
                                                                rag_asking: SpecExtractor) -> None:
    caption = "a man walking past a parked car"
    quick, asked = rag.extract_detailed(caption), rag_asking.extract_detailed(caption)
    assert not quick.asked_llm and quick.spec.model.startswith("rules+") and asked.asked_llm
    fields = ("is_dynamic", "z_min", "buffer_m", "is_human")
    assert quick.spec.model_dump(include=set(fields)) == asked.spec.model_dump(include=set(fields))
    assert quick.spec.is_human and quick.spec.source == "rag"


def test_rag_tells_a_statue_from_a_person(rag: SpecExtractor) -> None:
    spec = rag.extract("a stone statue of a king in a square")
    assert spec.source == "rag" and not spec.is_dynamic and spec.buffer_m == 1.0


def test_retrieval_mode_is_top1(resources: Resources) -> None:
    spec = SpecExtractor("retrieval", resources=resources).extract("a yellow school bus")
    assert spec.source == "retrieval" and spec.label == "bus" and spec.buffer_m == 5.0
    assert spec.evidence[0].kb_id == "bus" and len(spec.evidence) == 3


def test_rag_ablation_without_the_llm(resources: Resources) -> None:
    no_llm = resources.settings.model_copy(update={"rag_pointer": "first_word"})
    extractor = SpecExtractor("rag", settings=no_llm, resources=replace(resources, backend=None))
    spec = extractor.extract("a scarecrow in a field")
    assert spec.source == "rag" and spec.model.startswith("first-word") and spec.label == "scarecrow"
    extractor.close()


def test_llm_mode_uses_no_retrieval(resources: Resources) -> None:
    no_retrieval = replace(resources, retriever=None, names=None, embed=None)
    spec = SpecExtractor("llm", resources=no_retrieval).extract("a dog running on a beach")
    # the paper's LLM-only answer names no class: not "unknown", the careful spec's label (a newcomer
    # read "a parked red car" -> "unknown", 1 m as an unknown thing given 1 m)
    assert spec.source == "llm" and spec.evidence == [] and spec.label == LLM_ONLY_LABEL
    assert spec.model.startswith("SmolLM2")


def test_cache_answers_repeats_instantly(rag: SpecExtractor) -> None:
    first = rag.extract_detailed("A  brown cow in a field.")
    again = rag.extract_detailed("a brown cow in a field")  # same after normalisation
    assert not first.cached and again.cached
    assert again.spec.latency_ms < 100.0  # a lookup, not a model call (loose: CI machines are loaded)
    assert again.spec.model_dump(exclude={"latency_ms", "caption"}) == first.spec.model_dump(
        exclude={"latency_ms", "caption"}
    )


@pytest.mark.parametrize("backend", [BrokenBackend(), GarbageBackend()])
def test_model_failure_falls_back_conservatively(resources: Resources, backend: BrokenBackend) -> None:
    broken = replace(resources, backend=backend)
    for mode in ("rag", "llm"):
        for caption in (NEEDS_LLM, "a man walking on a grass field"):
            extractor = SpecExtractor(mode, resources=broken)
            spec = extractor.extract(caption)
            settled = mode == "rag" and caption != NEEDS_LLM  # answered by the rules: the LLM is not asked
            assert spec.source == ("rag" if settled else "fallback"), (mode, caption)
            if not settled:
                assert spec.is_dynamic and spec.buffer_m == CONSERVATIVE_BUFFER_M and spec.caption == caption
                assert extractor.extract_detailed(caption).error  # failures are not cached
            extractor.close()


def test_timeout_falls_back_and_the_late_answer_is_cached(resources: Resources) -> None:
    settings = resources.settings.model_copy(update={"timeout_s": 0.2})
    slow = SlowBackend()
    extractor = SpecExtractor("llm", settings=settings, resources=replace(resources, backend=slow))
    result = extractor.extract_detailed("a person waiting at a bus stop")
    assert not slow.release.is_set()  # answered while the LLM was still busy: the timeout, not the LLM
    assert result.spec.source == "fallback" and "timeout" in result.error
    slow.release.set()
    deadline = time.monotonic() + 10.0
    while not (late := extractor.extract_detailed("a person waiting at a bus stop")).cached:
        assert time.monotonic() < deadline, "the late answer was never cached"
        time.sleep(0.05)
    assert late.spec.source == "llm" and late.spec.buffer_m == 3.0
    extractor.close()


class SleepyBackend(BrokenBackend):
    """Scores every continuation alike, each call taking ``step_s`` (a slow LLM); counts the calls."""

    name = "sleepy"

    def __init__(self, step_s: float) -> None:
        self.step_s, self.calls = step_s, 0

    def score(
        self, prefix: str, suffix: str, continuations: Sequence[str], first_token_only: bool = False
    ) -> list[float]:
        self.calls += 1
        time.sleep(self.step_s)
        return [-1.0] * len(continuations)


def test_work_the_caller_stopped_waiting_for_stops_and_frees_the_worker(resources: Resources) -> None:
    """A long ambiguous caption (every "crane", "seal", "cab", "kite" scored by the LLM) ran on after
    its caller's timeout and held the one worker for minutes: every drone's next caption fell back.
    Now the work stops at its next step once the caller has stopped waiting."""
    settings = resources.settings.model_copy(update={"timeout_s": 0.5, "rag_pointer": "llm"})
    sleepy = SleepyBackend(step_s=0.1)
    extractor = SpecExtractor("rag", settings=settings, resources=replace(resources, backend=sleepy))
    long_caption = " ".join(["a crane, a seal, a cab and a kite"] * 10)  # 90 words, 40 ambiguous mentions
    first = extractor.extract_detailed(long_caption)
    assert first.spec.source == "fallback" and "timeout" in first.error
    started = time.monotonic()
    extractor.extract_detailed("a person waiting at a bus stop")
    assert time.monotonic() - started < 1.5, "the next caption waited behind the abandoned one"
    calls = sleepy.calls
    time.sleep(0.5)
    assert sleepy.calls == calls  # nothing is still scoring the abandoned caption
    extractor.close()


def test_the_work_noticing_the_deadline_first_reads_as_the_same_timeout(resources: Resources) -> None:
    """The caller's wait and the work's own deadline check end at the same ``timeout_s`` and race
    by microseconds: whichever sees it first, the fallback says the same thing (the full suite
    once got "DeadlineExceededError: ..." where the caller's wait says "timeout after ...")."""
    settings = resources.settings.model_copy(update={"timeout_s": 0.5, "rag_pointer": "llm"})
    extractor = SpecExtractor("rag", settings=settings,
                              resources=replace(resources, backend=SleepyBackend(step_s=0.1)))
    caption = " ".join(["a crane, a seal, a cab and a kite"] * 10)
    key = (normalize_caption(caption), resources.kb.version, "rag")
    with deadline.deadline_at(time.monotonic()):  # the caller has just stopped waiting
        result = extractor._compute(key, caption)  # noqa: SLF001 - the worker's side of the race
    assert result.spec.source == "fallback" and result.error == "timeout after 0.5 s"
    extractor.close()


def test_a_caption_longer_than_the_limit_falls_back_at_once(resources: Resources) -> None:
    settings = resources.settings.model_copy(update={"max_caption_words": 10})
    extractor = SpecExtractor("rag", settings=settings, resources=resources)
    started = time.monotonic()
    for result in (extractor.extract_detailed("a person " * 6), *extractor.extract_many(["a dog " * 6]),
                   extractor.extract_detailed("/".join(["crane", "seal", "cab"] * 4))):  # 12 tokens, 1 "word"
        assert result.spec.source == "fallback" and "max_caption_words" in result.error
    assert time.monotonic() - started < 0.5
    assert extractor.extract("a person walking on a road").source == "rag"
    extractor.close()


@pytest.mark.parametrize("caption", ["🐕", "狗", "🐕 🚗"])
def test_a_caption_with_no_word_read_falls_back_with_a_plain_reason(rag: SpecExtractor, caption: str) -> None:
    """Was: the careful spec, but its reason the LLM scorer's internal error ("ValueError: one
    log-probability per candidate position is needed"), sent back to an HTTP client."""
    result = rag.extract_detailed(caption)
    assert result.spec.source == "fallback" and result.spec.buffer_m >= 5.0
    assert "no word the reasoner reads" in result.error and "ValueError" not in result.error


@pytest.mark.parametrize("caption", ["", "   ", "...", None, 42])
def test_bad_captions_never_raise(rag: SpecExtractor, caption: object) -> None:
    spec = rag.extract(caption)  # type: ignore[arg-type]
    assert isinstance(spec, SafetySpec)
    if caption in ("", "   ", "...", None):
        assert spec.source == "fallback"


def test_kb_extension_changes_the_cache_key(
    resources: Resources, tmp_path: object, robot_mower: dict[str, object]
) -> None:
    own = Resources.load(resources.settings, retrieval=True, llm=False)
    extractor = SpecExtractor("retrieval", resources=own)
    assert extractor.extract("a robotic mower on a lawn").label != "robot lawn mower"
    extractor.add_entry(
        robot_mower,
        save_to=f"{tmp_path}/kb.json",
    )
    spec = extractor.extract("a robotic mower on a lawn")
    assert spec.label == "robot lawn mower" and spec.is_dynamic and spec.buffer_m == 5.0
    extractor.close()


def test_captions_are_answered_while_a_kb_write_builds_its_index(
    resources: Resources, tmp_path: object, robot_mower: dict[str, object], monkeypatch: pytest.MonkeyPatch
) -> None:
    """A KB write builds the new index beside the extraction worker, not on it: while the build
    is held (here until the test lets it go), captions are answered with the KB in use (its
    version); then the new KB is in use. Was: the rebuild ran on the worker and every spec of
    every drone waited for it (3.5 s quiet, ≈ 10 s beside flights)."""
    from concurrent.futures import ThreadPoolExecutor

    own = Resources.load(resources.settings, retrieval=True, llm=False)
    extractor = SpecExtractor("retrieval", resources=own)
    before = own.kb.version
    building, release = threading.Event(), threading.Event()
    build_for = own.build_for

    def held_build(kb: object) -> object:
        building.set()
        release.wait()
        return build_for(kb)  # type: ignore[arg-type]

    monkeypatch.setattr(own, "build_for", held_build)
    with ThreadPoolExecutor(max_workers=2) as pool:
        write = pool.submit(extractor.add_entry, robot_mower, save_to=f"{tmp_path}/kb.json")
        try:
            assert building.wait(timeout=60)
            # the build is held until the end of this block: an answer waiting for it never comes
            result = pool.submit(extractor.extract_detailed, "a robotic mower on a lawn").result(timeout=60)
            assert not write.done() and own.kb.version == before
            assert result.spec.label != "robot lawn mower" and not result.error
        finally:
            release.set()
        write.result(timeout=120)
    assert own.kb.version != before
    assert extractor.extract("a robotic mower on a lawn").label == "robot lawn mower"
    extractor.close()


def test_an_invalid_kb_write_changes_nothing(resources: Resources, robot_mower: dict[str, object]) -> None:
    """A write refused (an existing id, ``replace=False``) leaves the KB in use and its index as
    they were."""
    from llmland_reasoner.kb import KbEntryExistsError

    own = Resources.load(resources.settings, retrieval=True, llm=False)
    extractor = SpecExtractor("retrieval", resources=own)
    kb, retriever = own.kb, own.retriever
    with pytest.raises(KbEntryExistsError):
        extractor.add_entry({**robot_mower, "id": "person"}, replace=False)
    assert own.kb is kb and own.retriever is retriever
    extractor.close()


def test_an_accented_caption_is_its_plain_spelling(rag: SpecExtractor) -> None:
    """"a fiancée walking a dog" was read as "fianc" + "e" (an unknown thing, 5 m) beside the dog;
    folded, it is the plain spelling's caption: the same cache entry, a person's spec."""
    accented = rag.extract_detailed("A fiancée walking a dog")
    plain = rag.extract_detailed("a fiancee walking a dog")
    assert plain.cached and plain.spec.label == accented.spec.label
    assert accented.spec.is_human and accented.spec.buffer_m == 3.0


def test_no_extraction_in_any_mode_straddles_a_kb_swap(
    resources: Resources, tmp_path: object, robot_mower: dict[str, object], monkeypatch: pytest.MonkeyPatch
) -> None:
    """A KB write through the engine puts the new KB in use only between two extractions of every
    mode: an extraction of another mode in progress when the new index is ready ends with the KB
    it began with (it read the new KB's mention finder with the old KB's retriever before: a
    review's script). Here that extraction is held inside its retrieval until the write has
    built its index; the swap waits for it."""
    from concurrent.futures import ThreadPoolExecutor

    from llmland_reasoner import retrieval
    from llmland_reasoner.engine import ReasonerEngine
    from llmland_reasoner.kb import KbEntry

    own = Resources.load(resources.settings, retrieval=True, llm=False)
    settings = own.settings.model_copy(update={"mode": "retrieval", "kb_path": f"{tmp_path}/kb.json",
                                               "rag_pointer": "retrieval"})
    engine = ReasonerEngine(settings, own)
    rag = engine.extractor("rag")
    before = own.kb.version
    entered, release, built, installed = threading.Event(), threading.Event(), threading.Event(), threading.Event()
    seen: dict[str, str] = {}
    retrieve = retrieval.Retriever.retrieve

    def held(self: retrieval.Retriever, *args: object, **kwargs: object) -> object:
        out = retrieve(self, *args, **kwargs)  # type: ignore[arg-type]
        if threading.current_thread().name.startswith("reasoner-rag") and not entered.is_set():
            seen["retriever"] = self.kb.version
            entered.set()
            release.wait()
            seen["after"] = own.kb.version  # the KB the rest of this extraction reads
        return out

    install, build_for = own.install, own.build_for

    def noted_build(kb: object) -> object:
        parts = build_for(kb)  # type: ignore[arg-type]
        built.set()
        return parts

    def noted_install(parts: object) -> None:
        install(parts)  # type: ignore[arg-type]
        installed.set()

    monkeypatch.setattr(retrieval.Retriever, "retrieve", held)
    monkeypatch.setattr(own, "install", noted_install)
    monkeypatch.setattr(own, "build_for", noted_build)
    with ThreadPoolExecutor(max_workers=2) as pool:
        held_extraction = pool.submit(rag.extract_detailed, "a robotic mower on a lawn")
        try:
            assert entered.wait(timeout=60)
            write = pool.submit(engine.add_entry, KbEntry.model_validate(robot_mower))
            assert built.wait(timeout=120)
            assert not installed.wait(timeout=3)  # ms after the build before; now not while rag runs
        finally:
            release.set()
        held_extraction.result(timeout=60)
        write.result(timeout=120)
    assert seen == {"retriever": before, "after": before}
    assert installed.is_set() and own.kb.version != before
    assert engine.extract("a robotic mower on a lawn", "rag").label == "robot lawn mower"
    engine.close()
