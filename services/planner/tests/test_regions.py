"""Tests of unsafe-region boxes: construction, point queries, segment tests."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from llmland_planner.regions import UnsafeRegion, from_obstacle, points_in_boxes, segment_hits


def test_static_obstacle_box() -> None:
    (r,) = from_obstacle([1.0, 2.0], half_size_m=0.3, height_m=1.7, buffer_m=1.0, z_min=3.0,
                         obj_id="p1", label="person")
    np.testing.assert_allclose(r.lo, [-0.3, 0.7, -1.0])
    np.testing.assert_allclose(r.hi, [2.3, 3.3, 3.0])
    assert not r.is_dynamic and r.obj_id == "p1" and r.label == "person"
    (tall,) = from_obstacle([0, 0], 0.5, 5.0, 0.5, 3.0)
    assert tall.hi[2] == pytest.approx(5.5)


def test_dynamic_obstacle_sweep() -> None:
    boxes = from_obstacle([0.0, 0.0], 0.5, 1.0, 0.5, 2.0, velocity_xy=[1.0, 1.0],
                          horizon_s=1.0, dt_s=0.25)
    assert len(boxes) == 4 and all(b.is_dynamic for b in boxes)
    np.testing.assert_allclose(boxes[0].lo[:2], [-1.0, -1.0])
    np.testing.assert_allclose(boxes[-1].hi[:2], [2.0, 2.0])
    # slices are less conservative than the single swept bounding box
    corner = np.array([1.8, -0.8, 1.0])
    assert not any(b.contains(corner) for b in boxes)
    for t in np.linspace(0, 1, 9):  # the obstacle centre is always covered
        assert any(b.contains([t, t, 0.5]) for b in boxes)


def test_contains_and_signed_distance() -> None:
    r = UnsafeRegion([0, 0, 0], [2, 2, 2])
    assert r.contains([1, 1, 1]) and r.contains([2, 2, 2]) and not r.contains([2.1, 1, 1])
    assert r.contains([2.1, 1, 1], margin_m=0.2)
    assert r.signed_distance([1, 1, 1]) == pytest.approx(-1.0)
    assert r.signed_distance([1.5, 1, 1]) == pytest.approx(-0.5)
    assert r.signed_distance([3, 1, 1]) == pytest.approx(1.0)
    assert r.signed_distance([3, 3, 1]) == pytest.approx(np.sqrt(2))
    with pytest.raises(ValueError):
        UnsafeRegion([1, 0, 0], [0, 1, 1])


def test_segment_hits() -> None:
    r = UnsafeRegion([0, 0, 0], [1, 1, 1])
    assert segment_hits([-1, 0.5, 0.5], [2, 0.5, 0.5], r)  # through
    assert segment_hits([0.5, 0.5, 0.5], [0.6, 0.6, 0.6], r)  # inside
    assert not segment_hits([-1, 2, 0.5], [2, 2, 0.5], r)  # parallel, outside slab
    assert not segment_hits([-1, 0.5, 0.5], [-0.1, 0.5, 0.5], r)  # stops short
    assert segment_hits([-1, -1, 0.5], [2, 2, 0.5], r)  # diagonal
    assert not segment_hits([-0.5, 0.6, 0.5], [0.4, 1.5, 0.5], r)  # misses the corner


def test_segment_hits_agrees_with_dense_sampling() -> None:
    rng = np.random.default_rng(1)
    r = UnsafeRegion([0, 0, 0], [1, 1, 1])
    for _ in range(200):
        a, b = rng.uniform(-1, 2, 3), rng.uniform(-1, 2, 3)
        pts = a + np.linspace(0, 1, 2001)[:, None] * (b - a)
        sampled = bool(np.any(np.all((pts >= r.lo) & (pts <= r.hi), axis=1)))
        if sampled:
            assert segment_hits(a, b, r)


def test_box_footprint_keeps_its_sides_and_covers_the_buffer() -> None:
    # a 20 m × 4 m wall: its keep-out is 20 + 2b by 4 + 2b, not the square around its half diagonal
    (r,) = from_obstacle([0.0, 0.0], half_size_m=[10.0, 2.0], height_m=6.0, buffer_m=1.5, z_min=0.0)
    np.testing.assert_allclose(r.lo[:2], [-11.5, -3.5])
    np.testing.assert_allclose(r.hi[:2], [11.5, 3.5])
    # every point within the buffer (Euclidean) of the footprint is inside: along each side and past each corner
    rng = np.random.default_rng(0)
    for _ in range(500):
        on_footprint = rng.uniform([-10.0, -2.0], [10.0, 2.0])
        angle, dist = rng.uniform(0.0, 2 * np.pi), rng.uniform(0.0, 1.5)
        p = on_footprint + dist * np.array([np.cos(angle), np.sin(angle)])
        assert r.contains([p[0], p[1], 1.0])
    with pytest.raises(ValueError, match="negative half size"):
        from_obstacle([0.0, 0.0], half_size_m=[-1.0, 2.0], height_m=1.0, buffer_m=0.0, z_min=0.0)


@settings(max_examples=200, deadline=None)
@given(seed=st.integers(0, 2**31 - 1))
def test_a_keep_out_holding_the_vehicle_shrinks_to_its_present_distance(seed: int) -> None:
    """``no_closer_than_now``: the vehicle ends just outside the shrunk box; every point outside
    the shrunk box is at least as far (Chebyshev, plan view) from the thing as the vehicle is; the
    box never grows, and dynamic boxes and boxes not holding the vehicle are left as they are."""
    from llmland_planner.regions import POSSIBLE_PERSON, SHRINK_EPS_M, no_closer_than_now

    rng = np.random.default_rng(seed)
    half, buffer = rng.uniform(0.1, 2.0, 2), float(rng.uniform(0.5, 4.0))
    (box,) = from_obstacle((0.0, 0.0), half, float(rng.uniform(0.5, 3.0)), buffer, 0.0)
    person = from_obstacle((0.0, 0.0), 0.3, 1.8, buffer, 3.0, is_dynamic=True)[0]
    (stopped,) = from_obstacle((0.0, 0.0), 0.3, 1.8, buffer, 0.0)  # walked, then stood: a still box
    stopped.meta[POSSIBLE_PERSON] = 1.0
    sweep = from_obstacle((0.0, 0.0), 0.3, 1.8, buffer, 0.0, velocity_xy=(0.1, 0.0), horizon_s=1.0,
                          is_dynamic=False)
    p = rng.uniform(box.lo, box.hi)
    shrunk, *kept = no_closer_than_now(p, [box, person, stopped, *sweep])
    assert all(a is b for a, b in zip(kept, [person, stopped, *sweep], strict=True))
    assert np.all(shrunk.lo >= box.lo - 1e-12) and np.all(shrunk.hi <= box.hi + 1e-12)
    c = float(np.max(np.abs(p[:2]) - half))  # Chebyshev distance from the footprint (m)
    if c <= SHRINK_EPS_M:
        assert shrunk is box  # over the thing: left to the start's clearance ball
        return
    assert not shrunk.contains(p)
    assert shrunk.lo[2] == box.lo[2] and shrunk.hi[2] == box.hi[2]
    q = rng.uniform(box.lo, box.hi, (500, 3))
    outside = ~points_in_boxes(q, shrunk.lo[None], shrunk.hi[None])[:, 0]
    assert np.all(np.max(np.abs(q[outside, :2]) - half, axis=1) >= c - SHRINK_EPS_M - 1e-9)
