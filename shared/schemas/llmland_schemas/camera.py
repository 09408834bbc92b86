"""The pinhole camera model: one definition for the sim's renderer, the bus header and the planner.

Convention (OpenCV; see ``docs/conventions.md``): the optical frame is x right, y down,
z forward; pixel ``(u, v)`` (column, row) is the ray through ``((u - cx) / fx, (v - cy) / fy, 1)``,
so pixel centres sit at integer coordinates. Projection: ``u = fx · x / z + cx``,
``v = fy · y / z + cy`` (Hartley & Zisserman, *Multiple View Geometry*, 2nd ed., §6.1).
"""

from __future__ import annotations

import math
from typing import Annotated

import numpy as np
from numpy.typing import ArrayLike
from pydantic import Field, FiniteFloat

from .arrays import FloatArray
from .base import Strict

#: The largest image side a header may announce (px).
MAX_IMAGE_SIDE_PX = 8192


class CameraIntrinsics(Strict):
    """Pinhole intrinsics in pixels for an image of ``width`` × ``height``."""

    fx: Annotated[FiniteFloat, Field(gt=0)]
    fy: Annotated[FiniteFloat, Field(gt=0)]
    cx: FiniteFloat
    cy: FiniteFloat
    width: Annotated[int, Field(gt=0, le=MAX_IMAGE_SIDE_PX)]
    height: Annotated[int, Field(gt=0, le=MAX_IMAGE_SIDE_PX)]

    @classmethod
    def from_hfov(cls, width: int, height: int, hfov_deg: float) -> CameraIntrinsics:
        """Square-pixel intrinsics for a horizontal field of view ``hfov_deg`` (deg), centred pixels."""
        fx = 0.5 * width / math.tan(math.radians(hfov_deg) / 2.0)
        return cls(fx=fx, fy=fx, cx=(width - 1) / 2.0, cy=(height - 1) / 2.0, width=width, height=height)

    @property
    def K(self) -> FloatArray:  # noqa: N802 (standard name)
        """Camera matrix (3, 3)."""
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    @property
    def hfov_deg(self) -> float:
        """Horizontal field of view (deg)."""
        return math.degrees(2.0 * math.atan(0.5 * self.width / self.fx))

    @property
    def vfov_deg(self) -> float:
        """Vertical field of view (deg), what pybullet's ``computeProjectionMatrixFOV`` takes."""
        return math.degrees(2.0 * math.atan(0.5 * self.height / self.fy))

    @property
    def half_fov_rad(self) -> float:
        """Half of the narrower field of view (rad)."""
        return min(math.atan(0.5 * self.width / self.fx), math.atan(0.5 * self.height / self.fy))

    def normalized(self, u: ArrayLike, v: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """Normalised image coordinates ``((u - cx) / fx, (v - cy) / fy)``, each of its input's shape."""
        return ((np.asarray(u, dtype=float) - self.cx) / self.fx, (np.asarray(v, dtype=float) - self.cy) / self.fy)

    def project(self, points_cam: ArrayLike) -> FloatArray:
        """Pixel coordinates (N, 2) ``(u, v)`` of optical-frame points (N, 3) with ``z > 0``."""
        pts = np.atleast_2d(np.asarray(points_cam, dtype=float))
        return np.stack([self.fx * pts[:, 0] / pts[:, 2] + self.cx, self.fy * pts[:, 1] / pts[:, 2] + self.cy], 1)

    def backproject(self, u: ArrayLike, v: ArrayLike, depth_m: ArrayLike) -> FloatArray:
        """Optical-frame points (..., 3) at pixels ``(u, v)`` with z-depth ``depth_m`` (m)."""
        z = np.asarray(depth_m, dtype=float)
        xn, yn = self.normalized(u, v)
        return np.stack(np.broadcast_arrays(xn * z, yn * z, z), axis=-1)

    def in_image(self, u: float, v: float) -> bool:
        """Whether pixel coordinates ``(u, v)`` fall inside the image."""
        return bool(0 <= u < self.width and 0 <= v < self.height)
