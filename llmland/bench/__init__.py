"""Benchmarks printed by ``llmland bench <what> [--json]``: medians and 95th percentiles."""

from __future__ import annotations

import os
import platform
from typing import Any

import numpy as np


def percentiles(samples: list[float] | np.ndarray, prefix: str, digits: int = 1) -> dict[str, float]:
    a = np.asarray(samples, dtype=float)
    return {f"{prefix}_p50": round(float(np.percentile(a, 50)), digits),
            f"{prefix}_p95": round(float(np.percentile(a, 95)), digits)}


def machine() -> dict[str, Any]:
    return {"machine": f"{platform.machine()} {os.cpu_count()} cores, {platform.python_implementation()} "
                       f"{platform.python_version()}"}


def run(what: str, *, quick: bool = False) -> dict[str, Any]:
    if what == "bus":
        from .bus import run_bus
        figures = run_bus(n=300 if quick else 3000)
    elif what == "sim":
        from .sim import run_sim
        figures = run_sim(quick=quick)
    elif what == "mpc":
        from llmland_planner.bench_mpc import run_bench as run_mpc
        figures = {k: round(float(v), 2) for k, v in run_mpc(ticks=100 if quick else 500).items()}
    elif what == "reasoner":
        from .reasoner import run_reasoner
        figures = run_reasoner(quick=quick)
    elif what == "startup":
        from .startup import run_startup
        figures = run_startup(runs=1 if quick else 3)
    elif what == "vle":
        from llmland_vle.bench import run_bench as run_vle
        figures = run_vle(quick=quick)
    else:
        raise ValueError(f"unknown benchmark {what!r}")
    return {"benchmark": what, **figures, **machine()}
