"""Benchmarks printed by ``llmland bench <what> [--json]``: medians and 95th percentiles."""

from __future__ import annotations

import os
import platform
import re
from typing import Any

import numpy as np

#: what each ``llmland bench <what>`` measures (its ``--help``)
BENCHMARKS: dict[str, str] = {
    "bus": "Zenoh round trip of a VehicleState between two processes (encode + validate both ways)",
    "sim": "simulator speed: physics steps/s headless without camera, real-time factor with the cameras",
    "mpc": "one MPC tick (linearise + clarabel solve) on a closed loop around a person-sized obstacle",
    "vle": "simcap captioning: one frame (blobs, frame caption, crop captions), one crop, drops at 10 Hz",
    "reasoner": "caption -> spec latency per mode (cold/warm cache), peak RSS, 10 drones x 2 Hz on one reasoner",
    "startup": "wall time from launch until each of the four services of one drone can serve",
}

#: CPU features that decide which figures a machine can be compared with (and the LLM runtime's fault)
_CPU_FLAGS = ("avx2", "avx512f", "amx_tile")


def percentiles(samples: list[float] | np.ndarray, prefix: str, digits: int = 1) -> dict[str, float]:
    a = np.asarray(samples, dtype=float)
    return {f"{prefix}_p50": round(float(np.percentile(a, 50)), digits),
            f"{prefix}_p95": round(float(np.percentile(a, 95)), digits)}


def machine() -> dict[str, Any]:
    """The machine a figure came from: architecture, cores, Python, and (Linux) the CPU model and
    whether it has AVX2 / AVX-512 / AMX (``/proc/cpuinfo``)."""
    return {"machine": f"{platform.machine()} {os.cpu_count()} cores, {platform.python_implementation()} "
                       f"{platform.python_version()}", "cpu": _cpu()}


def _cpu(cpuinfo: str = "/proc/cpuinfo") -> str:
    """``"<model name> (avx2, avx512f, amx_tile)"`` from ``cpuinfo`` (Linux x86); the processor
    string alone where that file is missing (not Linux)."""
    try:
        with open(cpuinfo, encoding="utf-8") as f:
            info = f.read()
    except OSError:
        return platform.processor() or "unknown"
    model = re.search(r"^model name\s*:\s*(.+)$", info, re.MULTILINE)
    flags_line = re.search(r"^flags\s*:\s*(.+)$", info, re.MULTILINE)
    flags = set(flags_line.group(1).split()) if flags_line else set()
    has = [f for f in _CPU_FLAGS if f in flags]
    return f"{model.group(1).strip() if model else 'unknown'} ({', '.join(has) or 'no AVX2'})"


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
        raise ValueError(f"unknown benchmark {what!r}; one of: {', '.join(BENCHMARKS)}")
    return {"benchmark": what, **figures, **machine()}
