"""rag asks the LLM only when its answer could change the spec, and then the spec is the same as
if it had asked (real retrieval, MiniLM and WordNet; the LLM's pointer is a seeded fake)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np
import pytest
from llmland_reasoner.evaluation import load_cases
from llmland_reasoner.mention import caption_words, content_positions
from llmland_reasoner.pipeline import Outcome, normalize_caption, retrieve_hits
from llmland_reasoner.rag import finish_rag, run_rag, unanimous_answer
from llmland_reasoner.resources import Resources

#: random pointer answers tried per caption
DRAWS = 4


class RandomPointer:
    """An LLM whose pointer log-probabilities are random (seeded): any answer it could give."""

    name = "random-pointer"

    def __init__(self, seed: int) -> None:
        self.rng = np.random.default_rng(seed)
        self.calls = 0
        self.prefixes: list[str] = []

    def score(self, prefix: str, suffix: str, continuations: Sequence[str],
              first_token_only: bool = False) -> list[float]:
        self.calls += 1
        self.prefixes.append(prefix)
        return [float(x) for x in -self.rng.exponential(3.0, size=len(continuations))]

    def complete(self, prefix: str, suffix: str, grammar: str | None, max_tokens: int, temperature: float) -> str:
        raise AssertionError("rag never generates")


def _care(o: Outcome) -> tuple[bool, float, float, bool | None]:
    return (o.is_dynamic, o.z_min, o.buffer_m, o.is_human)


def _rag(res: Resources, caption: str, llm_when_needed: bool) -> Outcome:
    return run_rag(caption, res, False, "llm", True, None, llm_when_needed)


@pytest.fixture(scope="module")
def with_pointer(resources: Resources) -> Resources:
    return replace(resources, backend=RandomPointer(0))


def test_a_settled_caption_is_answered_without_the_llm_as_any_answer_would(with_pointer: Resources) -> None:
    settled = 0
    for case in load_cases("dev"):
        caption = normalize_caption(case.caption)
        known = unanimous_answer(caption, retrieve_hits(caption, with_pointer), with_pointer)
        if known is None:
            continue
        settled += 1
        quiet = RandomPointer(0)
        assert _care(_rag(replace(with_pointer, backend=quiet), caption, True)) == _care(known)
        assert quiet.calls == 0, caption
        assert not known.asked_llm and known.model.startswith("rules+") and not known.phrase
        for seed in range(DRAWS):  # whatever the LLM says, the same spec
            asked = _rag(replace(with_pointer, backend=RandomPointer(seed)), caption, False)
            assert asked.asked_llm and _care(asked) == _care(known), (caption, seed)
    assert settled >= len(load_cases("dev")) // 2  # the check is not vacuous


def test_a_caption_the_pointer_decides_asks_the_llm(with_pointer: Resources) -> None:
    caption = "a large group of people standing in a square"
    hits = retrieve_hits(caption, with_pointer)
    assert unanimous_answer(caption, hits, with_pointer) is None
    words = caption_words(caption)
    positions = content_positions(words)
    specs = set()
    for k in range(len(positions)):  # the pointer really moves the spec here
        one_hot = [-1.0] * len(positions)
        one_hot[k] = 0.0
        specs.add(_care(finish_rag(caption, hits, one_hot, with_pointer, "llm", True, None)))
    assert len(specs) > 1
    pointer = RandomPointer(1)
    out = _rag(replace(with_pointer, backend=pointer), caption, True)
    assert pointer.calls == 1 and out.asked_llm


def test_a_mention_with_another_reading_always_goes_to_the_llm(with_pointer: Resources) -> None:
    caption = "a white crane flying over the water"
    assert unanimous_answer(caption, retrieve_hits(caption, with_pointer), with_pointer) is None


def test_warm_up_evaluates_the_pointer_prompt_although_the_rules_settle_its_caption(resources: Resources) -> None:
    from llmland_reasoner.extractor import WARM_UP_CAPTION, SpecExtractor
    from llmland_reasoner.prompts import rag_prefix

    pointer = RandomPointer(0)
    caption = normalize_caption(WARM_UP_CAPTION)
    res = replace(resources, backend=pointer)
    assert unanimous_answer(caption, retrieve_hits(caption, res), res) is not None  # what the fix is for
    extractor = SpecExtractor("rag", resources=res)
    try:
        extractor.warm_up()
    finally:
        extractor.close()
    assert pointer.prefixes == [rag_prefix(False)]


class DeadPointer(RandomPointer):
    def score(self, prefix: str, suffix: str, continuations: Sequence[str],
              first_token_only: bool = False) -> list[float]:
        raise RuntimeError("LLM worker died")


def test_warm_up_survives_a_dead_llm(resources: Resources) -> None:
    from llmland_reasoner.extractor import SpecExtractor

    extractor = SpecExtractor("rag", resources=replace(resources, backend=DeadPointer(0)))
    try:
        extractor.warm_up()  # logs; the service still starts
        assert extractor.extract("a man walking past a parked car").source == "rag"  # settled: no LLM
    finally:
        extractor.close()
