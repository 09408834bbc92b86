"""The hard limit's reachable-set gate: bounds, the untracked bound, and a property test against people who
move as adversarially as the stated bounds allow."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from llmland_planner.descent import DescentProfile
from llmland_planner.hard_limit import (
    PERSON_BODY_RADIUS_M,
    PERSON_MAX_HEIGHT_M,
    HumanMotionBounds,
    PersonHypothesis,
    commit_clearance,
)
from llmland_planner.landing import LandingLogic, Surroundings
from llmland_planner.settings import PlannerSettings
from llmland_schemas import PERSON_HARD_LIMIT_M

BOUNDS = HumanMotionBounds()
SETTINGS = PlannerSettings()
TARGET = np.zeros(3)
HOVER_M = SETTINGS.cruise_altitude_m
DT_S = 0.01


def test_reach_is_monotone_and_capped_by_the_walking_speed() -> None:
    taus = np.linspace(0.0, 5.0, 51)
    for speed in (None, 0.0, 0.5, 1.4):
        r = [BOUNDS.reach_m(t, speed) for t in taus]
        assert np.all(np.diff(r) >= 0.0)
        assert all(ri <= BOUNDS.max_speed_mps * t + 1e-12 for ri, t in zip(r, taus, strict=True))
    assert BOUNDS.reach_m(2.0, None) == pytest.approx(3.2)  # unknown speed: already at 1.6 m/s
    standing = BOUNDS.reach_m(2.0, 0.0)
    assert 2.8 < standing < 3.2  # a standing person needs a step and acceleration first


def test_untracked_people_bound_needs_enough_coverage() -> None:
    far = commit_clearance(TARGET[:2], [], 2.0, BOUNDS, coverage_m=7.0, unseen_s=0.2, xy_margin_m=0.25)
    near = commit_clearance(TARGET[:2], [], 2.0, BOUNDS, coverage_m=4.0, unseen_s=0.2, xy_margin_m=0.25)
    assert far.safe and not near.safe and near.track_id == ""


def _distance_to_axis(drone: np.ndarray, axis_xy: np.ndarray, height_m: float) -> float:
    dz = max(0.0, drone[2] - height_m)
    return float(math.hypot(float(np.linalg.norm(drone[:2] - axis_xy)), dz))


def _descent_heights(logic: LandingLogic, duration_s: float) -> np.ndarray:
    """Vehicle height over the gate's whole duration: the profile, then resting on the ground."""
    n = int(duration_s / DT_S) + 1
    h, _ = logic.profile.reference(HOVER_M, 0.0, DT_S, n)
    return np.asarray(h)


@settings(max_examples=300, deadline=None)
@given(
    dist=st.floats(1.0, 9.0), bearing=st.floats(-math.pi, math.pi), speed=st.floats(0.0, 1.6),
    heading=st.floats(-math.pi, math.pi), age=st.floats(0.0, 3.0), axis_off=st.floats(0.0, PERSON_BODY_RADIUS_M),
    off_dir=st.floats(-math.pi, math.pi), turn=st.floats(-math.pi, math.pi), xy_err=st.floats(0.0, 0.2),
    strategy=st.sampled_from(["straight", "turn", "late"]),
)
def test_people_within_the_bounds_never_come_within_1_m_of_a_descent_the_gate_allowed(
        dist: float, bearing: float, speed: float, heading: float, age: float, axis_off: float, off_dir: float,
        turn: float, xy_err: float, strategy: str) -> None:
    """Random person states within the stated bounds: if the gate opens, simulate the descent and
    the person (true speed within the tracking error, a first step, bounded acceleration, at most
    1.6 m/s), heading for the landing point straight, after a turn, or late; distance ≥ 1 m."""
    logic = LandingLogic(TARGET, SETTINGS)
    observed = np.array([math.cos(bearing), math.sin(bearing)]) * dist
    person = PersonHypothesis("p", observed, PERSON_BODY_RADIUS_M, speed, age)
    gate = logic.gate(HOVER_M, 0.0, Surroundings([], [person], 100.0, lambda _d: []))
    if not gate.open:
        return
    drone_xy = TARGET[:2] + xy_err * np.array([1.0, 0.0])
    pos = observed + axis_off * np.array([math.cos(off_dir), math.sin(off_dir)])
    true_speed = min(BOUNDS.max_speed_mps, speed + BOUNDS.speed_error_mps)
    vel = true_speed * np.array([math.cos(heading), math.sin(heading)])
    heights = _descent_heights(logic, gate.duration_s)
    steps = int((age + gate.duration_s) / DT_S)
    stepped = False
    for k in range(steps):
        t = k * DT_S - age  # the person moves from their last observation on
        to_drone = drone_xy - pos
        go = to_drone / max(float(np.linalg.norm(to_drone)), 1e-9)
        if strategy == "turn" and t < 0.5:
            go = np.array([math.cos(heading + turn), math.sin(heading + turn)])
        if strategy == "late" and t < 0.8:
            go = -go
        if not stepped:  # the first step: an instant speed change of at most step_speed_mps
            vel = vel + BOUNDS.step_speed_mps * go
            stepped = True
        vel = vel + BOUNDS.max_accel_mps2 * DT_S * go
        v = float(np.linalg.norm(vel))
        if v > BOUNDS.max_speed_mps:
            vel *= BOUNDS.max_speed_mps / v
        pos = pos + vel * DT_S
        if t >= 0.0:
            h = heights[min(int(t / DT_S), heights.size - 1)]
            drone = np.array([*drone_xy, TARGET[2] + h])
            assert _distance_to_axis(drone, pos, PERSON_MAX_HEIGHT_M) >= PERSON_HARD_LIMIT_M, (t, pos, drone)


def test_gate_duration_covers_the_descent_and_the_touchdown_dwell() -> None:
    logic = LandingLogic(TARGET, SETTINGS)
    gate = logic.gate(HOVER_M, 0.0, Surroundings([], [], 100.0, lambda _d: []))
    profile = DescentProfile(SETTINGS.descent_speed_mps, SETTINGS.descent_accel_mps2, SETTINGS.descent_brake_mps2,
                             SETTINGS.descent_touchdown_speed_mps)
    assert gate.open and gate.duration_s == pytest.approx(
        profile.time_to_touchdown_s(HOVER_M, 0.0, SETTINGS.touchdown_height_m)
        + SETTINGS.descent_time_margin_s + SETTINGS.touchdown_dwell_s)


def test_untracked_people_walk_for_the_coverage_frames_age() -> None:
    """Someone outside the coverage at the newest downward frame has been walking since: with
    frames 0.45 s old (a stalled camera; 0.5 s still counts as fresh) the gate must not open on
    a radius that one frame period (0.2 s) would have allowed. A fixed period did."""
    logic = LandingLogic(TARGET, SETTINGS)
    fresh = logic.gate(HOVER_M, 0.0, Surroundings([], [], 100.0, lambda _d: []))
    need = (BOUNDS.reach_m(fresh.duration_s + SETTINGS.coverage_frame_period_s)
            + SETTINGS.landing_xy_margin_m + PERSON_HARD_LIMIT_M)
    radius = need + 0.1
    assert logic.gate(HOVER_M, 0.0, Surroundings([], [], radius, lambda _d: [], coverage_age_s=0.1)).open
    stale = logic.gate(HOVER_M, 0.0, Surroundings([], [], radius, lambda _d: [], coverage_age_s=0.45))
    assert not stale.open and stale.clearance.track_id == ""
    assert stale.clearance.margin_m == pytest.approx(radius - BOUNDS.reach_m(stale.duration_s + 0.45)
                                                     - SETTINGS.landing_xy_margin_m - PERSON_HARD_LIMIT_M)
