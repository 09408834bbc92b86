"""The terrain estimate and the hard limit's reach floor over it: over a mound, paths and holds stay
above the head of anyone standing within reach, whatever the estimate's cell rounding."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from llmland_planner.ground import MAX_SLOPE, GroundMap
from llmland_planner.hard_limit import REACH_CEILING_M
from llmland_planner.search import SearchConfig, plan
from llmland_schemas import PERSON_HARD_LIMIT_M

TARGET = np.zeros(3)
HALF_M = 12.0  # the observed square around the target (m)


def _terrain(height_m: float, sigma_m: float, centre: tuple[float, float], tilt: tuple[float, float]):
    """A Gaussian mound on a tilted plane: ground height (m) at plan-view points ``(..., 2)``."""
    c = np.asarray(centre)

    def ground(xy: np.ndarray) -> np.ndarray:
        d2 = np.sum((xy - c) ** 2, axis=-1)
        return height_m * np.exp(-0.5 * d2 / sigma_m**2) + xy[..., 0] * tilt[0] + xy[..., 1] * tilt[1]

    return ground


def _observed(ground, rng: np.random.Generator, spacing_m: float = 0.25) -> GroundMap:
    """A ground map fed with ground points over the square, and a few objects' tops above it."""
    g = np.arange(-HALF_M, HALF_M, spacing_m)
    xy = np.stack(np.meshgrid(g, g, indexing="ij"), axis=-1).reshape(-1, 2) + rng.uniform(0, spacing_m, (g.size**2, 2))
    pts = np.column_stack([xy, ground(xy)])
    tops = rng.uniform(-HALF_M, HALF_M, (40, 2))
    objects = np.column_stack([tops, ground(tops) + rng.uniform(0.5, 3.0, 40)])  # a car roof, a bush
    gm = GroundMap(TARGET)
    gm.stage(0.0, "down", np.vstack([pts, objects]))
    gm.commit(0.0)
    return gm


@settings(max_examples=40, deadline=None)
@given(height=st.floats(0.0, 0.9), centre=st.tuples(st.floats(-6.0, 6.0), st.floats(-6.0, 6.0)),
       tilt=st.tuples(st.floats(-0.07, 0.07), st.floats(-0.07, 0.07)), seed=st.integers(0, 2**31 - 1))
def test_the_floor_is_above_every_head_within_reach(height: float, centre: tuple[float, float],
                                                    tilt: tuple[float, float], seed: int) -> None:
    """Terrain no steeper than the estimate's slope bound: for vehicle positions over the observed
    square and people anywhere within the hard limit horizontally, the floor is at least the
    reach ceiling above the ground the person stands on."""
    rng = np.random.default_rng(seed)
    sigma = max(2.0, height * np.exp(-0.5) / (MAX_SLOPE - 0.15))  # mound slope + tilt <= MAX_SLOPE
    ground = _terrain(height, sigma, centre, tilt)
    floor = _observed(ground, rng).reach_floor(PERSON_HARD_LIMIT_M, REACH_CEILING_M)
    vehicle = rng.uniform(-HALF_M + 2.0, HALF_M - 2.0, (300, 2))
    angle, r = rng.uniform(0, 2 * np.pi, 300), PERSON_HARD_LIMIT_M * np.sqrt(rng.uniform(0, 1, 300))
    person = vehicle + np.column_stack([r * np.cos(angle), r * np.sin(angle)])
    assert np.all(floor(vehicle) >= ground(person) + REACH_CEILING_M)


def test_a_mound_raises_the_floor_within_reach_of_it_only() -> None:
    ground = _terrain(0.8, 3.0, (0.0, 6.0), (0.0, 0.0))
    floor = _observed(ground, np.random.default_rng(1)).reach_floor(PERSON_HARD_LIMIT_M, REACH_CEILING_M)
    on_top = float(floor(np.array([0.0, 6.0])))
    assert on_top >= 0.8 + REACH_CEILING_M
    assert float(floor(np.array([0.0, -6.0]))) < on_top - 0.6  # flat ground 12 m away
    assert floor.lowest_m <= float(floor(np.array([0.0, -6.0])))


def test_a_path_over_a_mound_keeps_the_floor_above_it() -> None:
    """The search reads the floor point by point: a path across a mound climbs over it (a scalar
    floor at the target's height flew 0.8 m closer to the heads on top)."""
    ground = _terrain(0.8, 3.0, (0.0, 0.0), (0.0, 0.0))
    floor = _observed(ground, np.random.default_rng(2)).reach_floor(PERSON_HARD_LIMIT_M, REACH_CEILING_M + 0.1)
    start, goal = np.array([-8.0, 0.0, 3.6]), np.array([8.0, 0.0, 3.6])
    assert floor(start[:2]) <= start[2] and floor(goal[:2]) <= goal[2]
    cfg = SearchConfig(time_budget_s=float("inf"), max_expansions=5000, z_floor_m=floor.lowest_m, floor_fn=floor)
    path = plan(start, np.zeros(3), goal, [], cfg)
    assert path is not None
    away = (np.linalg.norm(path.p - start, axis=1) > cfg.clearance_radius_m) & (
        np.linalg.norm(path.p - goal, axis=1) > cfg.clearance_radius_m)
    assert np.all(path.p[away, 2] >= floor(path.p[away, :2]) - 1e-9)
    assert path.p[:, 2].max() >= 0.8 + REACH_CEILING_M


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), frames=st.integers(1, 4))
def test_staged_frames_fold_in_as_their_points_would(seed: int, frames: int) -> None:
    """A frame staged as its per-cell minima and committed gives the estimate its points folded
    in one by one would (the same lowest heights, bit for bit), NaN and off-grid points ignored;
    the frozen surface's heights are those of :meth:`GroundMap.height` and its ``lowest_m`` is
    no higher than any of them."""
    rng = np.random.default_rng(seed)
    staged, direct = GroundMap(TARGET), GroundMap(TARGET)
    for k in range(frames):
        pts = np.column_stack([rng.uniform(-60.0, 60.0, (500, 2)), rng.normal(0.0, 1.0, 500)])
        pts[rng.random(500) < 0.1] = np.nan
        staged.stage(0.1 * k, "down", pts)
        np.minimum.at(direct._zmin, *_inside_cells(direct, pts))
    staged.commit(1.0)
    np.testing.assert_array_equal(staged._zmin, direct._zmin)
    xy = rng.uniform(-50.0, 50.0, (2, 300))
    surface = staged.surface()
    np.testing.assert_array_equal(surface(xy[0], xy[1]), staged.height(xy[0], xy[1]))
    assert surface.lowest_m <= float(np.min(surface(xy[0], xy[1])))
    assert surface.lowest_m == min(float(staged._ground.min()), float(TARGET[2]))


def _inside_cells(gm: GroundMap, pts: np.ndarray) -> tuple[tuple[np.ndarray, np.ndarray], np.ndarray]:
    """``np.minimum.at`` arguments folding the finite, on-grid points ``(N, 3)`` into ``gm``'s minima."""
    p = pts[np.all(np.isfinite(pts), axis=1)]
    i = np.floor((p[:, 0] - gm.origin[0]) / gm.cell).astype(np.int64)
    j = np.floor((p[:, 1] - gm.origin[1]) / gm.cell).astype(np.int64)
    inside = (i >= 0) & (i < gm.n) & (j >= 0) & (j < gm.n)
    return (i[inside], j[inside]), p[inside, 2]


def test_a_surface_is_the_commit_it_was_taken_at() -> None:
    """A surface taken before a commit keeps that commit's heights (a frame's blobs look at one
    estimate throughout, whatever the tick thread commits meanwhile)."""
    gm = GroundMap(TARGET)
    before = gm.surface()
    gm.stage(0.0, "down", np.array([[1.5, 1.5, -2.0]]))
    gm.commit(0.0)
    assert float(before(np.array([1.5]), np.array([1.5]))[0]) == 0.0
    assert float(gm.height(np.array([1.5]), np.array([1.5]))[0]) == -2.0
    assert gm.surface().lowest_m == -2.0 and before.lowest_m == 0.0
