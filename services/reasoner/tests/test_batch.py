"""Batches across drones and captions: the same answers as one by one; an LLM crash ⇒ a fallback
for every caption that asked it, real specs for the captions the rules settle."""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import replace
from typing import Any

import pytest
from llmland_reasoner.bus_service import ReasonerBusService
from llmland_reasoner.engine import ReasonerEngine
from llmland_reasoner.evaluation import load_cases
from llmland_reasoner.extractor import SpecExtractor
from llmland_reasoner.fleet import Pending
from llmland_reasoner.llm_worker import LlmUnavailableError
from llmland_reasoner.mention_cache import MentionCache
from llmland_reasoner.resources import Resources
from llmland_schemas import Caption, SafetySpec, SafetySpecMessage, SceneDescription, SceneObject

#: every 6th caption of the held-out set, and the senses captions whose readings the LLM decides
STRIDE = 6


def _captions() -> list[str]:
    own = [c.caption for c in load_cases("eval")][::STRIDE]
    senses = [c.caption for c in load_cases("senses:dev")][:6]
    return [*own, *senses, own[0], own[0].upper() + "."]  # repeats: computed once, answered for each


def _fresh(resources: Resources, cache: bool) -> Resources:
    mentions = MentionCache(resources.grounding_settings_key()) if cache else None
    return replace(resources, mention_cache=mentions)


def _same(a: SafetySpec, b: SafetySpec) -> None:
    assert (a.is_dynamic, a.z_min, a.buffer_m, a.label, a.is_human, a.source, a.model) == \
        (b.is_dynamic, b.z_min, b.buffer_m, b.label, b.is_human, b.source, b.model), a.caption
    assert [e.kb_id for e in a.evidence] == [e.kb_id for e in b.evidence], a.caption
    assert [e.score for e in a.evidence] == pytest.approx([e.score for e in b.evidence], abs=2e-4)
    assert a.mentions == b.mentions, a.caption
    assert a.caption == b.caption


@pytest.mark.parametrize(("mode", "llm_when_needed"), [("rag", True), ("rag", False), ("retrieval", True)])
def test_batched_answers_equal_one_by_one_answers(resources: Resources, mode: str, llm_when_needed: bool) -> None:
    captions = _captions()
    settings = resources.settings.model_copy(update={"rag_llm_when_needed": llm_when_needed})
    alone = SpecExtractor(mode, settings, _fresh(resources, cache=False))  # type: ignore[arg-type]
    one_by_one = [alone.extract(c) for c in captions]
    batched = SpecExtractor(mode, settings, _fresh(resources, cache=True))  # type: ignore[arg-type]
    together = [x.spec for x in batched.extract_many(captions)]
    assert len(together) == len(captions)
    for a, b in zip(together, one_by_one, strict=True):
        assert a.source != "fallback", a.reason
        _same(a, b)
    again = batched.extract_many(captions)  # now every caption is a cache hit
    assert all(x.cached for x in again)
    cached = batched.cached(captions)
    assert cached is not None and [x.spec.label for x in cached] == [s.label for s in one_by_one]


class CrashingBackend:
    """An LLM worker that dies during the batch."""

    name = "crashing"

    def __init__(self) -> None:
        self.batches: list[int] = []

    def score(self, prefix: str, suffix: str, continuations: Sequence[str],
              first_token_only: bool = False) -> list[float]:
        raise LlmUnavailableError("LLM worker died (killed by signal 9) during score")

    def score_many(self, requests: Sequence[Any]) -> list[list[float]]:
        self.batches.append(len(requests))
        raise LlmUnavailableError("LLM worker died (killed by signal 9) during score_many")

    def complete(self, prefix: str, suffix: str, grammar: str | None, max_tokens: int, temperature: float) -> str:
        raise LlmUnavailableError("LLM worker died")


class FakeBus:
    def __init__(self) -> None:
        self.sent: list[tuple[str, SafetySpecMessage]] = []

    def subscribe(self, *args: Any) -> None:
        pass

    def queryable(self, *args: Any) -> None:
        pass

    def publish(self, k: str, msg: SafetySpecMessage) -> None:
        self.sent.append((k, msg))


#: a caption whose spec no answer of the LLM can change (a moving tractor wins, whatever it points
#: at), and one the LLM must read ("crane": the machine or the bird, ``decide.py``)
SETTLED = "a {colour} tractor number {n} next to a barn"
NEEDS_LLM = "a white crane number {n} flying over the {colour} water"


def _scene(drone: str, n: int) -> SceneDescription:
    colour = ["red", "blue", "green"][n % 3]  # never cached
    settled, needs_llm = SETTLED.format(colour=colour, n=n), NEEDS_LLM.format(colour=colour, n=n)
    return SceneDescription(drone_id=drone, stamp=1.0, seq=n, caption=Caption(text=settled, backend="t"),
                            objects=[SceneObject(obj_id="b0", caption=Caption(text=needs_llm, backend="t"),
                                                 centroid_m=(1.0, 0.0, 0.5), size_m=(1.0, 1.0, 1.0))])


def _serve_with_a_dead_llm(resources: Resources, llm_when_needed: bool) -> tuple[CrashingBackend, FakeBus,
                                                                                 ReasonerEngine, list[str]]:
    backend = CrashingBackend()
    res = replace(_fresh(resources, cache=True), backend=backend)
    settings = resources.settings.model_copy(update={"mode": "rag", "rag_llm_when_needed": llm_when_needed})
    engine = ReasonerEngine(settings, res)
    bus = FakeBus()
    service = ReasonerBusService(engine, bus)  # type: ignore[arg-type]
    drones = [f"d{i}" for i in range(4)]
    try:
        now = time.perf_counter()
        service._serve([Pending(d, _scene(d, i), now) for i, d in enumerate(drones)])
    finally:
        service.close()
    assert sorted(m.drone_id for _, m in bus.sent) == drones
    return backend, bus, engine, drones


def _is_fallback(spec: SafetySpec) -> bool:
    return spec.source == "fallback" and spec.is_dynamic and "LlmUnavailableError" in (spec.reason or "")


def test_worker_crash_during_a_batch_gives_every_drone_a_fallback(resources: Resources) -> None:
    backend, bus, engine, _ = _serve_with_a_dead_llm(resources, llm_when_needed=False)
    assert backend.batches == [8]  # one LLM request for the whole batch: 4 drones x 2 captions
    for _, msg in bus.sent:
        assert all(_is_fallback(spec) for spec in [msg.scene, *[o.spec for o in msg.objects]])
    assert engine.cached_specs([_scene("d0", 0).caption.text]) is None  # a fallback is never cached


def test_worker_crash_spares_the_captions_the_rules_settle(resources: Resources) -> None:
    backend, bus, engine, _ = _serve_with_a_dead_llm(resources, llm_when_needed=True)
    assert backend.batches == [4]  # only the cranes asked the LLM
    for _, msg in bus.sent:
        assert _is_fallback(msg.objects[0].spec)
        settled = msg.scene
        assert settled.source == "rag" and settled.is_dynamic and settled.label != "unknown"
        assert settled.model.startswith("rules+")
    assert engine.cached_specs([_scene("d0", 0).caption.text]) is not None  # a real spec is cached
