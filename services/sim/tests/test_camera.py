"""RGB-D camera: intrinsics, optical-frame pose, metric depth, segmentation, renderers."""

from __future__ import annotations

import logging
import math
from collections.abc import Iterator

import numpy as np
import pybullet as p
import pytest
from llmland_schemas import CameraIntrinsics
from llmland_schemas.depth import backproject
from llmland_sim.camera import SKY_RGB, RgbdCamera
from llmland_sim.renderer import egl_available, prepare_renderer, release_renderer
from llmland_sim.world import build_world, shapes

logger = logging.getLogger(__name__)


@pytest.fixture(params=["tiny", "egl"])
def renderer(request: pytest.FixtureRequest) -> str:
    if request.param == "egl" and not egl_available():
        pytest.skip("EGL renderer not available on this machine")
    return str(request.param)


@pytest.fixture
def client() -> Iterator[int]:
    c = p.connect(p.DIRECT)
    yield c
    release_renderer(c)
    p.disconnect(c)


def test_intrinsics_match_fov() -> None:
    k = CameraIntrinsics.from_hfov(384, 384, 90.0)
    assert k.fx == pytest.approx(192.0) and k.fy == pytest.approx(192.0)
    assert (k.cx, k.cy) == (191.5, 191.5)
    assert k.vfov_deg == pytest.approx(90.0)
    k2 = CameraIntrinsics.from_hfov(320, 240, 90.0)
    assert k2.fx == pytest.approx(k2.fy)
    assert k2.vfov_deg == pytest.approx(math.degrees(2 * math.atan(0.75)))
    pts = np.array([[0.3, -0.2, 4.0], [-1.0, 0.5, 7.0]])
    uv = k2.project(pts)
    np.testing.assert_allclose(k2.backproject(uv[:, 0], uv[:, 1], pts[:, 2]), pts)


def test_camera_pose_convention(client: int) -> None:
    cam = RgbdCamera(client, renderer="tiny")
    t = cam.camera_pose((1.0, 2.0, 3.0), (0.0, 0.0, 0.0, 1.0))
    s = math.sqrt(0.5)
    np.testing.assert_allclose(t[:3, 2], [s, 0.0, -s], atol=1e-12)  # optical axis: forward, 45° down
    np.testing.assert_allclose(t[:3, 0], [0.0, -1.0, 0.0], atol=1e-12)  # image x: body right
    np.testing.assert_allclose(t[:3, 1], [-s, 0.0, -s], atol=1e-12)  # image y: down
    np.testing.assert_allclose(t[:3, 3], [1.1, 2.0, 2.95], atol=1e-12)
    yawed = cam.camera_pose((0.0, 0.0, 0.0), p.getQuaternionFromEuler([0.0, 0.0, math.pi / 2]))
    np.testing.assert_allclose(yawed[:3, 2], [0.0, s, -s], atol=1e-7)


def _ray_plane(t_wc: np.ndarray, k: CameraIntrinsics, u: int, v: int, axis: int, value: float) -> np.ndarray:
    """World point where the ray through pixel (u, v) meets the plane ``x[axis] = value``."""
    d = t_wc[:3, :3] @ np.array([(u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0])
    o = t_wc[:3, 3]
    return o + d * (value - o[axis]) / d[axis]


def test_depth_backprojection_and_segmentation(client: int, renderer: str) -> None:
    assert prepare_renderer(client, renderer) == renderer  # before creating bodies (EGL)
    rng = np.random.default_rng(0)
    ground = shapes.create_ground(client, rng)
    half = (0.5, 0.6, 0.5)
    box_pos = np.array([5.0, 1.0, 0.5])
    box = shapes.create_compound(client, [shapes.box((0.0, 0.0, half[2]), half, (0.8, 0.2, 0.2, 1.0))], (5.0, 1.0, 0.0))
    cam = RgbdCamera(client, renderer=renderer)
    assert cam.renderer == renderer
    quat = p.getQuaternionFromEuler([0.02, -0.05, 0.1])
    r = cam.render((0.0, 0.0, 2.0), quat)
    k = r.intrinsics
    assert r.rgb.shape == (384, 384, 3) and r.rgb.dtype == np.uint8
    assert r.depth_m.shape == (384, 384) and r.depth_m.dtype == np.float32
    assert r.seg.shape == (384, 384) and r.seg.dtype == np.int32
    t_cw = np.linalg.inv(r.T_world_camera)
    world = backproject(r.depth_m, k, r.T_world_camera, stride=1)  # (H, W, 3), NaN where no hit
    # (face centre, axis of its plane): front face (x = 4.5) and top face (z = 1.0)
    for point, axis in (((box_pos[0] - half[0], box_pos[1], box_pos[2]), 0), ((box_pos[0], box_pos[1], 1.0), 2)):
        pc = t_cw[:3, :3] @ np.asarray(point) + t_cw[:3, 3]
        u, v = (int(round(x)) for x in k.project(pc[None])[0])
        assert int(r.seg[v, u]) == box
        hit = world[v, u]
        expected = _ray_plane(r.T_world_camera, k, u, v, axis, float(point[axis]))
        assert np.linalg.norm(hit - expected) < 0.05, (hit, expected)
    # ground pixels back-project onto z = 0; the horizon row sees only sky
    gv, gu = np.nonzero(r.seg == ground)
    sel = np.linspace(0, len(gu) - 1, 50).astype(int)
    for u, v in zip(gu[sel], gv[sel], strict=True):
        assert abs(world[v, u][2]) < 0.05
    sky = ~np.isfinite(r.depth_m)  # 45° pitch, 90° vertical fov: the top rows look at the horizon
    assert sky[:3].mean() > 0.9
    assert np.all(r.rgb[sky] == np.array(SKY_RGB, dtype=np.uint8))
    assert np.all(r.seg[sky] == -1)
    pts = backproject(r.depth_m, k, r.T_world_camera, stride=8).reshape(-1, 3)
    pts = pts[~np.isnan(pts).any(axis=1)]
    assert pts.shape[1] == 3 and len(pts) > 0 and np.all(np.isfinite(pts))
    fast = cam.render((0.0, 0.0, 2.0), quat, with_seg=False)
    assert not fast.has_seg and np.all(fast.seg == -1)
    np.testing.assert_array_equal(np.isfinite(fast.depth_m), np.isfinite(r.depth_m))


def test_non_square_image_geometry(client: int, renderer: str) -> None:
    prepare_renderer(client, renderer)
    rng = np.random.default_rng(1)
    ground = shapes.create_ground(client, rng)
    wall = shapes.create_compound(
        client, [shapes.box((0.0, 0.0, 5.0), (40.0, 0.5, 5.0), (0.5, 0.5, 0.6, 1.0))], (0, -6.5, 0)
    )
    cam = RgbdCamera(client, width=320, height=240, hfov_deg=100.0, pitch_down_deg=30.0, renderer=renderer)
    r = cam.render((0.0, 0.0, 2.0), (0.0, 0.0, 0.0, 1.0))
    assert r.rgb.shape == (240, 320, 3)
    for body, axis, value in ((ground, 2, 0.0), (wall, 1, -6.0)):
        v, u = np.nonzero(r.seg == body)
        d = r.depth_m[v, u].astype(float)
        ok = d < 25.0
        pc = r.intrinsics.backproject(u[ok], v[ok], d[ok])
        pw = pc @ r.T_world_camera[:3, :3].T + r.T_world_camera[:3, 3]
        assert ok.sum() > 500
        assert np.abs(pw[:, axis] - value).max() < 0.05


def test_segmentation_maps_to_world_objects_and_timing(client: int) -> None:
    world = build_world(client, "urban", 3)  # 'auto': EGL when available
    cam = RgbdCamera(client)
    s, tgt = world.start_m, world.target_m
    quat = p.getQuaternionFromEuler([0.0, 0.0, math.atan2(tgt[1] - s[1], tgt[0] - s[0])])
    cam.render(s, quat)  # warm-up
    times = [cam.render(s, quat).render_time_s for _ in range(3)]
    r = cam.render(s, quat)
    seen = {world.body_to_object[int(b)] for b in np.unique(r.seg) if int(b) in world.body_to_object}
    assert "pad_0" in seen
    logger.info("render 384x384 urban renderer=%s: %.1f ms (min of 3)", cam.renderer, 1e3 * min(times))
    if cam.renderer != "tiny":
        tiny = RgbdCamera(client, renderer="tiny")
        t_tiny = [tiny.render(s, quat).render_time_s for _ in range(2)]
        logger.info("render 384x384 urban 'tiny' request on an EGL client: %.1f ms", 1e3 * min(t_tiny))


def _down_egl_camera(client: int, shadows: bool = False) -> RgbdCamera:
    """A small straight-down EGL camera at the vehicle's origin."""
    return RgbdCamera(client, width=96, height=96, hfov_deg=60.0, pitch_down_deg=90.0,
                      mount_offset_m=(0.0, 0.0, 0.0), renderer="egl", shadows=shadows)


def test_egl_without_shadows_skips_the_shadow_pass_and_keeps_depth(client: int) -> None:
    """The shadow-free EGL pass (the default) gives the shadow-mapped pass's depth bit for bit,
    and the same ground colours wherever the camera is: its texture coordinates are the world's
    ``(x, y) / GRASS_TILE_M``, the ground mesh's own, not the screen's."""
    if not egl_available():
        pytest.skip("EGL renderer not available on this machine")
    assert prepare_renderer(client, "egl") == "egl"
    shapes.create_ground(client, np.random.default_rng(3))
    box_shape = p.createVisualShape(p.GEOM_BOX, halfExtents=[0.5, 0.5, 0.5], physicsClientId=client)
    box = p.createMultiBody(0, -1, box_shape, [1.0, 0.5, 0.5], physicsClientId=client)
    plain = _down_egl_camera(client)
    shadowed = _down_egl_camera(client, shadows=True)
    quat = (0.0, 0.0, 0.0, 1.0)
    for pos in ((0.0, 0.0, 6.0), (1.3, 0.7, 6.0), (-2.9, 3.1, 4.0)):
        a, b = plain.render(pos, quat), shadowed.render(pos, quat, with_seg=True)
        np.testing.assert_array_equal(a.depth_m, b.depth_m)
        ground = b.seg != box
        diff = np.abs(a.rgb.astype(int) - b.rgb.astype(int)).max(axis=-1)
        assert np.median(diff[ground]) <= 3, pos  # the ground's texels, wherever the camera is
        assert diff.mean() < 12.0, pos  # the same scene, less the shadows


def test_sky_fill_matches_a_masked_write() -> None:
    """The 32-bit select that paints the background equals painting it pixel by pixel."""
    from llmland_sim.camera import _with_sky

    rng = np.random.default_rng(3)
    rgba = rng.integers(0, 256, (48, 64, 4), dtype=np.uint8)
    background = rng.random((48, 64)) < 0.6
    ref = rgba[..., :3].copy()
    ref[background] = SKY_RGB
    out = _with_sky(rgba, background)
    assert out.shape == (48, 64, 3) and out.dtype == np.uint8 and out.flags.c_contiguous
    np.testing.assert_array_equal(out, ref)
