"""Timing benchmark of the MPC tick on a representative closed loop.

Scenario: plan around a person-sized obstacle with the kinodynamic search, build corridors,
then fly the nominal RK4 model with the MPC for ``ticks`` ticks of ``dt`` (20 Hz), taking
the reference window and the timed corridor rows from the path each tick. Only
:meth:`MpcController.solve` is timed (``tick_ms``: whole call; ``solve_ms``: clarabel's
``solve()``). Run ``python -m llmland_planner.bench_mpc``.
"""

from __future__ import annotations

import json
import logging

import numpy as np

from llmland_planner.corridors import corridors_for_path, halfspaces_at_times
from llmland_planner.dynamics import ModelParams, step
from llmland_planner.mpc import MpcController
from llmland_planner.path import resample
from llmland_planner.regions import from_obstacle
from llmland_planner.search import SearchConfig, plan

log = logging.getLogger(__name__)


def run_bench(ticks: int = 200, horizon: int = 20, dt: float = 0.05,
              max_halfspaces: int = 8) -> dict[str, float]:
    """Closed-loop timing over ``ticks`` MPC ticks; percentiles in milliseconds."""
    params = ModelParams()
    start, goal = np.array([0.0, 0.0, 2.0]), np.array([8.0, 0.5, 1.2])
    regions = (from_obstacle([3.0, 0.3], 0.4, 1.8, 0.8, 3.0, obj_id="person")
               + from_obstacle([6.0, -1.2], 0.6, 1.0, 0.5, 3.0, obj_id="car"))
    path = plan(start, np.zeros(3), goal, regions, SearchConfig(time_budget_s=1.0))
    if path is None:
        raise RuntimeError("benchmark scenario has no path")
    corridors = corridors_for_path(path, regions, max_halfspaces=max_halfspaces)
    mpc = MpcController(params, horizon=horizon, dt=dt, max_halfspaces=max_halfspaces)
    x = np.zeros(9)
    x[:3] = start
    tick_ms, solve_ms, iters, failures = [], [], [], 0
    for k in range(ticks):
        win = resample(path, dt, t_start=k * dt, count=horizon + 1)
        rows = halfspaces_at_times(corridors, win.t[1:], max_halfspaces)
        res = mpc.solve(x, win.p, win.v, 0.0, rows)
        tick_ms.append(res.tick_ms)
        solve_ms.append(res.solve_ms)
        iters.append(res.iterations)
        failures += int(not res.ok)
        x = step(x, res.u0, dt, params)
    out = {
        "mpc_tick_ms_p50": float(np.percentile(tick_ms, 50)),
        "mpc_tick_ms_p95": float(np.percentile(tick_ms, 95)),
        "mpc_solve_ms_p50": float(np.percentile(solve_ms, 50)),
        "mpc_solve_ms_p95": float(np.percentile(solve_ms, 95)),
        "qp_iterations_p50": float(np.percentile(iters, 50)),
        "qp_iterations_max": float(np.max(iters)),
    }
    log.info("MPC bench (%d ticks, %d failures, final error %.3f m): %s", ticks, failures,
             float(np.linalg.norm(x[:3] - goal)), json.dumps(out))
    return out


def main() -> None:
    """Log the benchmark result as JSON."""
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    run_bench()


if __name__ == "__main__":
    main()
