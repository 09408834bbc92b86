"""Out of reach by altitude over real terrain: after the take-off climb (straight up from where the
mission starts it) and away from the final descent, the vehicle flies at least 3 m (a 2 m head
plus the 1 m limit) above the highest ground anyone within 1 m horizontally could stand on
(services/planner/README.md, safety argument 1)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pybullet as p
import pytest
from llmland_planner.hard_limit import REACH_CEILING_M
from llmland_schemas import PERSON_HARD_LIMIT_M
from llmland_sim.world.worlds import build_world

from .conftest import run_cli

pytestmark = pytest.mark.integration

#: forest_edge seed 38: its approach crosses a 0.8 m mound, where the floor at the target's height
#: left 2.43 m over the ground (at 9e89978)
SEED = 38
#: the take-off climb is vertical: it has ended once the vehicle has moved this far (m) horizontally
TAKE_OFF_DRIFT_M = 0.5
#: the final descent is flown within this distance (m) of the target
DESCENT_ZONE_M = 1.0


def _highest_ground_within_reach(world, x: float, y: float) -> float:
    offsets = [(dx, dy) for dx in np.linspace(-1.0, 1.0, 5) for dy in np.linspace(-1.0, 1.0, 5)
               if dx * dx + dy * dy <= PERSON_HARD_LIMIT_M**2]
    return max(world.ground_height(x + dx, y + dy) for dx, dy in offsets)


def test_over_a_mound_the_vehicle_stays_out_of_everyones_reach(tmp_path: Path) -> None:
    proc = run_cli("experiment", "exp2", "--worlds", "forest_edge", "--methods", "baseline", "--trials", "1",
                   "--seed-base", str(SEED), "--timeout", "20", "--out", str(tmp_path), timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    trace = json.loads((tmp_path / "traces" / f"forest_edge-baseline-s{SEED}.json").read_text())
    t, x, y, z = np.asarray(trace["drone"], dtype=float).T
    target = np.asarray(trace["target"], dtype=float)
    client = p.connect(p.DIRECT)
    try:
        world = build_world(client, "forest_edge", SEED, renderer="tiny")
        climbed = np.flatnonzero(np.hypot(x - x[0], y - y[0]) > TAKE_OFF_DRIFT_M)
        assert climbed.size, "the vehicle never left its start"
        away = np.hypot(x - target[0], y - target[1]) > DESCENT_ZONE_M
        checked = [k for k in range(int(climbed[0]), len(t)) if away[k]]
        assert len(checked) > 20
        over = [z[k] - _highest_ground_within_reach(world, x[k], y[k]) for k in checked]
        worst = int(np.argmin(over))
        assert over[worst] >= REACH_CEILING_M, (t[checked[worst]], x[checked[worst]], y[checked[worst]], over[worst])
    finally:
        p.disconnect(client)
