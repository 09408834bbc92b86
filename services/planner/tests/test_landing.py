"""Landing phases: descend only onto a clear disc, climb back when it stops being clear."""

import numpy as np
from llmland_planner.landing import LandingLogic, Phase, disc_clear, hover_altitude
from llmland_planner.regions import UnsafeRegion
from llmland_planner.settings import PlannerSettings

TARGET = np.array([0.0, 0.0, 0.0])


def _region(x: float, top: float = 4.7, half: float = 1.0) -> UnsafeRegion:
    return UnsafeRegion(np.array([x - half, -half, -1.0]), np.array([x + half, half, top]), "p", "person", True)


def test_disc_clear():
    assert disc_clear(TARGET[:2], 0.8, [_region(3.0)])
    assert not disc_clear(TARGET[:2], 0.8, [_region(1.5)])


def test_hover_altitude_rises_over_a_region_covering_the_target():
    s = PlannerSettings(cruise_altitude_m=3.0)
    assert hover_altitude(TARGET, [], s) == 3.0
    assert hover_altitude(TARGET, [_region(0.5, top=4.7)], s) == 5.2


def test_phases_hold_descend_abort_touchdown():
    s = PlannerSettings(hold_clear_s=0.5)
    logic = LandingLogic(TARGET, s)
    above, still = np.array([0.0, 0.0, 3.0]), np.zeros(3)
    phase, goal = logic.update(np.array([8.0, 0.0, 3.0]), still, [], 0.0)
    assert phase == Phase.APPROACH and np.allclose(goal, above)
    assert logic.update(above, still, [_region(1.5)], 1.0)[0] == Phase.HOLD  # blocked disc
    assert logic.update(above, still, [], 2.0)[0] == Phase.HOLD  # clear, but not for long enough
    assert logic.update(above, still, [], 2.6)[0] == Phase.DESCEND
    phase, goal = logic.update(np.array([0.0, 0.0, 1.5]), still, [_region(0.5)], 3.0)
    assert phase == Phase.HOLD and goal[2] > 4.7  # intrusion: back up above the region
    logic.phase = Phase.DESCEND
    assert logic.update(np.array([0.0, 0.0, 0.1]), still, [], 4.0)[0] == Phase.TOUCHDOWN
