"""Detection coverage of the downward camera: how far from the vehicle everyone is detected.

The hard limit (:mod:`.hard_limit`) assumes that every person within the coverage radius
``R_cov`` is detected in every downward frame. A purely geometric radius (the ground a person
stands on is in view) is not enough: the detector (:func:`llmland_schemas.depth.find_blobs`)
drops clusters of fewer than ``min_points`` sampled depth points, and a person seen from a few
metres up through a wide-angle lens covers only a handful of pixels. This module bounds that
count from below and returns the radius within which it is at least ``min_points``.

Model: the part of a person the guarantee relies on is an upright **torso cylinder**
(:class:`PersonTorso`; radius and height band rounded down from adult 5th-percentile
anthropometry, so it lies inside the body of almost every adult). Its image under a pinhole
camera is the convex hull of the images of its two end circles (the projection of a convex body
is convex). Every image point of that hull is a ray that meets the torso, so the depth pixel
there lies on the person (or on something nearer the camera, which the detector sees instead),
at least ``torso.bottom_m`` above the ground. The sampled pixel centres form a lattice of
spacing ``stride`` px; a convex region of area ``A`` and perimeter ``P`` (both in lattice units)
contains at least ``A − P/√2`` lattice points (each point of the region within ``√2/2`` of its
nearest lattice point's cell; the part of the region within ``√2/2`` of its boundary has area at
most ``P·√2/2``). Those points are connected neighbours on the lattice, well within the
detector's cluster gap, so they form one cluster of at least that many points.

Assumptions: a person's torso contains :class:`PersonTorso` (children and people lying down may
not), nothing occludes it from above, the depth image is complete over it (no dropouts), the
ground estimate under them is within ``torso.bottom_m − ground tolerance`` (0.65 m by default)
of the true ground (so no torso point is taken for ground), the camera looks straight down up
to the vehicle's tilt, and the radius, checked every
:data:`OFFSET_STEP_M`, holds between those checks (the count varies smoothly with the offset).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from llmland_schemas import CameraIntrinsics
from llmland_schemas.arrays import FloatArray
from scipy.spatial import ConvexHull

#: offsets from the vertical (m) at which the detection bound is checked: every COARSE_STEP_M
#: out to the first failure, then every OFFSET_STEP_M between the last pass and that failure
COARSE_STEP_M = 0.25
OFFSET_STEP_M = 0.05
#: heights (m) and tilts (rad) at which coverage radii are tabulated (lookups take the worse neighbour)
HEIGHT_STEP_M = 0.1
TILT_STEP_RAD = 0.05
#: points sampled on each end circle of the torso cylinder
CIRCLE_SAMPLES = 32
#: the farthest offset (m) examined (beyond the horizon of any downward camera that matters)
MAX_OFFSET_M = 30.0


@dataclass(frozen=True)
class PersonTorso:
    """The smallest upright torso the coverage guarantee protects (m, above the person's feet).

    Defaults: radius 0.10 m (half an adult 5th-percentile chest depth of about 0.2 m), from
    0.9 m (the waist of a 1.5 m adult) to 1.25 m (their shoulder height).
    """

    radius_m: float = 0.10
    bottom_m: float = 0.9
    top_m: float = 1.25


def _camera_points(offset_m: float, height_m: float, tilt_rad: float, torso: PersonTorso) -> FloatArray:
    """Optical-frame points (2·CIRCLE_SAMPLES, 3) of the torso's end circles, for a camera
    ``height_m`` above the person's feet, looking down and tilted by ``tilt_rad`` toward the
    person (negative: away), the person ``offset_m`` along the image's +u axis."""
    a = np.linspace(0.0, 2.0 * math.pi, CIRCLE_SAMPLES, endpoint=False)
    ring = np.stack([offset_m + torso.radius_m * np.cos(a), torso.radius_m * np.sin(a)], axis=1)
    pts = []
    for z in (torso.bottom_m, torso.top_m):
        # camera-centred, looking down: x_c = x, y_c = −y, z_c = height − z
        pts.append(np.column_stack([ring[:, 0], -ring[:, 1], np.full(len(a), height_m - z)]))
    p = np.vstack(pts)
    c, s = math.cos(tilt_rad), math.sin(tilt_rad)
    # tilting the optical axis toward +x by tilt: rotate the points by −tilt about the y axis
    return np.column_stack([c * p[:, 0] - s * p[:, 2], p[:, 1], s * p[:, 0] + c * p[:, 2]])


def _clip(poly: FloatArray, width: float, height: float) -> FloatArray:
    """Sutherland–Hodgman clip of a convex polygon (N, 2) to the rectangle [0, width] × [0, height]."""
    out = poly
    for axis, bound, keep_below in ((0, 0.0, False), (0, width, True), (1, 0.0, False), (1, height, True)):
        if len(out) == 0:
            break
        inside = out[:, axis] <= bound if keep_below else out[:, axis] >= bound
        res = []
        for i in range(len(out)):
            p, q = out[i], out[(i + 1) % len(out)]
            ip, iq = inside[i], inside[(i + 1) % len(out)]
            if ip:
                res.append(p)
            if ip != iq:
                t = (bound - p[axis]) / (q[axis] - p[axis])
                res.append(p + t * (q - p))
        out = np.asarray(res).reshape(-1, 2)
    return out


def detected_points_lower_bound(intrinsics: CameraIntrinsics, height_m: float, offset_m: float, tilt_rad: float,
                                stride: int, torso: PersonTorso = PersonTorso()) -> float:
    """A lower bound on the sampled depth points (at ``stride`` px) that fall on a person standing
    ``offset_m`` (m) from the vertical below a downward camera ``height_m`` (m) above their feet.

    ``A − P/√2`` of the torso's image clipped to the image (lattice units; module docstring);
    0 when any of the torso is not in front of the camera.
    """
    pts = _camera_points(offset_m, height_m, tilt_rad, torso)
    if np.any(pts[:, 2] <= 1e-6):
        return 0.0
    uv = intrinsics.project(pts)
    hull = uv[ConvexHull(uv).vertices]
    # pixel centres sit at integer (u, v); the image's sampled area is [0, width − 1] × [0, height − 1]
    poly = _clip(hull, intrinsics.width - 1.0, intrinsics.height - 1.0) / float(stride)
    if len(poly) < 3:
        return 0.0
    x, y = poly[:, 0], poly[:, 1]
    area = 0.5 * abs(float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))
    perimeter = float(np.sum(np.hypot(np.diff(x, append=x[0]), np.diff(y, append=y[0]))))
    return area - perimeter / math.sqrt(2.0)


@lru_cache(maxsize=4096)
def _tabulated_radius_m(camera: tuple[float, float, float, float, int, int], height_m: float, tilt_rad: float,
                        stride: int, min_points: int, torso: PersonTorso) -> float:
    fx, fy, cx, cy, width, height = camera
    intrinsics = CameraIntrinsics(fx=fx, fy=fy, cx=cx, cy=cy, width=width, height=height)

    def detected(d: float) -> bool:
        return min(detected_points_lower_bound(intrinsics, height_m, d, sign * tilt_rad, stride, torso)
                   for sign in ((1.0, -1.0) if tilt_rad > 0 else (1.0,))) >= min_points

    # Coarse steps, then the fine steps after the last coarse offset that passed.
    fine_per_coarse = round(COARSE_STEP_M / OFFSET_STEP_M)
    coarse = 0
    while coarse * COARSE_STEP_M <= MAX_OFFSET_M and detected(coarse * COARSE_STEP_M):
        coarse += 1
    if coarse == 0:
        return 0.0
    base = radius = (coarse - 1) * COARSE_STEP_M
    for i in range(1, fine_per_coarse):
        if not detected(base + i * OFFSET_STEP_M):
            break
        radius = base + i * OFFSET_STEP_M
    return radius

def detection_radius_m(intrinsics: CameraIntrinsics, height_m: float, tilt_rad: float, *, stride: int,
                       min_points: int, torso: PersonTorso = PersonTorso()) -> float:
    """Horizontal radius (m) around the vehicle within which everyone is detected (module docstring).

    ``height_m``: camera height above the ground; ``tilt_rad``: angle of the optical axis from the
    vertical, taken in the plane of the offset toward and away from the person (the worse for the
    image edge and for the pixel scale). The radius is the largest ``R`` such that at every offset
    in ``[0, R]`` (checked as :data:`COARSE_STEP_M` says) :func:`detected_points_lower_bound` is at
    least ``min_points``; 0 when a person right below is not detected. Tabulated per :data:`HEIGHT_STEP_M` and
    :data:`TILT_STEP_RAD`; a lookup returns the smallest radius of the neighbouring heights at the
    next tilt up.
    """
    if height_m <= torso.top_m:
        return 0.0
    tilt = math.ceil(abs(tilt_rad) / TILT_STEP_RAD - 1e-9) * TILT_STEP_RAD
    lo = math.floor(height_m / HEIGHT_STEP_M) * HEIGHT_STEP_M
    camera = (intrinsics.fx, intrinsics.fy, intrinsics.cx, intrinsics.cy, intrinsics.width, intrinsics.height)
    return min(_tabulated_radius_m(camera, round(h, 6), round(tilt, 6), stride, min_points, torso)
               for h in (lo, lo + HEIGHT_STEP_M) if h > torso.top_m)
