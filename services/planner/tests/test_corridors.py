"""Tests of convex safe corridors: exclusion of every box (LP-verified) and segment containment."""

from __future__ import annotations

import numpy as np
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from llmland_planner.corridors import (
    Corridor,
    active_halfspaces,
    corridor_for_segment,
    corridors_for_path,
    halfspaces_at_times,
)
from llmland_planner.regions import UnsafeRegion, from_obstacle
from llmland_planner.search import SearchConfig, plan
from scipy.optimize import linprog

coord = st.floats(-5.0, 5.0, allow_nan=False)
size = st.floats(0.05, 3.0, allow_nan=False)
point = st.tuples(coord, coord, coord).map(np.array)
box = st.tuples(point, st.tuples(size, size, size).map(np.array)).map(
    lambda t: UnsafeRegion(t[0], t[0] + t[1]))


def _overlap_depth(cor: Corridor, region: UnsafeRegion) -> float:
    """max t s.t. a ball-ish point is t inside both polytope rows and the box (t < 0 ⇒ disjoint)."""
    k = cor.A.shape[0]
    a_ub = np.vstack([np.hstack([cor.A, np.ones((k, 1))]),
                      np.hstack([-np.eye(3), np.ones((3, 1))]),
                      np.hstack([np.eye(3), np.ones((3, 1))])])
    b_ub = np.concatenate([cor.b, -region.lo, region.hi])
    res = linprog(np.array([0, 0, 0, -1.0]), A_ub=a_ub, b_ub=b_ub,
                  bounds=[(None, None)] * 3 + [(None, 10.0)], method="highs")
    assert res.status == 0
    return float(-res.fun)


def _gap_inf(a: np.ndarray, b: np.ndarray, region: UnsafeRegion) -> float:
    """∞-norm distance between segment ``a→b`` and a box, by LP over ``(t, q, r)``."""
    d = b - a
    a_ub, b_ub = [], []
    for i in range(3):  # |a_i + t d_i − q_i| ≤ r
        e = np.zeros(5)
        e[0], e[1 + i], e[4] = d[i], -1.0, -1.0
        a_ub.append(e)
        b_ub.append(-a[i])
        e2 = -e
        e2[4] = -1.0
        a_ub.append(e2)
        b_ub.append(a[i])
    bounds = [(0.0, 1.0)] + [(float(region.lo[i]), float(region.hi[i])) for i in range(3)]
    res = linprog(np.array([0, 0, 0, 0, 1.0]), A_ub=np.array(a_ub), b_ub=np.array(b_ub),
                  bounds=bounds + [(0.0, None)], method="highs")
    assert res.status == 0
    return float(res.fun)


@settings(max_examples=120, deadline=None)
@given(st.lists(box, min_size=1, max_size=6), point, point)
def test_corridor_excludes_boxes_and_contains_clear_segment(regions: list[UnsafeRegion],
                                                            a: np.ndarray, b: np.ndarray) -> None:
    gap = min(_gap_inf(a, b, r) for r in regions)
    assume(not 1e-9 < gap < 1e-4)  # skip near-tangent segments (tolerance ambiguity)
    clear = gap >= 1e-4
    cor = corridor_for_segment(a, b, regions, max_halfspaces=6 + len(regions))
    assert cor is not None
    assert cor.segment_clear == clear
    np.testing.assert_allclose(np.linalg.norm(cor.A, axis=1), 1.0)
    for r in regions:
        assert _overlap_depth(cor, r) < 0.0
    if clear:
        assert cor.contains(a, tol=0.0) and cor.contains(b, tol=0.0)
        assert np.all(cor.A @ a < cor.b) and np.all(cor.A @ b < cor.b)


def test_corridors_for_planned_path() -> None:
    regions = (from_obstacle([3.0, 0.5], 0.5, 1.8, 0.5, 3.0)
               + from_obstacle([6.0, -1.0], 0.8, 1.8, 0.5, 3.0)
               + from_obstacle([4.5, 2.5], 0.4, 1.8, 0.5, 3.0))
    path = plan(np.array([0.0, 0.0, 2.0]), np.zeros(3), np.array([8.0, 0.0, 1.5]), regions,
                SearchConfig(time_budget_s=float("inf")))  # bounded by expansions, not wall time
    assert path is not None
    cors = corridors_for_path(path, regions, max_halfspaces=8)
    assert cors and cors[0].t0 == 0.0 and cors[-1].t1 == path.t[-1]
    for c in cors:
        assert c.A.shape[0] <= 8 and c.segment_clear
        assert c.seg_a is not None and c.seg_b is not None
        assert c.contains(c.seg_a) and c.contains(c.seg_b)
        for r in regions:
            assert _overlap_depth(c, r) < 0.0
    for c0, c1 in zip(cors[:-1], cors[1:], strict=True):
        assert c0.t1 == c1.t0
    # every path sample lies in the corridor of its time, up to the chord tolerance
    rows = halfspaces_at_times(cors, path.t, 8)
    viol = [np.max(a @ p - b) for (a, b), p in zip(rows, path.p, strict=True)]
    assert max(viol) < 0.12


def test_many_boxes_respect_row_budget() -> None:
    regions = [UnsafeRegion([x, y, -1.0], [x + 0.3, y + 0.3, 3.0])
               for x in np.arange(-3.0, 3.0, 0.8) for y in (-1.0, 0.7)]
    from llmland_planner.path import Path
    t = np.linspace(0.0, 6.0, 61)
    pts = np.stack([t - 3.0, np.zeros_like(t), np.full_like(t, 1.0)], axis=1)
    path = Path(t, pts, np.tile([1.0, 0.0, 0.0], (61, 1)))
    cors = corridors_for_path(path, regions, max_halfspaces=8)
    for c in cors:
        assert c.A.shape[0] <= 8 and c.segment_clear
        for r in regions:
            assert _overlap_depth(c, r) < 0.0


def test_active_halfspaces_padding() -> None:
    cor = corridor_for_segment(np.zeros(3), np.ones(3), [])
    assert cor is not None and cor.A.shape == (6, 3)
    a, b = active_halfspaces(cor, 8)
    assert a.shape == (8, 3) and b.shape == (8,)
    np.testing.assert_allclose(a[6:], 0.0)
    assert np.all(a[6:] @ np.array([1e3, 1e3, 1e3]) <= b[6:])
    none_a, none_b = active_halfspaces(None, 5)
    assert none_a.shape == (5, 3) and np.all(none_b > 0)
