"""The experiment's plots: every group drawn at its own place (exp3's LLM rows included)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from llmland.experiment import plots

EXP3_LLMS = ("SmolLM2-135M-Instruct (measured)", "Llama-3.2-1B-Instruct (latency replay)",
             "Qwen2.5-1.5B-R1-Distilled (latency replay)", "Qwen2.5-3B (latency replay)")


def _drawn(monkeypatch: pytest.MonkeyPatch) -> list[Any]:
    figures: list[Any] = []
    monkeypatch.setattr(plots.plt, "close", figures.append)
    return figures


def test_exp3_summary_rows_are_drawn_apart(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """summary.json names exp3's LLM row ``llm`` (trials.csv ``variant``): every row was drawn at
    one x, so success.png showed a single bar, the last row's."""
    summary = {"experiment": "exp3", "rows": [
        {"world": "open_field", "method": "llm-land", "llm": name, "success_rate": 1.0 - 0.02 * k}
        for k, name in enumerate(EXP3_LLMS)]}
    figures = _drawn(monkeypatch)
    plots.success_by_method(summary, tmp_path / "success.png")
    labels = [t.get_text() for t in figures[0].axes[0].get_xticklabels()]
    assert len(set(labels)) == len(EXP3_LLMS), labels
    heights = sorted(round(p.get_height(), 6) for p in figures[0].axes[0].patches)
    assert heights == sorted(round(100 * (1.0 - 0.02 * k), 6) for k in range(len(EXP3_LLMS)))


def test_trial_rows_group_by_variant(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    rows = [{"method": "llm-land", "variant": name, "spec_latency_ms_mean": str(30 + k)}
            for k, name in enumerate(EXP3_LLMS)]
    figures = _drawn(monkeypatch)
    plots.spec_latency(rows, tmp_path / "spec_latency.png")
    labels = [t.get_text() for t in figures[0].axes[0].get_xticklabels()]
    assert len(set(labels)) == len(EXP3_LLMS)
    assert all(t.get_rotation() > 0 for t in figures[0].axes[0].get_xticklabels())  # long names: slanted
    assert (tmp_path / "spec_latency.png").stat().st_size > 5_000


def test_methods_with_the_same_trials_stay_apart_in_closest_person(tmp_path: Path,
                                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    """Two methods with identical closest approaches drew one step line over the other: one method
    vanished from the plot. Each now has its own line style and width, and its legend says how many
    trials it has and its smallest approach."""
    rows = [{"method": m, "closest_person_m": str(d)} for m in ("baseline", "conservative") for d in (1.8, 2.5, 4.0)]
    figures = _drawn(monkeypatch)
    plots.closest_approach(rows, tmp_path / "closest_person.png")
    ax = figures[0].axes[0]
    steps = [p for p in ax.patches]
    assert len(steps) == 2
    assert len({(p.get_linestyle(), p.get_linewidth()) for p in steps}) == 2
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert any("baseline" in t and "n=3" in t and "min 1.80 m" in t for t in labels), labels
    assert any("conservative" in t and "n=3" in t for t in labels), labels
