"""find_blobs on synthetic depth images ray-cast analytically from boxes on the ground plane."""

from __future__ import annotations

import logging
import time

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from llmland_schemas import CameraIntrinsics
from llmland_schemas.depth import backproject, backproject_planes, find_blobs, ground_mask

log = logging.getLogger(__name__)

W = H = 384


def K() -> CameraIntrinsics:  # noqa: N802 (the camera matrix's name)
    """Pinhole intrinsics (pixels), 90° field of view."""
    return CameraIntrinsics(fx=W / 2, fy=H / 2, cx=(W - 1) / 2, cy=(H - 1) / 2, width=W, height=H)


def camera_pose(position_m: tuple[float, float, float], pitch_down_rad: float) -> np.ndarray:
    """(4, 4) T_world_camera for a camera facing world +x, pitched down (optical x right, y down)."""
    f = np.array([np.cos(pitch_down_rad), 0.0, -np.sin(pitch_down_rad)])
    r = np.array([0.0, -1.0, 0.0])
    d = np.cross(f, r)
    T = np.eye(4)
    T[:3, :3] = np.column_stack([r, d, f])
    T[:3, 3] = position_m
    return T


def raycast(T: np.ndarray, boxes: list[tuple[np.ndarray, np.ndarray]], far_m: float = 100.0) -> np.ndarray:
    """(H, W) float32 z-depth of the ground plane z=0 and axis-aligned boxes (lo, hi); inf = no hit."""
    k = K()
    u, v = np.meshgrid(np.arange(W, dtype=np.float64), np.arange(H, dtype=np.float64))
    rays_cam = np.stack([(u - k.cx) / k.fx, (v - k.cy) / k.fy, np.ones_like(u)], axis=-1)
    dirs = rays_cam @ T[:3, :3].T  # camera z component is 1, so ray parameter t = z-depth
    origin = T[:3, 3]
    with np.errstate(divide="ignore", invalid="ignore"):
        t_best = np.where(dirs[..., 2] < 0, -origin[2] / dirs[..., 2], np.inf)
        for lo, hi in boxes:
            t0 = (lo - origin) / dirs
            t1 = (hi - origin) / dirs
            t_near = np.nanmax(np.minimum(t0, t1), axis=-1)
            t_far = np.nanmin(np.maximum(t0, t1), axis=-1)
            hit = (t_near <= t_far) & (t_near > 0)
            t_best = np.where(hit & (t_near < t_best), t_near, t_best)
    t_best[t_best > far_m] = np.inf
    return t_best.astype(np.float32)


def box(cx: float, cy: float, sx: float, sy: float, sz: float) -> tuple[np.ndarray, np.ndarray]:
    """Box of footprint centre (cx, cy), size (sx, sy, sz) standing on z = 0."""
    return np.array([cx - sx / 2, cy - sy / 2, 0.0]), np.array([cx + sx / 2, cy + sy / 2, sz])


BOXES = [box(10.0, -2.0, 1.0, 1.0, 1.5), box(12.0, 2.5, 0.8, 0.8, 1.8)]
POSE = camera_pose((0.0, 0.0, 8.0), np.radians(40.0))


def match(blobs: list, truth: list[tuple[np.ndarray, np.ndarray]]) -> list:
    """Blob nearest (horizontally) to each true box."""
    return [min(blobs, key=lambda b: np.linalg.norm(b.centroid_m[:2] - (lo[:2] + hi[:2]) / 2)) for lo, hi in truth]


def test_backproject_roundtrip() -> None:
    depth = raycast(POSE, [])
    pts = backproject(depth, K(), POSE, stride=4)
    assert pts.shape == (H // 4, W // 4, 3)
    finite = np.isfinite(pts[..., 0])
    assert finite.any() and not finite.all()  # sky rows are NaN
    assert np.allclose(pts[finite][:, 2], 0.0, atol=1e-6)
    assert ground_mask(pts).sum() == finite.sum()
    bumpy = ground_mask(pts, lambda x, y: 0.2 + 0 * x, tol_m=0.15)
    assert bumpy.sum() == finite.sum()  # points below the ground count as ground


def test_two_boxes() -> None:
    depth = raycast(POSE, BOXES)
    find_blobs(depth, K(), POSE)  # warm-up
    t0 = time.perf_counter()
    blobs = find_blobs(depth, K(), POSE)
    log.info("find_blobs %dx%d stride 2: %.2f ms", W, H, 1e3 * (time.perf_counter() - t0))
    assert len(blobs) == 2
    assert [b.blob_id for b in blobs] == [0, 1]
    for b, (lo, hi) in zip(match(blobs, BOXES), BOXES, strict=True):
        assert np.linalg.norm(b.centroid_m[:2] - (lo[:2] + hi[:2]) / 2) < 0.3
        assert np.allclose(b.lo_m, lo, atol=0.3), (b.lo_m, lo)
        assert np.allclose(b.hi_m, hi, atol=0.3), (b.hi_m, hi)
        assert np.allclose(b.size_m, b.hi_m - b.lo_m)
        assert b.lo_m[2] == 0.0
        assert 0.3 < b.footprint_radius_m < 0.9
        u0, v0, u1, v1 = b.bbox_px
        assert 0 <= u0 < u1 <= W and 0 <= v0 < v1 <= H
        assert np.isfinite(depth[v0:v1, u0:u1]).all()


def test_touching_in_image_at_different_depths() -> None:
    """A short box in front of a tall one: adjacent in the image, split by the depth jump."""
    pose = camera_pose((0.0, 0.0, 1.2), np.radians(5.0))
    boxes = [box(8.0, 0.0, 1.0, 1.0, 1.5), box(11.0, 0.5, 1.0, 1.0, 3.0)]
    blobs = find_blobs(raycast(pose, boxes), K(), pose)
    assert len(blobs) == 2
    for b, (lo, hi) in zip(match(blobs, boxes), boxes, strict=True):
        assert abs(b.centroid_m[1] - (lo[1] + hi[1]) / 2) < 0.3
        assert b.size_m[0] < 0.3  # only the front face is visible: bounds are thin in x
        assert abs(b.lo_m[0] - lo[0]) < 0.1
        assert abs(b.hi_m[2] - hi[2]) < 0.3


def test_ground_only_gives_no_blob() -> None:
    assert find_blobs(raycast(POSE, []), K(), POSE) == []


def test_invalid_depth_handled() -> None:
    depth = raycast(POSE, BOXES)
    depth[:40] = np.nan
    depth[40:80] = 0.0
    depth[:, :10] = np.inf
    assert len(find_blobs(depth, K(), POSE)) == 2
    assert find_blobs(np.full((H, W), np.inf, np.float32), K(), POSE) == []
    assert find_blobs(np.full((H, W), np.nan, np.float32), K(), POSE) == []


def test_range_and_min_points() -> None:
    depth = raycast(POSE, BOXES)
    assert find_blobs(depth, K(), POSE, max_range_m=5.0) == []
    assert find_blobs(depth, K(), POSE, min_points=100_000) == []


def test_raised_ground() -> None:
    """Same image seen from 0.5 m higher is the scene on a ground at z = 0.5."""
    depth = raycast(POSE, BOXES)
    raised = POSE.copy()
    raised[2, 3] += 0.5
    assert len(find_blobs(depth, K(), raised)) > 2  # flat-ground assumption: the ground is an obstacle
    blobs = find_blobs(depth, K(), raised, ground_height_fn=lambda x, y: np.full_like(x, 0.5))
    assert len(blobs) == 2
    for b, (lo, hi) in zip(match(blobs, BOXES), BOXES, strict=True):
        assert np.allclose(b.lo_m, lo + [0, 0, 0.5], atol=0.3)
        assert np.allclose(b.hi_m, hi + [0, 0, 0.5], atol=0.3)


def test_blobs_cut_by_an_image_edge_say_so() -> None:
    """Whole in view: not cut. Cut by the image's left edge (a box far to the camera's left,
    straddling the frustum's side): ``touches_border``; its bounds are partly the view's."""
    whole = find_blobs(raycast(POSE, BOXES), K(), POSE)
    assert whole and not any(b.touches_border for b in whole)
    # the left edge of a 90° camera at x=10 m ahead (8 m up, 40° down, slant ≈ 12.8 m) is y ≈ +12.8 m
    straddling = [box(10.0, 12.5, 1.0, 3.0, 1.5)]
    cut = find_blobs(raycast(POSE, straddling), K(), POSE)
    assert len(cut) == 1 and cut[0].touches_border and cut[0].bbox_px[0] == 0
    assert not cut[0].touches_top


def test_backproject_is_the_vector_formula_bit_for_bit() -> None:
    """The plane-by-plane back-projection gives the same bits as ``d * (R @ ray) + t`` written as
    one vector expression (what it replaced), so a speed-up cannot move an obstacle."""
    rng = np.random.default_rng(7)
    k = K()
    for stride in (1, 2, 3):
        q, _ = np.linalg.qr(rng.standard_normal((3, 3)))
        pose = np.eye(4)
        pose[:3, :3], pose[:3, 3] = q, rng.uniform(-5.0, 5.0, 3)
        depth = rng.uniform(0.5, 40.0, (H, W)).astype(np.float32)
        depth[rng.random((H, W)) < 0.1] = np.inf
        d = np.asarray(depth, dtype=np.float64)[::stride, ::stride]
        d = np.where(np.isfinite(d) & (d > 0.0), d, np.nan)
        xn, yn = k.normalized(np.arange(d.shape[1]) * float(stride), np.arange(d.shape[0]) * float(stride))
        rays = xn[None, :, None] * q[:, 0] + yn[:, None, None] * q[:, 1] + q[:, 2]
        np.testing.assert_array_equal(backproject(depth, k, pose, stride), d[:, :, None] * rays + pose[:3, 3])


def test_find_blobs_with_or_without_given_points() -> None:
    """Points given interleaved or as planes (no copy) give the same blobs, bit for bit."""
    depth = raycast(POSE, BOXES)
    pts = backproject(depth, K(), POSE, stride=2)
    planes = backproject_planes(depth, K(), POSE, stride=2)
    np.testing.assert_array_equal(np.moveaxis(planes, 0, -1), pts)
    a = find_blobs(depth, K(), POSE, stride=2, min_points=5)
    for b in (find_blobs(depth, K(), POSE, stride=2, min_points=5, points_world=pts),
              find_blobs(depth, K(), POSE, stride=2, min_points=5, points_planes=planes)):
        assert len(a) == len(b) > 0
        for x, y in zip(a, b, strict=True):
            for field in ("lo_m", "hi_m", "mean_m", "centroid_m"):
                np.testing.assert_array_equal(getattr(x, field), getattr(y, field))
            assert (x.n_points, x.bbox_px, x.footprint_radius_m) == (y.n_points, y.bbox_px, y.footprint_radius_m)


def test_squared_distance_sums_in_numpys_order() -> None:
    """The bit-for-bit argument rests on ``np.sum`` over a length-3 last axis adding
    ``(x + y) + z``; pin it, so a numpy that sums otherwise fails here, not in an episode."""
    from llmland_schemas.depth import _planes, _squared_distance

    rng = np.random.default_rng(3)
    a, b = rng.normal(0.0, 10.0, (50, 40, 3)), rng.normal(0.0, 10.0, (50, 40, 3))
    a[rng.random((50, 40)) < 0.1] = np.nan
    np.testing.assert_array_equal(_squared_distance(_planes(a), _planes(b)), np.sum((a - b) ** 2, axis=-1))


def test_find_blobs_takes_one_form_of_given_points() -> None:
    depth = raycast(POSE, BOXES)
    with pytest.raises(ValueError, match="not both"):
        find_blobs(depth, K(), POSE, points_world=backproject(depth, K(), POSE),
                   points_planes=backproject_planes(depth, K(), POSE))


@settings(max_examples=200, deadline=None)
@given(h=st.integers(1, 24), w=st.integers(1, 24), valid_p=st.floats(0.0, 1.0), nan_p=st.floats(0.0, 0.3),
       gap_m=st.floats(0.05, 4.0), seed=st.integers(0, 2**32 - 1))
def test_graph_and_grid_labelling_agree(h: int, w: int, valid_p: float, nan_p: float, gap_m: float, seed: int) -> None:
    """The two ways of labelling clusters give the same labels, numbered alike (raster order of a
    cluster's first pixel), whatever the fraction of valid pixels, NaN points or a one-pixel-wide
    image (rows must not wrap into each other, columns neither)."""
    from llmland_schemas.depth import _label_graph, _label_grid

    rng = np.random.default_rng(seed)
    planes = rng.normal(0.0, rng.uniform(0.1, 2.0), (3, h, w))
    planes[:, rng.random((h, w)) < nan_p] = np.nan
    valid = rng.random((h, w)) < valid_p
    grid_labels, grid_n = _label_grid(planes, valid, gap_m)
    graph_labels, graph_n = _label_graph(planes, valid, gap_m)
    assert graph_n == grid_n
    np.testing.assert_array_equal(graph_labels, grid_labels)


def test_sparse_and_dense_frames_take_both_labellings() -> None:
    """A frame of a few obstacles is labelled as a graph, a frame full of them as a grid; each
    gives what the other would."""
    from llmland_schemas import depth as d

    for boxes, expect_graph in ((BOXES, True), ([box(10.0, 0.0, 30.0, 30.0, 1.5)], False)):
        planes = backproject_planes(raycast(POSE, boxes), K(), POSE, 2)
        valid = planes[2] > 0.15
        assert (np.count_nonzero(valid) <= d.SPARSE_LABEL_MAX_FRACTION * valid.size) == expect_graph
        labels, n = d._label_edges(planes, valid, 0.6)
        other = d._label_grid if expect_graph else d._label_graph
        np.testing.assert_array_equal(labels, other(planes, valid, 0.6)[0])
        assert n == other(planes, valid, 0.6)[1] > 0


@settings(max_examples=100, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), floor_m=st.floats(-3.0, 3.0), tol_m=st.floats(0.0, 0.5))
def test_a_ground_floor_changes_no_answer(seed: int, floor_m: float, tol_m: float) -> None:
    """Points below the floor plus the tolerance are ground without a lookup: the same mask as
    looking every point up, with points right at the boundary, NaN points and heights above and
    at the floor."""
    from llmland_schemas.depth import _ground_mask_planes

    rng = np.random.default_rng(seed)
    planes = rng.normal(0.0, 5.0, (3, 20, 30))
    planes[2] = floor_m + rng.uniform(-1.0, 2.0, (20, 30))
    planes[2, :, :3] = floor_m + tol_m  # at the boundary (ground at the floor)
    planes[:, rng.random((20, 30)) < 0.1] = np.nan

    def ground(x: np.ndarray, y: np.ndarray) -> np.ndarray:  # at or above the floor everywhere
        return floor_m + np.where(np.sin(x) * np.cos(y) > 0.0, 0.0, np.abs(np.sin(x + y)))

    asked: list[int] = []

    def counting(x: np.ndarray, y: np.ndarray) -> np.ndarray:
        asked.append(np.size(x))
        return ground(x, y)

    full = _ground_mask_planes(planes, ground, tol_m)
    np.testing.assert_array_equal(_ground_mask_planes(planes, counting, tol_m, floor_m), full)
    assert sum(asked) <= planes[2].size


def test_find_blobs_with_a_ground_floor_finds_the_same_blobs() -> None:
    """On a raised scene (ground 0.5 m up): the same blobs with or without the floor."""
    depth = raycast(POSE, BOXES)
    raised = POSE.copy()
    raised[2, 3] += 0.5

    def ground(x: np.ndarray, y: np.ndarray) -> np.ndarray:
        return np.full_like(x, 0.5)

    a = find_blobs(depth, K(), raised, ground_height_fn=ground)
    b = find_blobs(depth, K(), raised, ground_height_fn=ground, ground_floor_m=0.5)
    assert len(a) == len(b) == 2
    for x, y in zip(a, b, strict=True):
        for field in ("lo_m", "hi_m", "mean_m", "centroid_m"):
            np.testing.assert_array_equal(getattr(x, field), getattr(y, field))
        assert (x.n_points, x.bbox_px, x.footprint_radius_m) == (y.n_points, y.bbox_px, y.footprint_radius_m)


def test_given_planes_in_any_memory_layout_give_the_same_blobs() -> None:
    """Planes given transposed or in Fortran order (a caller's own back-projection) give the blobs
    C-ordered planes give, with a ground floor too: the ground answers looked up are written into
    the mask, not into a copy of it (every looked-up point stayed "not ground": one 100-point blob
    of a plane 0.1 m above a 0.2 m ground)."""
    k = CameraIntrinsics(fx=10.0, fy=10.0, cx=5.0, cy=5.0, width=10, height=10)
    pose = np.eye(4)
    pose[:3, :3], pose[2, 3] = np.diag([1.0, -1.0, -1.0]), 5.0
    depth = np.full((10, 10), 4.7)  # a flat plane at z = 0.3

    def ground(x: np.ndarray, y: np.ndarray) -> np.ndarray:
        return np.full(np.shape(x), 0.2)

    planes = backproject_planes(depth, k, pose, 1)
    for layout in (planes, np.asfortranarray(planes)):
        for floor in (None, 0.0):
            assert find_blobs(depth, k, pose, stride=1, min_points=1, points_planes=layout,
                              ground_height_fn=ground, ground_floor_m=floor) == []
