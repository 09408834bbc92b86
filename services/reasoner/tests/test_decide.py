"""The LLM's decision in rag: which reading an ambiguous mention has (decide.py); is_human."""

from __future__ import annotations

import subprocess
import time
from collections.abc import Iterator, Sequence
from dataclasses import replace
from typing import Literal

import pytest
from llmland_reasoner.decide import LlmDecider
from llmland_reasoner.evaluation import load_cases, peak_rss_mb
from llmland_reasoner.extractor import SpecExtractor
from llmland_reasoner.resources import Resources
from llmland_reasoner.safety import CAREFUL, Alternative, Grounded, Numbers, dominates, ground_mentions
from llmland_schemas.messages import SafetySpec

HAS_IS_HUMAN = "is_human" in SafetySpec.model_fields


@pytest.fixture(scope="module")
def rag(resources: Resources) -> Iterator[SpecExtractor]:
    ex = SpecExtractor("rag", resources=resources)
    yield ex
    ex.close()


def _grounded(resources: Resources, caption: str) -> list[Grounded]:
    assert resources.finder is not None and resources.names is not None
    return ground_mentions(caption, resources.finder.find(caption), resources.kb, resources.names, resources.wordnet)


def test_a_thing_with_a_living_sense_has_another_reading(resources: Resources) -> None:
    crane = _grounded(resources, "a crane over the water")[0]
    assert crane.numbers.category == "structure" and crane.plain == ("device",)
    assert [(a.word_class, a.plain) for a in crane.alternatives] == [("animal", ("bird",))]
    assert crane.alternatives[0].numbers.is_dynamic and crane.alternatives[0].numbers.buffer_m >= 4.0
    cab = _grounded(resources, "a yellow cab on the street")
    assert any(a.word_class == "vehicle" for g in cab for a in g.alternatives)


@pytest.mark.parametrize("caption", [
    "a man walking a dog", "a parked car", "a bicycle leaning on a wall", "a tall tower",
    "a large sheep bends his head",
])
def test_settled_or_unambiguous_mentions_have_no_other_reading(resources: Resources, caption: str) -> None:
    """People, animals, vehicles are settled; a bicycle's vehicle reading is the rider rule's; a
    "tower" is not a tugboat (its first name is "tugboat"); a person's reading is never offered."""
    for g in _grounded(resources, caption):
        assert all(a.word_class in ("animal", "vehicle") for a in g.alternatives)
        if g.numbers.category in ("person", "animal", "vehicle") or g.found.text in ("bicycle", "tower"):
            assert not g.alternatives, g


def test_a_compound_is_read_as_a_whole(resources: Resources) -> None:
    """"storage tanks" are containers (was: offered the army tank, the head's sense); a bare "tank"
    is a vehicle by the rules (its common senses include the army's)."""
    tanks = [g for g in _grounded(resources, "several storage tanks are surrounded by bare land")
             if "tank" in g.found.text]
    assert tanks and not any(g.alternatives for g in tanks)
    assert [g.numbers.category for g in _grounded(resources, "a tank on a dirt road")][0] == "vehicle"


def test_another_reading_may_only_add_care() -> None:
    static = Numbers("crane", "crane", "structure", False, False, 45.0, 1.0)
    bird = Numbers("flock of birds", "bird_flock", "animal", True, False, 10.0, 4.0)
    person = Numbers("person", "person", "person", True, True, 3.0, 3.0)
    assert dominates(bird, static) and not dominates(static, bird)
    assert not dominates(bird, person) and not dominates(person, bird)  # a person never loses is_human
    assert not dominates(bird, bird) and dominates(CAREFUL, static)


class _AlwaysOther:
    """A decider that takes every other reading (the worst an LLM could do for accuracy)."""

    name = "llm"
    source: Literal["llm", "retrieval"] = "llm"

    def decide(self, caption: str, grounded: Sequence[Grounded]) -> list[Alternative | None]:
        return [g.alternatives[-1] if g.alternatives else None for g in grounded]


def test_no_decision_ever_makes_a_spec_less_careful(resources: Resources) -> None:
    """Whatever the decider answers, the spec is at least as careful as the rules' own."""
    from llmland_reasoner.pipeline import Outcome, most_careful_of_mentions

    entry = resources.kb.get("grass_field")
    answer = Outcome.from_entry(entry, "test", [])
    captions = ["the dump truck and the crane are working", *[c.caption.lower() for c in load_cases("senses")[::3]]]
    for caption in captions:  # the first: a bird (4 m) would beat the truck (5 m) by the living-first order
        rules = most_careful_of_mentions(caption, answer, entry, "retrieval", resources)
        worst = most_careful_of_mentions(caption, answer, entry, "llm", resources, decider=_AlwaysOther())
        assert worst.is_dynamic >= rules.is_dynamic and worst.buffer_m >= rules.buffer_m, caption
        assert bool(worst.is_human) >= bool(rules.is_human), caption


def test_the_llm_reads_the_caption_around_the_word(resources: Resources) -> None:
    """Calibrated: the same word, opposite contexts, opposite margins (SmolLM2-135M, greedy)."""
    assert resources.backend is not None and resources.wordnet is not None
    decider = LlmDecider(resources.backend, resources.wordnet)
    bird = _grounded(resources, "a white crane flying low over the water")[0]
    machine = _grounded(resources, "a crane lifting steel beams at a building site")[0]
    assert decider.margins("a white crane flying low over the water", bird)[0] > decider.margin_nats
    assert decider.margins("a crane lifting steel beams at a building site", machine)[0] < 0.0


def test_rag_decides_retrieval_keeps_the_rules(resources: Resources, rag: SpecExtractor) -> None:
    retrieval = SpecExtractor("retrieval", resources=resources)
    try:
        caption = "a white crane flying low over the water"
        by_llm, by_rules = rag.extract_detailed(caption), retrieval.extract_detailed(caption)
        assert by_llm.decisions == by_rules.decisions == 1 and by_llm.changed == 1 and by_rules.changed == 0
        assert by_llm.spec.is_dynamic and by_llm.spec.buffer_m >= 4.0 and not by_rules.spec.is_dynamic
        assert any(m.source == "llm" and m.text == "crane" for m in by_llm.spec.mentions)
    finally:
        retrieval.close()


@pytest.mark.parametrize(("caption", "human"), [
    ("a man walking across a field", True),
    ("a dog lying on a porch", False),
    ("a large green field", False),
    ("a tree and a child", True),
    ("a quokka on a rock", None),  # an unknown noun: no KB entry says
])
def test_is_human_comes_from_the_grounded_entry(resources: Resources, caption: str, human: bool | None) -> None:
    for mode in ("rag", "retrieval"):
        ex = SpecExtractor(mode, resources=resources)  # type: ignore[arg-type]
        try:
            got = ex.extract_detailed(caption)
            assert got.is_human is human, (mode, got.spec)
            if HAS_IS_HUMAN:
                assert got.spec.model_dump()["is_human"] is human
        finally:
            ex.close()


def test_is_human_is_unknown_without_a_kb(resources: Resources) -> None:
    llm = SpecExtractor("llm", resources=resources)
    broken = SpecExtractor("retrieval", resources=replace(resources, retriever=None))
    try:
        for got in (llm.extract_detailed("a man walking across a field"), broken.extract_detailed("a man")):
            assert got.is_human is None
            if HAS_IS_HUMAN:
                assert got.spec.model_dump()["is_human"] is None
        assert broken.extract_detailed("a man").spec.source == "fallback"
    finally:
        llm.close()
        broken.close()


def test_peak_memory_counts_child_processes() -> None:
    """The LLM runs in a worker process by default: its peak memory is the reasoner's too."""
    child = subprocess.Popen(["python3", "-c", "b = bytearray(64 * 2**20); import time; time.sleep(30)"])
    try:
        time.sleep(1.0)
        parts = peak_rss_mb()
        assert any(k.endswith(f":{child.pid}") and v >= 60.0 for k, v in parts.items()), parts
        assert parts["reasoner"] > 0.0
    finally:
        child.kill()
        child.wait()
