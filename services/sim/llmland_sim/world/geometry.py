"""Horizontal footprints of world objects: discs and oriented rectangles, and their distances (m)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from llmland_schemas.arrays import FloatArray, VecLike

#: A point / vector given as a sequence or a numpy array.


@dataclass(frozen=True)
class Footprint:
    """Horizontal extent of an object: a disc (``half_xy is None``) or an oriented rectangle.

    ``center_xy`` (m); ``radius_m`` for discs; ``half_xy`` half extents along the object's
    local x / y axes and ``yaw_rad`` their rotation about world z for rectangles.
    """

    center_xy: tuple[float, float]
    radius_m: float = 0.0
    half_xy: tuple[float, float] | None = None
    yaw_rad: float = 0.0

    def _axes(self) -> tuple[FloatArray, FloatArray]:
        c, s = math.cos(self.yaw_rad), math.sin(self.yaw_rad)
        return np.array([c, s]), np.array([-s, c])

    def corners(self) -> FloatArray:
        """Rectangle corners (4, 2) in metres (counter-clockwise)."""
        if self.half_xy is None:
            raise ValueError("a disc footprint has no corners")
        ux, uy = self._axes()
        hx, hy = self.half_xy
        c = np.asarray(self.center_xy, dtype=float)
        return np.array([c + sx * hx * ux + sy * hy * uy for sx, sy in ((1, 1), (-1, 1), (-1, -1), (1, -1))])

    def distance_to_point(self, xy: VecLike) -> float:
        """Horizontal distance (m) from ``xy`` to the footprint (0 inside)."""
        d = np.asarray(xy, dtype=float)[:2] - np.asarray(self.center_xy, dtype=float)
        if self.half_xy is None:
            return max(float(np.linalg.norm(d)) - self.radius_m, 0.0)
        ux, uy = self._axes()
        ex = max(abs(float(d @ ux)) - self.half_xy[0], 0.0)
        ey = max(abs(float(d @ uy)) - self.half_xy[1], 0.0)
        return math.hypot(ex, ey)

    def bounding_radius(self) -> float:
        """Radius (m) of the smallest disc around ``center_xy`` containing the footprint."""
        if self.half_xy is None:
            return self.radius_m
        return math.hypot(*self.half_xy)


def _rects_overlap(a: Footprint, b: Footprint) -> bool:
    ca, cb = a.corners(), b.corners()
    for f in (a, b):
        for axis in f._axes():
            pa, pb = ca @ axis, cb @ axis
            if pa.max() < pb.min() or pb.max() < pa.min():
                return False
    return True


def footprint_distance(a: Footprint, b: Footprint) -> float:
    """Exact horizontal distance (m) between two footprints (0 when they overlap)."""
    if a.half_xy is None and b.half_xy is None:
        d = float(np.linalg.norm(np.subtract(a.center_xy, b.center_xy)))
        return max(d - a.radius_m - b.radius_m, 0.0)
    if a.half_xy is None:
        return max(b.distance_to_point(a.center_xy) - a.radius_m, 0.0)
    if b.half_xy is None:
        return max(a.distance_to_point(b.center_xy) - b.radius_m, 0.0)
    if _rects_overlap(a, b):
        return 0.0
    return min(
        min(b.distance_to_point(c) for c in a.corners()),
        min(a.distance_to_point(c) for c in b.corners()),
    )
