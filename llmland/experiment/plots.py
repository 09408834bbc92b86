"""PNG plots of an experiment (matplotlib, no display needed)."""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from llmland_schemas import PERSON_HARD_LIMIT_M  # noqa: E402
from matplotlib.patches import Rectangle  # noqa: E402

from .traces import load_trace  # noqa: E402

log = logging.getLogger(__name__)


def _name(row: dict[str, Any]) -> str:
    """A trial row's or a summary row's group: the method, and exp3's LLM row (trials.csv names it
    ``variant``, summary.json ``llm``; reading only ``variant`` drew every exp3 bar at one place)."""
    variant = row.get("variant") or row.get("llm")
    return row["method"] + (f"\n{variant}" if variant else "")


#: Longest tick label (characters) drawn level; longer ones are slanted so they do not overlap.
LEVEL_LABEL_CHARS = 14


def _tick_labels(ax: Any, positions: list[float], names: list[str]) -> None:
    """Tick labels at ``positions``: slanted when long (exp3's LLM rows), one line per part."""
    slant = max((len(part) for n in names for part in n.split("\n")), default=0) > LEVEL_LABEL_CHARS
    ax.set_xticks(positions, names, fontsize=8, rotation=25 if slant else 0, ha="right" if slant else "center")


def success_by_method(summary: dict[str, Any], path: Path) -> None:
    rows = summary["rows"]
    worlds = list(dict.fromkeys(r["world"] for r in rows))
    names = list(dict.fromkeys(_name(r) for r in rows))
    fig, ax = plt.subplots(figsize=(max(6.0, 1.6 * len(names)), 4.0))
    width = 0.8 / max(1, len(worlds))
    for i, world in enumerate(worlds):
        vals = {_name(r): 100 * (r["success_rate"] or 0.0) for r in rows if r["world"] == world}
        xs = [j + i * width for j in range(len(names))]
        ax.bar(xs, [vals.get(n, 0.0) for n in names], width, label=world)
    _tick_labels(ax, [j + width * (len(worlds) - 1) / 2 for j in range(len(names))], names)
    ax.set_ylabel("success %")
    ax.set_ylim(0, 100)
    ax.legend(fontsize=8)
    ax.set_title(f"{summary['experiment']}: landing success")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


#: Line styles of the closest-approach histograms, one per method in turn, each drawn thinner than
#: the one before: two methods with the same trials (baseline and conservative often are) show as
#: a dashed line inside a solid one instead of one line hiding the other.
HIST_STYLES = ("-", "--", ":", "-.")
HIST_WIDTH_FIRST, HIST_WIDTH_STEP, HIST_WIDTH_MIN = 3.2, 0.7, 1.0


def closest_approach(rows: list[dict[str, str]], path: Path) -> None:
    """Histogram per method of each trial's closest approach to a person, with the 1 m limit;
    each legend entry gives its trials and its smallest approach."""
    fig, ax = plt.subplots(figsize=(6.5, 4.0))
    groups: dict[str, list[float]] = {}
    for r in rows:
        if r["closest_person_m"]:
            groups.setdefault(_name(r).replace("\n", " "), []).append(float(r["closest_person_m"]))
    for k, (name, vals) in enumerate(groups.items()):
        ax.hist(vals, bins=24, range=(0.0, 8.0), histtype="step", linestyle=HIST_STYLES[k % len(HIST_STYLES)],
                linewidth=max(HIST_WIDTH_MIN, HIST_WIDTH_FIRST - HIST_WIDTH_STEP * k),
                label=f"{name} (n={len(vals)}, min {min(vals):.2f} m)")
    ax.axvline(PERSON_HARD_LIMIT_M, color="red", linestyle="--", label="1 m hard limit")
    ax.set_xlabel("closest approach to a person per trial (m)")
    ax.set_ylabel("trials")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def spec_latency(rows: list[dict[str, str]], path: Path) -> None:
    groups: dict[str, list[float]] = {}
    for r in rows:
        if r["spec_latency_ms_mean"]:
            groups.setdefault(_name(r), []).append(float(r["spec_latency_ms_mean"]))
    if not groups:
        return
    fig, ax = plt.subplots(figsize=(max(6.0, 1.6 * len(groups)), 4.0))
    ax.boxplot(list(groups.values()), showfliers=True)
    _tick_labels(ax, [k + 1.0 for k in range(len(groups))], list(groups))
    ax.set_ylabel("mean spec latency per trial (ms)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def trajectory(trace_path: Path, title: str, path: Path) -> None:
    """Top-down view of one trial: drone path, people, unsafe regions of the last plan, target."""
    tr = load_trace(trace_path)
    fig, ax = plt.subplots(figsize=(6.0, 6.0))
    for reg in tr["regions"]:
        lo, hi = reg["lo"], reg["hi"]
        ax.add_patch(Rectangle((lo[0], lo[1]), hi[0] - lo[0], hi[1] - lo[1], alpha=0.12,
                               color="red" if reg["dynamic"] else "grey"))
    for pid, pts in tr["people"].items():
        ax.plot([p[1] for p in pts], [p[2] for p in pts], color="tab:red", linewidth=1.2, label=pid)
    if tr["drone"]:
        ax.plot([p[1] for p in tr["drone"]], [p[2] for p in tr["drone"]], color="tab:blue", linewidth=2.0,
                label="drone")
    if tr["target"]:
        ax.plot(tr["target"][0], tr["target"][1], marker="*", markersize=16, color="gold", label="target")
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=7, loc="best")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


#: The plots a run writes (``trajectory_<method>.png`` per method): what ``--overwrite`` removes.
PLOT_PATTERNS = ("success.png", "closest_person.png", "spec_latency.png", "trajectory_*.png")


def write_plots(out: Path, summary: dict[str, Any], rows: list[dict[str, str]]) -> list[Path]:
    """Every plot of the folder; returns the files written."""
    written = [out / "success.png", out / "closest_person.png"]
    success_by_method(summary, written[0])
    closest_approach(rows, written[1])
    if any(r["spec_latency_ms_mean"] for r in rows):
        spec_latency(rows, out / "spec_latency.png")
        written.append(out / "spec_latency.png")
    firsts: dict[str, dict[str, str]] = {}
    for r in sorted(rows, key=lambda r: int(r["seed"])):
        firsts.setdefault(_name(r), r)
    for name, r in firsts.items():
        suffix = f"-{r['variant']}" if r["variant"] else ""
        trace = out / "traces" / f"{r['world']}-{r['method']}{suffix}-s{r['seed']}.json".replace(" ", "_")
        if not trace.exists():
            continue
        png = out / f"trajectory_{r['method']}{suffix}.png".replace(" ", "_").replace("(", "").replace(")", "")
        trajectory(trace, f"{name.replace(chr(10), ' ')} — {r['world']} seed {r['seed']}: {r['outcome']}", png)
        written.append(png)
    return written
