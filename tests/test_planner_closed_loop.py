"""The planner flying the simulator over real Zenoh (separate processes)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from llmland_schemas import PERSON_HARD_LIMIT_M

from .conftest import run_cli

pytestmark = pytest.mark.integration


def test_baseline_lands_on_target_among_static_obstacles(tmp_path: Path) -> None:
    """Static obstacles only: every seed lands within 0.5 m (the README's 20-seed run covers more)."""
    proc = run_cli("trials", "--method", "baseline", "--pedestrians", "0", "--seeds", "1-3",
                   "--out", str(tmp_path), timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    summary = json.loads(proc.stdout)
    assert summary["landed_within_0_5m"] == 3, summary
    assert summary["collisions"] == 0
    assert (tmp_path / "trials.csv").read_text().count("\n") == 4


def test_given_pedestrian_spec_lands_outside_reach() -> None:
    """A pedestrian near the path whose spec (3 m buffer) is given directly: a safe landing.

    Seed 3: the person walks to the pad and lingers around it. The 3 m buffer is the planning
    keep-out (predicted motion); the scored hard limit is 1 m from the person's body axis,
    guaranteed by the reachable-set gate (services/planner/README.md, "Safety argument"). So the
    drone must land on target and never come within 1 m; it may pass closer than 3 m while
    the person walks. Lockstep runs are reproducible (search bounded by expansions).
    """
    proc = run_cli("land", "--method", "llm-land", "--specs", "oracle", "--seed", SEED, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    r = json.loads(proc.stdout)
    assert r["collisions"] == [] and r["close_calls"] == 0, r
    assert min(r["min_person_distance_m"].values()) > PERSON_HARD_LIMIT_M, r
    assert r["outcome"] == "landed", r
    assert r["mpc_solve_ms_p50"] is not None and r["mpc_solve_ms_p50"] < 20


SEED = "3"


def test_detour_away_from_the_goal_is_flown_looking_ahead() -> None:
    """Regression (Exp 2, conservative, open_field seed 34): the start lay inside a tree's
    possible-person keep-out, the first detour led backwards, and the drone flew it facing the
    goal into a tree neither camera had seen (a collision at 9.4 s). The forward camera now looks
    along the path; the first 15 s hold no collision."""
    proc = run_cli("land", "--method", "conservative", "--world", "open_field", "--seed", "34",
                   "--timeout", "15", timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    r = json.loads(proc.stdout)
    assert r["collisions"] == [] and r["close_calls"] == 0, r
