"""An experiment's folder from its ``trials.csv``: ``summary.json`` and ``results.md`` (ours beside
the paper's numbers, with the command, seeds, machine and wall time)."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from .plan import PAPER_EXP1, PAPER_EXP2, PAPER_EXP3, PAPER_METHOD_NAMES


def _floats(rows: list[dict[str, str]], col: str) -> list[float]:
    return [float(r[col]) for r in rows if r.get(col) not in (None, "")]


def _round(v: float | None, digits: int = 2) -> float | None:
    return None if v is None or not math.isfinite(v) else round(float(v), digits)


def summarize_group(rows: list[dict[str, str]]) -> dict[str, Any]:
    """Figures of one (world, method[, variant]) group of trial rows."""
    n = len(rows)
    closest = _floats(rows, "closest_person_m")
    landed = [float(r["time_to_land_s"]) for r in rows if r["time_to_land_s"]]
    latency = _floats(rows, "spec_latency_ms_mean")
    return {
        "n": n,
        "success_rate": _round(sum(int(r["success"]) for r in rows) / n, 3) if n else None,
        "close_calls": sum(1 for r in rows if r["close_calls"] not in ("", "0")),
        "collisions": sum(1 for r in rows if r["collisions"]),
        "timeouts": sum(1 for r in rows if r["outcome"] == "timeout"),
        "time_to_land_s_median": _round(float(np.median(landed)), 1) if landed else None,
        "closest_person_m_p5": _round(float(np.percentile(closest, 5)), 2) if closest else None,
        "spec_latency_ms_mean": _round(float(np.mean(latency)), 1) if latency else None,
    }


def summarize(experiment: str, rows: list[dict[str, str]], latency_model: str) -> dict[str, Any]:
    """``summary.json``: one row per world × method (exp3: per world × LLM variant)."""
    groups: dict[tuple[str, str, str], list[dict[str, str]]] = {}
    for r in rows:
        groups.setdefault((r["world"], r["method"], r["variant"]), []).append(r)
    out_rows = []
    for (world, method, variant), g in groups.items():
        row: dict[str, Any] = {"world": world, "method": method}
        if experiment == "exp3":
            row["llm"] = variant
        row.update(summarize_group(g))
        if experiment == "exp3":
            mem = _floats(g, "peak_memory_mb")
            row["peak_memory_mb"] = _round(max(mem), 0) if mem else None
        out_rows.append(row)
    return {"experiment": experiment, "latency_model": latency_model, "rows": out_rows}


def _pct(v: float | None) -> str:
    return "—" if v is None else f"{100 * v:.0f} %"


def _val(v: Any, unit: str = "") -> str:
    return "—" if v is None else f"{v}{unit}"


def _method_table(summary: dict[str, Any], world: str) -> list[str]:
    lines = ["| method | paper | ours | close calls | collisions | time-outs | time to land (median) "
             "| closest person (5th pct) | spec latency (mean) |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in summary["rows"]:
        if r["world"] != world:
            continue
        paper = PAPER_EXP1.get(r["method"]) if summary["experiment"] == "exp1" else \
            PAPER_EXP2.get(r["method"], {}).get(world)
        lines.append(
            f"| {r['method']} ({PAPER_METHOD_NAMES.get(r['method'], '')}) | {_val(paper, ' %')} "
            f"| **{_pct(r['success_rate'])}** ({r['n']}) | {r['close_calls']} | {r['collisions']} | {r['timeouts']} "
            f"| {_val(r['time_to_land_s_median'], ' s')} | {_val(r['closest_person_m_p5'], ' m')} "
            f"| {_val(r['spec_latency_ms_mean'], ' ms')} |")
    return lines


def _exp3_table(summary: dict[str, Any]) -> list[str]:
    lines = ["| LLM | paper latency | our spec latency (mean) | paper peak VRAM "
             "| our peak RAM (reasoner + the LLM it ran) | paper success | our success |",
             "|---|---|---|---|---|---|---|"]
    for r in summary["rows"]:
        name = r["llm"].split(" (")[0]
        lat, vram, succ = PAPER_EXP3.get(name, (None, None, None))
        lines.append(f"| {r['llm']} | {_val(lat, ' ms')} | {_val(r['spec_latency_ms_mean'], ' ms')} "
                     f"| {_val(vram, ' GB')} | {_val(r['peak_memory_mb'], ' MB')} | {_val(succ, ' %')} "
                     f"| **{_pct(r['success_rate'])}** ({r['n']}) |")
    return lines


def results_markdown(summary: dict[str, Any], meta: dict[str, Any]) -> str:
    """``results.md``: the paper's table beside ours, and how it was measured."""
    exp = summary["experiment"]
    lines = [f"# {exp}: results", "",
             f"- command: `{meta['command']}`",
             f"- seeds: {meta['seeds']}; latency model: `{summary['latency_model']}`; {meta['trials']} trials",
             f"- machine: {meta['machine']}; code: {meta.get('code', 'not recorded')}",
             f"- wall time: {meta['wall_time_s'] / 60:.1f} min ({meta['jobs']} job(s))"
             + (f"; resumed with {', '.join(f'`{c}`' for c in meta['resumed_with'])}"
                if meta.get("resumed_with") else ""), ""]
    if exp == "exp3":
        lines += _exp3_table(summary)
    else:
        for world in dict.fromkeys(r["world"] for r in summary["rows"]):
            lines += [f"## {world}", ""] + _method_table(summary, world) + [""]
    errored, missing = summary.get("errored_trials", {}), summary.get("missing_trials", [])
    if errored or missing:
        lines += ["", f"**Incomplete: {len(errored)} trial(s) failed on their stack twice and {len(missing)} "
                  "never ran; they are left out of the figures above (`--resume` flies them again).**", ""]
        lines += [f"- {name}: error, {reason}" for name, reason in errored.items()]
        lines += [f"- {name}: no row" for name in missing]
    lines += ["", "Success (DESIGN §8): touchdown within 0.5 m of the target, no collision, never within 1 m "
              "of a person. *paper*: Cai, Wu, Zhou, LLM-Land, Tables I–III (ROS/Gazebo, 50 trials each)."]
    return "\n".join(lines) + "\n"


def write_report(out: Path, summary: dict[str, Any], meta: dict[str, Any]) -> None:
    (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    (out / "results.md").write_text(results_markdown(summary, meta))
