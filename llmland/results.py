"""Summary figures of episode results (``llmland trials``; its CSV rows are
:func:`llmland.experiment.runner.trial_row`'s, like every experiment's)."""

from __future__ import annotations

from typing import Any

import numpy as np
from llmland_schemas import EpisodeResult


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
