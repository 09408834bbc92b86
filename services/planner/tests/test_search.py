"""Tests of the kinodynamic A* search, its penalty and path resampling."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from llmland_planner.regions import UnsafeRegion, from_obstacle, segments_hit_boxes
from llmland_planner.search import Path, SearchConfig, _Checker, _FreeDistance, penalty, plan, resample

START = np.array([0.0, 0.0, 2.0])
GOAL = np.array([8.0, 0.0, 1.5])
# bounded by expansions, not wall time: the suite runs on loaded machines
CFG = SearchConfig(time_budget_s=float("inf"), max_expansions=3000, workspace_lo=(-3.0, -6.0, -1.0),
                   workspace_hi=(11.0, 6.0, 6.0))


def _outside_clearance(path: Path, cfg: SearchConfig) -> np.ndarray:
    d0 = np.linalg.norm(path.p - path.p[0], axis=1)
    d1 = np.linalg.norm(path.p - path.p[-1], axis=1)
    mask: np.ndarray = (d0 > cfg.clearance_radius_m) & (d1 > cfg.clearance_radius_m)
    return mask


def _assert_clear(path: Path, regions: list[UnsafeRegion], cfg: SearchConfig) -> None:
    far = _outside_clearance(path, cfg)
    for r in regions:
        inside = np.array([r.contains(p) for p in path.p])
        assert not np.any(inside & far), f"path enters {r.obj_id}"
    lo, hi = np.stack([r.lo for r in regions]), np.stack([r.hi for r in regions])
    both_far = far[:-1] & far[1:]
    hits = segments_hit_boxes(path.p[:-1][both_far], path.p[1:][both_far], lo, hi)
    assert not np.any(hits)
    assert np.all(path.p[far, 2] >= cfg.z_floor_m - 1e-9)
    assert np.all(np.linalg.norm(path.v, axis=1) <= cfg.v_max_mps + 1e-6)


def test_free_space_reaches_goal_at_rest() -> None:
    path = plan(START, np.zeros(3), GOAL, [], CFG)
    assert path is not None
    np.testing.assert_allclose(path.p[0], START)
    np.testing.assert_allclose(path.p[-1], GOAL, atol=1e-9)
    np.testing.assert_allclose(path.v[-1], 0.0, atol=1e-9)
    assert path.duration_s >= np.linalg.norm(GOAL - START) / CFG.v_max_mps


def test_blocked_wall_gives_no_path() -> None:
    wall = [UnsafeRegion([4.0, -10.0, -2.0], [4.5, 10.0, 10.0], obj_id="wall")]
    assert plan(START, np.zeros(3), GOAL, wall, CFG) is None


def test_gap_in_wall_is_found_and_regions_avoided() -> None:
    wall = [UnsafeRegion([4.0, -10.0, -2.0], [4.5, 1.0, 10.0], obj_id="w1"),
            UnsafeRegion([4.0, 2.0, -2.0], [4.5, 10.0, 10.0], obj_id="w2")]
    path = plan(START, np.zeros(3), GOAL, wall, CFG)
    assert path is not None
    crossing = path.p[np.argmin(np.abs(path.p[:, 0] - 4.25))]
    assert 1.0 < crossing[1] < 2.0
    _assert_clear(path, wall, CFG)


def test_obstacles_avoided() -> None:
    regions = from_obstacle([3.0, 0.5], 0.5, 1.8, 0.5, 3.0, obj_id="a") + from_obstacle(
        [6.0, -1.0], 0.8, 1.8, 0.5, 3.0, obj_id="b")
    path = plan(START, np.zeros(3), GOAL, regions, CFG)
    assert path is not None
    _assert_clear(path, regions, CFG)


def test_start_inside_inflated_region_can_leave() -> None:
    regions = from_obstacle([0.3, 0.0], 0.0, 1.8, 0.4, 3.0, obj_id="near")  # start within 0.2 m
    assert regions[0].contains(START)
    path = plan(START, np.zeros(3), GOAL, regions, CFG)
    assert path is not None
    _assert_clear(path, regions, CFG)


def test_never_crosses_region_beyond_clearance() -> None:
    big = [UnsafeRegion([-2.0, -2.0, -1.0], [2.0, 2.0, 5.0], obj_id="big")]  # start deep inside
    assert plan(START, np.zeros(3), GOAL, big, CFG) is None


def test_penalty_formula() -> None:
    box = [UnsafeRegion([0.0, 0.0, 0.0], [2.0, 2.0, 2.0])]
    eps = 0.01
    pts = np.array([[0.5, 1.0, 1.0], [1.0, 1.0, 1.8], [3.0, 1.0, 1.0], [1.0, 1.0, 1.0]])
    np.testing.assert_allclose(penalty(pts, box, 0.0, eps), [0.25 + eps, 0.04 + eps, 0.0, 1.0 + eps])
    # with a margin the box grows: (2.2, 1, 1) is 0.3 m inside the grown face x = 2.5
    np.testing.assert_allclose(penalty(np.array([[2.2, 1.0, 1.0]]), box, 0.5, eps), [0.09 + eps])
    two = box + [UnsafeRegion([1.5, 0.0, 0.0], [4.0, 2.0, 2.0])]
    np.testing.assert_allclose(penalty(np.array([[1.8, 1.0, 1.0]]), two, 0.0, eps),
                               [0.04 + eps + 0.09 + eps])


def test_resample_is_exact_and_holds_the_end() -> None:
    path = plan(START, np.zeros(3), GOAL, [], CFG)
    assert path is not None
    for i in range(0, path.t.size, 7):
        at = resample(path, 0.05, t_start=float(path.t[i]), count=1)
        np.testing.assert_allclose(at.p[0], path.p[i], atol=1e-9)
        np.testing.assert_allclose(at.v[0], path.v[i], atol=1e-9)
    # Hermite interpolation reproduces the quadratic/cubic pieces between samples
    half = resample(path, 0.05, t_start=0.5 * float(path.t[1]), count=1)
    a0 = (path.v[1] - path.v[0]) / path.t[1]
    t = 0.5 * path.t[1]
    np.testing.assert_allclose(half.p[0], path.p[0] + path.v[0] * t + 0.5 * a0 * t * t, atol=1e-9)
    win = resample(path, 0.05, t_start=path.t[-1] - 0.1, count=21)
    assert win.p.shape == (21, 3)
    np.testing.assert_allclose(win.p[5:], np.tile(GOAL, (16, 1)), atol=1e-9)
    np.testing.assert_allclose(win.v[3:], 0.0, atol=1e-9)
    mid = resample(path, 0.01)
    step_len = np.linalg.norm(np.diff(mid.p, axis=0), axis=1)
    assert np.max(step_len) <= CFG.v_max_mps * 0.01 + 1e-6


@pytest.mark.parametrize("v0", [[1.5, 0.0, 0.0], [-1.0, 1.0, 0.0]])
def test_moving_start(v0: list[float]) -> None:
    path = plan(START, np.array(v0), GOAL, [], CFG)
    assert path is not None
    np.testing.assert_allclose(path.v[0], v0)


def _box(lo: tuple[float, float, float], hi: tuple[float, float, float], buffer_m: float = 5.0) -> UnsafeRegion:
    return UnsafeRegion(np.array(lo, dtype=float), np.array(hi, dtype=float), label="unknown", is_dynamic=True,
                        buffer_m=buffer_m, z_min=5.0)


def test_escape_distance_leaves_every_overlapping_region() -> None:
    from llmland_planner.regions import escape_distance_m

    a = _box((7.2, -13.5, -1.0), (17.6, -3.1, 5.0))
    b = _box((-2.3, -13.8, -1.0), (8.2, -3.3, 5.0))
    p = np.array([7.9, -5.6, 3.4])
    # alone, each box is left within 0.7 m (x faces); together, only up (1.6 m) or +y (2.5 m) leave both
    assert max(-a.signed_distance(p), -b.signed_distance(p)) == pytest.approx(0.7)
    assert escape_distance_m(p, [a, b]) == pytest.approx(1.6, abs=1e-5)
    assert escape_distance_m(np.array([0.0, 0.0, 6.0]), [a, b]) == 0.0


def test_a_start_inside_overlapping_keep_outs_has_a_way_out() -> None:
    """urban seed 27 through the pipeline: two 'unknown' things near the start got the most
    careful class (5 m buffer, overfly above 5 m); their boxes overlapped around the drone, the
    start clearance covered the depth in one box only, every search failed and the drone held at
    its start for the whole 90 s."""
    from dataclasses import replace

    from llmland_planner.replanning import START_CLEARANCE_MARGIN_M, start_clearance_m

    regions = [_box((7.2, -13.5, -1.0), (17.6, -3.1, 5.0)), _box((-2.3, -13.8, -1.0), (8.2, -3.3, 5.0))]
    start, goal = np.array([7.9, -5.6, 3.4]), np.array([0.2, 0.1, 3.5])
    cfg = replace(CFG, workspace_lo=(-20.0, -20.0, -1.0), workspace_hi=(20.0, 20.0, 12.0), z_floor_m=3.1)
    old = max(-r.signed_distance(start) for r in regions) + START_CLEARANCE_MARGIN_M
    assert plan(start, np.zeros(3), goal, regions, replace(cfg, clearance_radius_m=old)) is None
    path = plan(start, np.zeros(3), goal, regions, replace(cfg, clearance_radius_m=start_clearance_m(start, regions)))
    assert path is not None
    outside_ball = np.linalg.norm(path.p - start, axis=1) > start_clearance_m(start, regions)
    assert not np.any(segments_hit_boxes(path.p[:-1][outside_ball[1:]], path.p[1:][outside_ball[1:]],
                                         np.array([r.lo for r in regions]), np.array([r.hi for r in regions])))


@settings(max_examples=50, deadline=None)
@given(seed=st.integers(0, 2**31 - 1))
def test_segments_leaving_a_clearance_ball_are_cut_at_its_surface(seed: int) -> None:
    """The mixed segments (one end in a clearance ball) are checked only outside the ball: the
    inner end moves to where the segment enters the nearest ball, the outer end stays."""
    rng = np.random.default_rng(seed)
    start, goal = rng.uniform(-3.0, 3.0, 3), rng.uniform(-3.0, 3.0, 3)
    cfg = SearchConfig(clearance_radius_m=float(rng.uniform(0.3, 1.5)))
    chk = _Checker([], start, goal, cfg)
    a = np.concatenate([start + rng.normal(0.0, 0.8, (20, 3)), goal + rng.normal(0.0, 0.8, (20, 3))])
    b = a + rng.normal(0.0, 1.0, a.shape)
    ea, eb = chk.exempt(a), chk.exempt(b)
    ca, cb = chk._clip_to_balls(a, b, ea, eb)
    r = cfg.clearance_radius_m
    for i in range(len(a)):
        if ea[i] == eb[i]:  # both in or both out: untouched
            assert np.array_equal(ca[i], a[i]) and np.array_equal(cb[i], b[i])
            continue
        inner, outer, moved, kept = (a[i], b[i], ca[i], cb[i]) if ea[i] else (b[i], a[i], cb[i], ca[i])
        assert np.array_equal(kept, outer)
        centre = chk.centers[np.argmin(np.linalg.norm(chk.centers - inner, axis=1))]
        # on the segment, on the sphere (or at the inner end when the outer end is outside only by rounding)
        assert np.linalg.norm(np.cross(moved - outer, inner - outer)) < 1e-9
        assert abs(np.linalg.norm(moved - centre) - r) < 1e-6 or np.allclose(moved, inner)


@pytest.mark.parametrize("xy", [(-40.0, -2.0, -36.0, 6.0), (-2.0, -40.0, 6.0, -36.0), (40.0, -2.0, 44.0, 6.0)])
def test_a_tall_region_wholly_outside_the_free_distance_grid_changes_no_distance(
        xy: tuple[float, float, float, float]) -> None:
    # the plan-view free distance (the heuristic's lower bound) once marked a band across its grid
    # for a building wholly west or south of it: negative slice ends count from the far side
    cfg = SearchConfig(workspace_hi=(100.0, 100.0, 10.0))
    far = UnsafeRegion(np.array([xy[0], xy[1], -1.0]), np.array([xy[2], xy[3], 15.0]))
    alone = _FreeDistance([], START, GOAL, cfg)
    beside = _FreeDistance([far], START, GOAL, cfg)
    np.testing.assert_array_equal(beside.dist, alone.dist)


def test_a_cancelled_search_returns_none_at_its_next_expansion() -> None:
    import threading

    cancel = threading.Event()
    assert plan(START, np.zeros(3), GOAL, [], CFG, cancel=cancel) is not None  # free space
    cancel.set()
    assert plan(START, np.zeros(3), GOAL, [], CFG, cancel=cancel) is None


#: a keep-out too tall to fly over, 8.4 m wide, between the start and the goal (open_field seed
#: 34's tree, as the planner keeps it out with its unseen top)
WIDE_WALL = UnsafeRegion(np.array([0.7, -7.8, -1.0]), np.array([9.0, 1.1, 10.5]))
WALL_CFG = SearchConfig(time_budget_s=float("inf"), max_expansions=20000, workspace_hi=(100.0, 100.0, 10.0),
                        clearance_radius_m=0.8)


@pytest.mark.parametrize("face_x", [9.05, 9.2, 9.4])
def test_beside_a_tall_wall_the_free_distance_is_the_way_round_not_the_straight_line(face_x: float) -> None:
    # the grid blocks every cell the wall touches, up to one cell past its face; a point there
    # once fell back to the straight line through the wall: a hole in the heuristic along the face
    start, goal = np.array([9.6, -4.4, 3.5]), np.array([-0.1, -0.3, 4.0])
    free = _FreeDistance([WIDE_WALL], start, goal, WALL_CFG)
    beside = np.array([[face_x, -1.0, 3.5]])  # along the face, away from the start's clearance ball
    way_round = np.hypot(face_x - 9.0, 2.1) + 8.3 + np.hypot(0.8, 1.4)  # round the north-east corner (the shorter)
    assert free(beside)[0] >= way_round - 2.0 * WALL_CFG.grid_res_m
    assert free(beside)[0] > np.linalg.norm(beside[0, :2] - goal[:2]) + 2.0  # not through the wall


def test_a_way_round_a_wide_tall_wall_from_its_face_is_found_within_the_first_budget() -> None:
    # open_field seed 34 (llm-land): starting at the face of a tree's keep-out, every search failed
    # at every budget up to ×16 (6,400 expansions) for the 90 s of the episode
    start, goal = np.array([9.2, -4.4, 3.5]), np.array([-0.1, -0.3, 4.0])
    path = plan(start, np.zeros(3), goal, [WIDE_WALL], WALL_CFG)
    assert path is not None
    _assert_clear(path, [WIDE_WALL], WALL_CFG)
    assert path.expansions <= 400, path.expansions  # the lockstep budget of a first search


def _pocket_with_a_slit() -> list[UnsafeRegion]:
    """Tall walls (to 10.5 m, above the 10 m ceiling) round a 6 m pocket at the origin whose only
    way out is a 0.7 m slit in its west wall; the goal lies east, beyond the east wall."""
    walls = [((-9.0, 3.0), (9.0, 4.5)), ((-9.0, -4.5), (9.0, -3.0)), ((3.0, -4.5), (4.5, 4.5)),
             ((-4.5, 0.35), (-3.0, 4.5)), ((-4.5, -4.5), (-3.0, -0.35))]
    return [UnsafeRegion(np.array([x0, y0, -1.0]), np.array([x1, y1, 10.5]), obj_id=f"w{i}")
            for i, ((x0, y0), (x1, y1)) in enumerate(walls)]


def test_a_start_enclosed_but_for_a_slit_reads_the_way_round() -> None:
    """urban seed 12 alone at fixed:40: the vehicle held in a pocket whose exits (a 0.7 m slit, a
    1.2 m lane) the free-distance grid closed, since it blocks every cell a box touches. The start
    read the straight line through the walls and every search spent its budget in the pocket."""
    from dataclasses import replace

    regions = _pocket_with_a_slit()
    start, goal = np.array([0.0, 0.0, 4.0]), np.array([12.0, 0.0, 4.0])
    cfg = replace(CFG, clearance_radius_m=0.3, z_floor_m=3.0, workspace_lo=(-20.0, -20.0, -1.0),
                  workspace_hi=(20.0, 20.0, 10.0), max_expansions=6400)
    free = _FreeDistance(regions, start, goal, cfg)
    assert float(free(start[None])[0]) > 30.0  # out west through the slit, round a wall, back east
    path = plan(start, np.zeros(3), goal, regions, cfg)
    assert path is not None
    assert path.p[:, 0].min() < -4.5  # it left through the slit
    _assert_clear(path, regions, cfg)
