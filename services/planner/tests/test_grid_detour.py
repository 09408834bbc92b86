"""Tests of the plan-view grid detour the search falls back to at its largest budget."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from llmland_planner.grid_detour import grid_detour, rest_to_rest
from llmland_planner.regions import UnsafeRegion, segments_hit_boxes
from llmland_planner.search import SearchConfig, _Checker, plan

START = np.array([0.0, 0.0, 3.5])
GOAL = np.array([12.0, 0.0, 4.0])
CFG = SearchConfig(time_budget_s=float("inf"), max_expansions=5, z_floor_m=3.0,
                   workspace_lo=(-20.0, -20.0, -1.0), workspace_hi=(30.0, 20.0, 10.0))
#: a wall across the way, taller than the workspace, with a 1.2 m gap at y ∈ [3.0, 4.2]
GAP_WALL = [UnsafeRegion([5.0, -15.0, -1.0], [6.0, 3.0, 12.0], obj_id="south"),
            UnsafeRegion([5.0, 4.2, -1.0], [6.0, 15.0, 12.0], obj_id="north")]


def _detour(start: np.ndarray, goal: np.ndarray, regions: list[UnsafeRegion], cfg: SearchConfig = CFG):
    chk = _Checker(regions, start, goal, cfg)
    return grid_detour(start, goal, regions, chk.ok, z_floor_m=cfg.z_floor_m, v_max_mps=cfg.v_max_mps,
                       a_max_mps2=cfg.a_max_mps2, rho=cfg.rho, res_m=cfg.grid_res_m,
                       grid_margin_m=cfg.grid_margin_m, clearance_radius_m=cfg.clearance_radius_m)


def _assert_clear(p: np.ndarray, v: np.ndarray, regions: list[UnsafeRegion], cfg: SearchConfig) -> None:
    """No sample and no segment between samples in a region outside the clearance balls; the
    floor kept there; speed within the limit."""
    far = ((np.linalg.norm(p - p[0], axis=1) > cfg.clearance_radius_m)
           & (np.linalg.norm(p - p[-1], axis=1) > cfg.clearance_radius_m))
    for r in regions:
        assert not any(r.contains(q) for q in p[far]), f"detour enters {r.obj_id}"
    lo, hi = np.stack([r.lo for r in regions]), np.stack([r.hi for r in regions])
    both = far[:-1] & far[1:]
    assert not np.any(segments_hit_boxes(p[:-1][both], p[1:][both], lo, hi))
    assert np.all(p[far, 2] >= cfg.z_floor_m - 1e-9)
    assert np.all(np.linalg.norm(v, axis=1) <= cfg.v_max_mps + 1e-9)


def test_rest_to_rest_leg_is_exact_and_within_limits() -> None:
    a, b = np.array([1.0, 2.0, 3.0]), np.array([7.0, -1.0, 3.0])
    t, p, v = rest_to_rest(a, b, 2.0, 2.5, 0.05)
    np.testing.assert_allclose(p[0], a)
    np.testing.assert_allclose(p[-1], b)
    np.testing.assert_allclose(v[[0, -1]], 0.0)
    speed = np.linalg.norm(v, axis=1)
    assert np.all(speed <= 2.0 + 1e-9)
    assert np.all(np.diff(np.linalg.norm(p - a, axis=1)) >= -1e-12)  # never backs up
    accel = np.linalg.norm(np.diff(v, axis=0), axis=1) / np.diff(t)
    assert np.all(accel <= 2.5 + 1e-6)
    # minimum time: 6.7 m at 2 m/s with 0.8 s to reach it and 0.8 s to stop
    length = float(np.linalg.norm(b - a))
    assert t[-1] == pytest.approx(length / 2.0 + 2.0 / 2.5)


def test_short_leg_is_triangular() -> None:
    t, p, v = rest_to_rest(np.zeros(3), np.array([0.5, 0.0, 0.0]), 2.0, 2.5, 0.01)
    assert float(np.max(np.linalg.norm(v, axis=1))) < 2.0
    assert t[-1] == pytest.approx(2.0 * np.sqrt(0.5 / 2.5), abs=1e-9)


def test_search_with_a_spent_budget_falls_back_to_a_clear_detour_through_the_gap() -> None:
    assert plan(START, np.zeros(3), GOAL, GAP_WALL, CFG) is None  # 5 expansions do not get through
    path = plan(START, np.zeros(3), GOAL, GAP_WALL, CFG, grid_fallback=True)
    assert path is not None
    np.testing.assert_allclose(path.p[[0, -1]], [START, GOAL], atol=1e-9)
    np.testing.assert_allclose(path.v[-1], 0.0)
    crossing = path.p[np.argmin(np.abs(path.p[:, 0] - 5.5))]
    assert 3.0 < crossing[1] < 4.2
    _assert_clear(path.p, path.v, GAP_WALL, CFG)
    assert np.all(np.diff(path.t) > 0.0)


def test_no_detour_through_a_closed_wall() -> None:
    closed = [UnsafeRegion([5.0, -25.0, -1.0], [6.0, 25.0, 12.0], obj_id="wall")]
    assert _detour(START, GOAL, closed) is None


def test_a_gap_narrower_than_a_grid_cell_is_not_squeezed_through() -> None:
    narrow = [UnsafeRegion([5.0, -15.0, -1.0], [6.0, 3.0, 12.0]), UnsafeRegion([5.0, 3.3, -1.0], [6.0, 15.0, 12.0])]
    path = _detour(START, GOAL, narrow)
    if path is not None:  # only round the far ends of the wall (outside this 15 m grid margin: none)
        _assert_clear(path.p, path.v, narrow, CFG)
        assert not np.any((np.abs(path.p[:, 0] - 5.5) < 0.5) & (np.abs(path.p[:, 1] - 3.15) < 1.0))


def test_low_obstacles_under_the_cruise_altitude_are_flown_over() -> None:
    rock = [UnsafeRegion([4.0, -3.0, -1.0], [8.0, 3.0, 2.0], obj_id="rock")]
    path = _detour(START, GOAL, rock)
    assert path is not None
    assert float(np.max(np.abs(path.p[:, 1]))) < 1e-6  # straight over it
    _assert_clear(path.p, path.v, rock, CFG)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.floats(1.0, 11.0), st.floats(-6.0, 6.0), st.floats(0.3, 3.0), st.floats(0.3, 3.0),
                          st.floats(2.0, 12.0)), min_size=1, max_size=6))
def test_any_detour_keeps_out_of_every_region(boxes: list[tuple[float, float, float, float, float]]) -> None:
    """The safety property: whatever the grid proposes, a returned detour never touches a region
    (samples or segments) outside the clearance balls, nor dips under the floor."""
    regions = [UnsafeRegion([x - hx, y - hy, -1.0], [x + hx, y + hy, top]) for x, y, hx, hy, top in boxes]
    path = _detour(START, GOAL, regions)
    if path is not None:
        _assert_clear(path.p, path.v, regions, CFG)
        np.testing.assert_allclose(path.p[[0, -1]], [START, GOAL], atol=1e-9)


def test_cruise_altitude_rises_over_a_varying_floor() -> None:
    """The reach floor over a person (here 4.6 m in a disc on the way) lifts the whole detour;
    a detour at the start's altitude would pass under it."""
    def floor(xy: np.ndarray) -> np.ndarray:
        return np.where(np.linalg.norm(xy - [3.0, 3.6], axis=-1) < 2.0, 4.6, 3.0)

    cfg = SearchConfig(time_budget_s=float("inf"), max_expansions=5, z_floor_m=3.0, floor_fn=floor,
                       workspace_lo=(-20.0, -20.0, -1.0), workspace_hi=(30.0, 20.0, 10.0))
    path = plan(START, np.zeros(3), GOAL, GAP_WALL, cfg, grid_fallback=True)
    assert path is not None
    far = ((np.linalg.norm(path.p - START, axis=1) > cfg.clearance_radius_m)
           & (np.linalg.norm(path.p - GOAL, axis=1) > cfg.clearance_radius_m))
    assert np.all(path.p[far, 2] >= floor(path.p[far, :2]) - 1e-9)
    assert float(np.max(path.p[:, 2])) >= 4.6
    _assert_clear(path.p, path.v, GAP_WALL, cfg)
