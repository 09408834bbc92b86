"""Regression guard on the held-out caption set: LLM-Land (rag) must stay >= 95% right.

The baselines are measured and reported, with no bound (the LLM-MPC baseline is expected
to be poor: that is the paper's point). Run with ``-s`` to see the figures.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

from llmland_reasoner import prompts
from llmland_reasoner.evaluation import EvalReport, evaluate, load_cases
from llmland_reasoner.resources import Resources


def _summary(report: EvalReport, name: str = "") -> str:
    return (
        f"{name or report.mode}: both {report.acc_both:.3f}"
        f" (dynamic {report.acc_dynamic:.3f}, buffer {report.acc_buffer:.3f}) on {report.n};"
        f" cold p50 {report.latency_cold_ms['p50']} ms, cpu p50 {report.cpu_cold_ms['p50']} ms"
    )


def test_eval_set_is_large_and_covers_every_group() -> None:
    cases = load_cases("eval")
    assert len(cases) >= 80
    assert {c.buffer_class for c in cases} == {"ground", "static", "person", "animal", "vehicle"}
    dev = {c.caption for c in load_cases("dev")}
    assert not dev & {c.caption for c in cases}  # tuning set and held-out set are disjoint
    shots = {c for c, _, _ in prompts.RAG_SHOTS} | {c for c, _ in prompts.PAPER_SHOTS}
    assert not shots & (dev | {c.caption for c in cases})  # no few-shot example is scored


def test_rag_accuracy_lower_bound(resources: Resources, record_property: Callable[[str, object], None]) -> None:
    report = evaluate("rag", "eval", resources=resources)
    record_property("rag", report.model_dump(exclude={"misses"}))
    print(_summary(report))
    assert report.fallbacks == 0
    assert report.acc_both >= 0.95, report.misses


def test_baselines_are_reported(resources: Resources, record_property: Callable[[str, object], None]) -> None:
    retrieval = evaluate("retrieval", "eval", resources=resources)
    llm = evaluate("llm", "eval", resources=resources, stride=12)  # a subset: ~0.5 s a caption
    for name, report in (("retrieval", retrieval), ("llm", llm)):
        record_property(name, report.model_dump(exclude={"misses"}))
        print(_summary(report, name))
        assert 0.0 <= report.acc_both <= 1.0


def test_senses_set_is_sourced_and_apart() -> None:
    cases = load_cases("senses")
    assert len(cases) >= 100 and all(c.source.startswith("github:") and c.reading for c in cases)
    assert {c.split for c in cases} == {"dev", "test"} and sum(c.reading == "other" for c in cases) >= 15
    others = {c.caption.lower() for c in load_cases("dev") + load_cases("eval") + load_cases("public")}
    assert not others & {c.caption.lower() for c in cases}


def test_public_set_is_sourced_and_covers_every_class() -> None:
    cases = load_cases("public")
    assert len(cases) >= 150
    assert all(c.source.startswith("github:") and c.split in ("dev", "eval", "heldout") for c in cases)
    assert {c.kind for c in cases} == {"person", "animal", "vehicle", "static", "ground"}
    own = {c.caption.lower() for c in load_cases("dev") + load_cases("eval")}
    assert not own & {c.caption.lower() for c in cases}  # apart from the project's own sets


def test_public_held_out_split_never_unsafe(
    resources: Resources, record_property: Callable[[str, object], None]
) -> None:
    """Captions real captioners and people wrote: never a moving thing made static or given a
    smaller buffer than its class; accuracy floors at the measured figures (README)."""
    rag = evaluate("rag", "public:heldout", resources=resources)
    retrieval = evaluate("retrieval", "public", resources=resources)
    for name, report in (("rag public:heldout", rag), ("retrieval public", retrieval)):
        record_property(name, report.model_dump(exclude={"misses"}))
        print(_summary(report, name), "unsafe", report.unsafe, report.per_class)
        assert report.unsafe == 0, [m for m in report.misses if m["unsafe"]]
        assert report.fallbacks == 0
    assert rag.acc_both >= 0.90 and rag.per_class["person"]["acc"] >= 0.90, rag.misses
    assert retrieval.acc_both >= 0.95 and retrieval.per_class["person"]["acc"] >= 0.97, retrieval.misses


def test_the_llm_decisions_add_care_on_the_senses_set(
    resources: Resources, record_property: Callable[[str, object], None]
) -> None:
    """The decision the LLM makes in rag (which reading an ambiguous mention has, ``decide.py``),
    on the held-out split of the focused set: measured against retrieval alone (the rules'
    reading) and against rag with retrieval's top-1 in the LLM's place. Not zero by construction:
    the LLM moves mentions off the rules' reading, and finds more of the living and moving ones."""
    rag = evaluate("rag", "senses:test", resources=resources)
    retrieval = evaluate("retrieval", "senses:test", resources=resources)
    no_llm = resources.settings.model_copy(update={"rag_pointer": "retrieval"})
    top1 = evaluate("rag", "senses:test", resources=replace(resources, settings=no_llm), settings=no_llm)
    for name, report in (("rag senses:test", rag), ("retrieval senses:test", retrieval),
                         ("rag_retrieval_top1 senses:test", top1)):
        record_property(name, report.model_dump(exclude={"misses"}))
        print(_summary(report, name), "unsafe", report.unsafe, "decided", report.changed, "of", report.decisions,
              "right", report.decisions_right)
    assert rag.changed > 0 and retrieval.changed == 0
    assert rag.unsafe < min(retrieval.unsafe, top1.unsafe) and rag.decisions_right is not None
    assert retrieval.decisions_right is not None and top1.decisions_right is not None
    assert rag.decisions_right > max(retrieval.decisions_right, top1.decisions_right)


def test_wording_set_is_apart_and_labelled() -> None:
    cases = load_cases("wording")
    assert len(cases) >= 450 and {c.split for c in cases} == {"dev", "heldout", "test"}
    assert {c.kind for c in cases} == {"person", "animal", "vehicle", "static", "ground"}
    others = {c.caption.lower() for name in ("dev", "eval", "public", "senses") for c in load_cases(name)}
    assert not others & {c.caption.lower() for c in cases}
    assert len({c.caption.lower() for c in cases}) == len(cases)


def test_wording_set_floors(resources: Resources, record_property: Callable[[str, object], None]) -> None:
    """Wordings that misled the rules (``data/WORDING.md``): a regression guard at the figures
    measured when the kinds found on ``wording:dev`` were fixed (README)."""
    for split, right, unsafe in (("dev", 149, 13), ("heldout", 108, 11), ("test", 98, 4)):
        report = evaluate("rag", f"wording:{split}", resources=resources)
        record_property(f"rag wording:{split}", report.model_dump(exclude={"misses"}))
        print(_summary(report, f"rag wording:{split}"), "unsafe", report.unsafe)
        assert report.fallbacks == 0
        assert round(report.acc_both * report.n) >= right and report.unsafe <= unsafe, report.misses
