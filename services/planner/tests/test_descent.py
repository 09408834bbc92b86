"""The final descent profile: fast, committed, with a flare; its closed-form duration."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from llmland_planner.descent import REFERENCE_FLOOR_M, DescentProfile, climb_out_heights

PROFILE = DescentProfile(max_speed_mps=3.0, accel_mps2=5.0, brake_mps2=5.0, touchdown_speed_mps=0.3)


def test_reference_is_monotone_bounded_and_ends_at_rest_at_the_floor() -> None:
    h, v = PROFILE.reference(3.5, 0.0, 0.02, 200)
    assert np.all(np.diff(h) <= 1e-12) and h[-1] == REFERENCE_FLOOR_M and v[-1] == 0.0
    assert v.max() == pytest.approx(3.0) and np.all(np.diff(v)[:10] <= 5.0 * 0.02 + 1e-9)
    flare = np.sqrt(0.3 ** 2 + 2 * 5.0 * np.maximum(h - REFERENCE_FLOOR_M, 0.0))
    assert np.all(v[1:] <= np.minimum(flare[:-1], 3.0) + 1e-9)  # never faster than the flare allows


@settings(deadline=None)  # integrates 60 000 steps: slow on a loaded machine, not wrong
@given(h=st.floats(0.2, 8.0), v0=st.floats(0.0, 3.0))
def test_closed_form_duration_matches_the_integrated_profile(h: float, v0: float) -> None:
    dt = 1e-4
    hs, vs = PROFILE.reference(h, v0, dt, int(6.0 / dt))
    reached = np.flatnonzero(hs <= REFERENCE_FLOOR_M + 1e-9)
    numeric = reached[0] * dt if reached.size else np.inf
    assert PROFILE.time_to_touchdown_s(h, v0, REFERENCE_FLOOR_M) == pytest.approx(numeric, abs=0.01)


def test_three_and_a_half_metres_take_under_two_seconds() -> None:
    assert 1.4 < PROFILE.time_to_touchdown_s(3.5, 0.0, 0.12) < 1.9
    assert PROFILE.time_to_touchdown_s(0.1, 0.0, 0.12) == 0.0


def test_a_climb_out_brakes_then_climbs_to_the_exit() -> None:
    h = climb_out_heights(2.0, 2.0, 3.0, 1.5, 5.0, 0.01)
    assert h[0] == 2.0 and h[-1] >= 3.0 > h[-2]
    assert min(h) == pytest.approx(2.0 - 2.0**2 / (2 * 5.0), abs=0.03)  # 0.4 m of braking first
    assert np.max(np.diff(h)) <= 1.5 * 0.01 + 1e-12  # never faster than the climb speed
    assert list(climb_out_heights(3.5, 0.0, 3.0, 1.5, 5.0, 0.01)) == [3.5]
    with pytest.raises(ValueError):
        climb_out_heights(2.0, 0.0, 3.0, 0.0, 5.0, 0.01)
