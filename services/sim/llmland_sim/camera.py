"""Forward-looking RGB-D + segmentation camera for the pybullet simulator.

Frames per ``docs/conventions.md``: the camera is mounted at ``mount_offset_m`` in the body
frame (FLU) and looks along body ``+x`` pitched down by ``pitch_down_deg``. Images use the
optical frame (``x`` right, ``y`` down, ``z`` forward); ``T_world_camera`` (4×4) maps optical
frame points into the world. Pixel ``(u, v)`` = (column, row), row 0 at the top, pixel
centres at integer coordinates, so ``u = fx * x / z + cx`` with ``cx = (W - 1) / 2``.

Pixel grids differ between renderers and the intrinsics account for it: OpenGL/EGL samples
pixel centres (``cx = (W - 1) / 2``, ``cy = (H - 1) / 2``), pybullet's TinyRenderer samples
pixel corners (``cx = W / 2``, ``cy = H / 2 - 1``); using the wrong one tilts back-projected
rays by half a pixel (≈ 8 cm height error on the ground at 50 m for 384 px / 90°).

Renderers (``tiny``, ``egl``, ``auto``): :mod:`.renderer`.

Shadows and speed with EGL: pybullet's EGL renderer (``GLInstancingRenderer``) draws every
frame into a 4096×4096 shadow map first, whatever ``getCameraImage(shadow=...)`` says; on Mesa
llvmpipe that pass is most of a frame (≈ 20 of 30 ms at 384×384, single-threaded, and as much
at 32×32). Its projective-texture mode is the one pass that skips it, so a camera without
shadows (the default) renders through it with a projector that maps world ``(x, y)`` to
texture coordinates ``(x, y) / GRASS_TILE_M``: the planar coordinates the ground meshes carry,
so textured ground looks as before, less the shadows. Depth is the same bit for bit (the pass
only changes the fragment colour); vertical textured faces get their texture stretched along
``z``. ``shadows=True`` keeps pybullet's shadow-mapped pass.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pybullet as p
from llmland_schemas import CameraIntrinsics
from llmland_schemas.arrays import FloatArray, VecLike
from numpy.typing import NDArray

from .renderer import egl_active, prepare_renderer
from .world.shapes.textures import GRASS_TILE_M

logger = logging.getLogger(__name__)

#: Colour given to background pixels (nothing within the far plane), RGB uint8.
SKY_RGB = (185, 210, 235)


def planar_texture_projector(tile_m: float = GRASS_TILE_M) -> tuple[list[float], list[float]]:
    """(view, projection) matrices, column-major 16 floats each, for pybullet's projective-texture
    pass: texture coordinates ``(x, y) / tile_m`` of the world point ``(x, y, z)`` (the shader
    divides by the third row, here 1)."""
    proj = np.array([[1.0 / tile_m, 0.0, 0.0, 0.0],
                     [0.0, 1.0 / tile_m, 0.0, 0.0],
                     [0.0, 0.0, 0.0, 1.0],
                     [0.0, 0.0, 0.0, 1.0]])
    return [float(v) for v in np.eye(4).ravel()], [float(v) for v in proj.T.ravel()]

# --------------------------------------------------------------------------- geometry


def quat_to_matrix(quat_xyzw: VecLike) -> FloatArray:
    """Rotation matrix (3, 3) of a unit quaternion ``(x, y, z, w)``."""
    x, y, z, w = (float(v) for v in quat_xyzw)
    n = math.sqrt(x * x + y * y + z * z + w * w)
    if n == 0.0:
        raise ValueError("zero quaternion")
    x, y, z, w = x / n, y / n, z / n, w / n
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


#: :data:`SKY_RGB` with an opaque alpha, as one native-endian 32-bit RGBA word
_SKY_RGBA_WORD = np.array([*SKY_RGB, 255], dtype=np.uint8).view(np.uint32)[0]


def _with_sky(rgba: np.ndarray, background: np.ndarray) -> np.ndarray:
    """RGB (H, W, 3) uint8 of ``rgba`` (H, W, 4) with ``background`` (H, W) pixels set to
    :data:`SKY_RGB`; one select over 32-bit pixels (a quarter of the cost of a masked write to
    the (H, W, 3) array, which was half the camera's post-processing)."""
    words = np.ascontiguousarray(rgba).view(np.uint32)[..., 0]
    sky = np.where(background, _SKY_RGBA_WORD, words)
    return sky.view(np.uint8).reshape(*background.shape, 4)[..., :3].copy()


@dataclass
class CameraRender:
    """One rendered frame.

    Attributes:
        rgb: (H, W, 3) uint8; background (nothing within the far plane) is :data:`SKY_RGB`.
        depth_m: (H, W) float32 metric depth along the optical axis (``z_cam``), ``inf`` where
            nothing was hit within the far plane.
        seg: (H, W) int32 pybullet body id per pixel, ``-1`` for background (all ``-1`` when
            rendered with ``with_seg=False``, see ``has_seg``). Map ids to objects with
            ``World.body_to_object``.
        intrinsics: the pinhole model.
        T_world_camera: (4, 4) float64 pose of the optical frame in the world.
        renderer: ``"tiny"``, ``"egl"`` or ``"opengl"``.
        render_time_s: wall time spent in ``getCameraImage`` (s).
        has_seg: whether ``seg`` was rendered.
    """

    rgb: NDArray[np.uint8]
    depth_m: NDArray[np.float32]
    seg: NDArray[np.int32]
    intrinsics: CameraIntrinsics
    T_world_camera: FloatArray
    renderer: str = "tiny"
    render_time_s: float = 0.0
    has_seg: bool = True


class RgbdCamera:
    """Body-mounted RGB-D + segmentation camera rendered with pybullet.

    Args:
        client: pybullet physics client id.
        width, height: image size (px).
        hfov_deg: horizontal field of view (deg); pixels are square.
        pitch_down_deg: optical axis pitched down from body ``+x`` (deg).
        mount_offset_m: camera centre in the body frame (FLU, m).
        near, far: clipping planes (m); depth beyond ``far`` is ``inf``.
        renderer: ``"auto"``, ``"tiny"`` or ``"egl"`` (see the module docstring).
        shadows: cast shadows (off by default: EGL shadow maps show acne on the thin ground
            decorations, and both renderers get slower; see the module docstring for EGL).
        light_direction: direction towards the light, world frame (unit-less).
    """

    def __init__(
        self,
        client: int,
        width: int = 384,
        height: int = 384,
        hfov_deg: float = 90.0,
        pitch_down_deg: float = 45.0,
        mount_offset_m: Sequence[float] = (0.1, 0.0, -0.05),
        near: float = 0.1,
        far: float = 60.0,
        renderer: str = "auto",
        shadows: bool = False,
        light_direction: Sequence[float] = (0.4, 0.3, 1.0),
    ) -> None:
        if not 0.0 < near < far:
            raise ValueError("need 0 < near < far")
        if not 0.0 < hfov_deg < 180.0:
            raise ValueError("hfov_deg must be in (0, 180)")
        self.client = client
        self.pitch_down_deg = float(pitch_down_deg)
        self.near = float(near)
        self.far = float(far)
        self.shadows = bool(shadows)
        self.light_direction = [float(v) for v in light_direction]
        self.renderer = prepare_renderer(client, renderer)
        if self.renderer == "tiny" and egl_active(client):
            logger.info("client %d has the EGL plugin: pybullet serves 'tiny' requests with EGL", client)
            self.renderer = "egl"
        intr = CameraIntrinsics.from_hfov(int(width), int(height), hfov_deg)
        if self.renderer == "tiny":  # TinyRenderer samples pixel corners (measured, see module doc)
            intr = intr.model_copy(update={"cx": width / 2.0, "cy": height / 2.0 - 1.0})
        self.intrinsics = intr
        self._pb_renderer = p.ER_TINY_RENDERER if self.renderer == "tiny" else p.ER_BULLET_HARDWARE_OPENGL
        self._texture_projector = planar_texture_projector()
        self._proj = list(
            p.computeProjectionMatrixFOV(
                fov=self.intrinsics.vfov_deg,
                aspect=width / height,
                nearVal=self.near,
                farVal=self.far,
                physicsClientId=client,
            )
        )
        # optical axes in the body frame: x_c = right (-y_b), y_c = down (-z_b), z_c = forward
        r0 = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
        a = math.radians(self.pitch_down_deg)
        ry = np.array([[math.cos(a), 0.0, math.sin(a)], [0.0, 1.0, 0.0], [-math.sin(a), 0.0, math.cos(a)]])
        self.T_body_camera = np.eye(4)
        self.T_body_camera[:3, :3] = ry @ r0
        self.T_body_camera[:3, 3] = np.asarray(mount_offset_m, dtype=float)
        logger.info(
            "RgbdCamera %dx%d hfov=%.1f° pitch=%.1f° renderer=%s",
            width,
            height,
            hfov_deg,
            pitch_down_deg,
            self.renderer,
        )

    def camera_pose(self, pos_m: VecLike, quat_xyzw: VecLike) -> FloatArray:
        """``T_world_camera`` (4, 4) for a body at ``pos_m`` (3,) with attitude ``quat_xyzw``."""
        t_wb = np.eye(4)
        t_wb[:3, :3] = quat_to_matrix(quat_xyzw)
        t_wb[:3, 3] = np.asarray(pos_m, dtype=float)
        return t_wb @ self.T_body_camera

    @staticmethod
    def view_matrix(T_world_camera: FloatArray) -> list[float]:
        """OpenGL view matrix (column-major, 16) of an optical-frame pose."""
        r_wgl = T_world_camera[:3, :3] @ np.diag([1.0, -1.0, -1.0])  # GL camera: y up, looks down -z
        view = np.eye(4)
        view[:3, :3] = r_wgl.T
        view[:3, 3] = -r_wgl.T @ T_world_camera[:3, 3]
        return [float(v) for v in view.T.ravel()]

    def render(self, pos_m: VecLike, quat_xyzw: VecLike, with_seg: bool = True) -> CameraRender:
        """Render RGB, metric depth and (optionally) segmentation for the given body pose."""
        intr = self.intrinsics
        w, h = intr.width, intr.height
        t_wc = self.camera_pose(pos_m, quat_xyzw)
        flags = 0 if with_seg else p.ER_NO_SEGMENTATION_MASK
        extra: dict[str, list[float]] = {}
        if self.renderer == "egl" and not self.shadows:  # skip the shadow-map pass (module docstring)
            flags |= p.ER_USE_PROJECTIVE_TEXTURE
            extra["projectiveTextureView"], extra["projectiveTextureProj"] = self._texture_projector
        t0 = time.perf_counter()
        _, _, rgba, depth, seg = p.getCameraImage(
            w,
            h,
            viewMatrix=self.view_matrix(t_wc),
            projectionMatrix=self._proj,
            renderer=self._pb_renderer,
            flags=flags,
            shadow=int(self.shadows),
            lightDirection=self.light_direction,
            physicsClientId=self.client,
            **extra,
        )
        dt = time.perf_counter() - t0
        d = np.asarray(depth, dtype=np.float64).reshape(h, w)
        background = d >= 1.0
        with np.errstate(divide="ignore"):
            z = self.far * self.near / (self.far - (self.far - self.near) * d)
        z[background] = np.inf
        rgb = _with_sky(np.asarray(rgba, dtype=np.uint8).reshape(h, w, 4), background)
        if with_seg:
            seg_img = np.asarray(seg, dtype=np.int32).reshape(h, w)
        else:
            seg_img = np.full((h, w), -1, dtype=np.int32)
        return CameraRender(
            rgb=rgb,
            depth_m=z.astype(np.float32),
            seg=seg_img,
            intrinsics=intr,
            T_world_camera=t_wc,
            renderer=self.renderer,
            render_time_s=dt,
            has_seg=with_seg,
        )
