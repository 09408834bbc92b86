"""Episode results → CSV rows and summary figures."""

from __future__ import annotations

import csv
from pathlib import Path
from typing import Any

import numpy as np
from llmland_schemas import EpisodeResult

COLUMNS = [
    "episode_id", "world", "seed", "method", "clock", "success", "outcome", "touchdown_error_m",
    "time_to_land_s", "min_person_distance_m", "close_calls", "collisions", "sim_time_s", "wall_time_s",
    "deadline_misses", "commands_missing", "spec_latency_ms_mean", "mpc_solve_ms_p50", "mpc_solve_ms_p95",
]


def _row(r: EpisodeResult) -> dict[str, Any]:
    d = r.model_dump()
    d["min_person_distance_m"] = min(r.min_person_distance_m.values()) if r.min_person_distance_m else ""
    d["collisions"] = ";".join(r.collisions)
    return {k: d[k] for k in COLUMNS}


def write_results_csv(path: Path, results: list[EpisodeResult]) -> None:
    with path.open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=COLUMNS)
        w.writeheader()
        for r in results:
            w.writerow(_row(r))


def summarize(results: list[EpisodeResult]) -> dict[str, Any]:
    n = len(results)
    if n == 0:
        return {"trials": 0}
    errs = [r.touchdown_error_m for r in results if r.touchdown_error_m is not None]
    times = [r.time_to_land_s for r in results if r.time_to_land_s is not None]
    dists = [min(r.min_person_distance_m.values()) for r in results if r.min_person_distance_m]
    outcomes: dict[str, int] = {}
    for r in results:
        outcomes[r.outcome] = outcomes.get(r.outcome, 0) + 1
    return {
        "trials": n,
        "success": sum(r.success for r in results),
        "success_rate": round(sum(r.success for r in results) / n, 3),
        "landed_within_0_5m": sum(1 for e in errs if e <= 0.5),
        "outcomes": outcomes,
        "touchdown_error_m_median": round(float(np.median(errs)), 3) if errs else None,
        "time_to_land_s_median": round(float(np.median(times)), 2) if times else None,
        "min_person_distance_m_min": round(float(np.min(dists)), 3) if dists else None,
        "close_calls": sum(r.close_calls > 0 for r in results),
        "collisions": sum(bool(r.collisions) for r in results),
        "deadline_misses": sum(r.deadline_misses for r in results),
    }
