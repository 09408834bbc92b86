"""``Replanner.path_blocked``: what of the path ahead is checked, and against which boxes."""

import numpy as np
import pytest
from llmland_planner.path import Path
from llmland_planner.regions import UnsafeRegion
from llmland_planner.replanning import PATH_GRAZE_M, ActivePlan, Replanner

STEP_M = 0.1


def _plan(points: list[list[float]], start_clearance_m: float = 0.0) -> ActivePlan:
    """A straight-segment plan through ``points`` sampled every ``STEP_M``."""
    corners = np.asarray(points, dtype=float)
    pts = [corners[0]]
    for a, b in zip(corners[:-1], corners[1:], strict=True):
        n = max(1, int(np.ceil(np.linalg.norm(b - a) / STEP_M)))
        pts += [a + (b - a) * k / n for k in range(1, n + 1)]
    p = np.array(pts)
    t = np.arange(len(p), dtype=float)
    return ActivePlan(Path(t, p, np.zeros_like(p)), [], p[-1], 0.0, 0.0, start_clearance_m=start_clearance_m)


def _box(lo: list[float], hi: list[float], **kw: object) -> UnsafeRegion:
    return UnsafeRegion(np.array(lo), np.array(hi), obj_id="b", **kw)  # type: ignore[arg-type]


@pytest.mark.parametrize("depth_m", [0.001, 0.01, 0.9 * PATH_GRAZE_M])
def test_a_path_grazing_a_face_by_less_than_the_tolerance_is_not_blocked(depth_m: float) -> None:
    """Regression (open_field seed 34, specs from truth): each new plan out of a shrunk keep-out
    ran along its face and cut it by millimetres after resampling; read as blocked at once, it
    was searched again every tick and the vehicle held for 90 s."""
    wall = _box([2.0, 1.0, 0.0], [4.0, 3.0, 5.0], is_dynamic=True)
    plan = _plan([[0.0, 1.0 - 2.0, 3.0], [3.0, 1.0 + depth_m, 3.0], [6.0, -1.0, 3.0]])
    assert not Replanner.path_blocked(plan, [wall])


@pytest.mark.parametrize("depth_m", [1.5 * PATH_GRAZE_M, 0.5, 1.0])
def test_a_path_into_a_region_ahead_is_blocked(depth_m: float) -> None:
    wall = _box([2.0, 1.0, 0.0], [4.0, 3.0, 5.0], is_dynamic=True)
    plan = _plan([[0.0, -1.0, 3.0], [3.0, 1.0 + depth_m, 3.0], [6.0, -1.0, 3.0]])
    assert Replanner.path_blocked(plan, [wall])


def test_the_search_s_start_clearance_ball_is_not_checked_but_past_it_is() -> None:
    """A plan from inside a region (a person's box grew over the vehicle) leaves it inside the
    clearance ball its search waived: that part is not read as blocked; the same path entering
    the region again past the ball is."""
    person = _box([-1.0, -1.0, 0.0], [1.0, 1.0, 3.0], is_dynamic=True)
    leaving = _plan([[0.5, 0.0, 2.0], [3.0, 0.0, 2.0]], start_clearance_m=0.8)
    assert not Replanner.path_blocked(leaving, [person])
    back_in = _plan([[0.5, 0.0, 2.0], [3.0, 0.0, 2.0], [3.0, 3.0, 2.0], [0.0, 0.5, 2.0]], start_clearance_m=0.8)
    assert Replanner.path_blocked(back_in, [person])
    no_ball = _plan([[0.5, 0.0, 2.0], [3.0, 0.0, 2.0]], start_clearance_m=0.0)
    assert Replanner.path_blocked(no_ball, [person])  # without a waived ball, its points in the box count


def test_what_lies_behind_the_vehicle_is_not_checked() -> None:
    wall = _box([1.0, -1.0, 0.0], [2.0, 1.0, 5.0], is_dynamic=True)
    plan = _plan([[0.0, 0.0, 3.0], [3.0, 0.0, 3.0], [3.0, 5.0, 3.0]])
    assert Replanner.path_blocked(plan, [wall])
    plan.progress_idx = 35  # 0.5 m past the wall's far face
    assert not Replanner.path_blocked(plan, [wall])
