"""Landing phases: descend only onto a clear disc, climb back when it stops being clear."""

import numpy as np
from llmland_planner.landing import (
    LandingLogic,
    Phase,
    descent_profile,
    disc_clear,
    hover_altitude,
    time_to_touchdown,
)
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


def test_phases_hold_scan_descend_abort_touchdown():
    s = PlannerSettings(hold_clear_s=0.5, scan_yaw_rate_rps=1.0, scan_sweep_rad=2.0, reach_speed_mps=1.5)
    logic = LandingLogic(TARGET, s)
    above, still = np.array([0.0, 0.0, 3.0]), np.zeros(3)
    phase, goal = logic.update(np.array([8.0, 0.0, 3.0]), still, [], 0.0)
    assert phase == Phase.APPROACH and np.allclose(goal, above)
    assert logic.update(above, still, [_region(1.5)], 1.0)[0] == Phase.HOLD  # blocked disc
    assert logic.update(above, still, [], 2.0)[0] == Phase.HOLD  # clear, but not scanned all around yet
    assert logic.update(above, still, [], 2.6)[0] == Phase.HOLD
    assert logic.update(above, still, [], 3.0)[0] == Phase.DESCEND  # 2 rad swept at 1 rad/s
    phase, goal = logic.update(np.array([0.0, 0.0, 1.5]), still, [_region(0.5)], 3.5)
    assert phase == Phase.HOLD and goal[2] > 4.7  # intrusion: back up above the region
    logic.phase = Phase.DESCEND
    assert logic.update(np.array([0.0, 0.0, 0.3]), still, [_region(0.5)], 4.0)[0] == Phase.DESCEND  # committed
    assert logic.update(np.array([0.0, 0.0, 0.1]), still, [], 4.1)[0] == Phase.TOUCHDOWN


def test_descent_waits_until_nobody_can_walk_in_before_touchdown():
    """A person 6 m away (region edge 2.7 m from the pad) is clear of the disc now, but can
    walk into it during the ~2.7 s descent from 3 m: no descent until they are farther."""
    s = PlannerSettings(hold_clear_s=0.0, scan_sweep_rad=0.0, reach_speed_mps=1.5)
    logic = LandingLogic(TARGET, s)
    above, still = np.array([0.0, 0.0, 3.0]), np.zeros(3)
    near = _region(6.0, half=3.3)
    assert disc_clear(TARGET[:2], s.landing_disc_radius_m, [near])
    logic.phase = Phase.HOLD
    assert logic.update(above, still, [near], 0.0)[0] == Phase.HOLD
    assert logic.update(above, still, [_region(10.0, half=3.3)], 0.1)[0] == Phase.DESCEND
    static = UnsafeRegion(near.lo, near.hi, "r", "rock", False)  # a rock does not walk
    logic2 = LandingLogic(TARGET, s)
    logic2.phase = Phase.HOLD
    assert logic2.update(above, still, [static], 0.0)[0] == Phase.DESCEND


def test_descent_profile_is_fast_high_and_soft_at_the_ground():
    s = PlannerSettings(descent_speed_mps=1.2, descent_min_speed_mps=0.3, descent_brake_mps2=0.8)
    z, vz = descent_profile(3.0, 0.0, 0.05, 200, s)
    assert vz[0] == -1.2 and np.all(np.diff(z) <= 0.0) and z[-1] == 0.03 and vz[-1] == 0.0
    assert -0.5 < vz[np.searchsorted(-z, -0.12)] < 0.0  # slow near the ground
    assert 2.0 < time_to_touchdown(3.0, s) < 3.5
