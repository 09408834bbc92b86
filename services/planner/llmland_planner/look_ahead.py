"""Look before flying: the approach waits while the way ahead lies outside the forward camera's view.

The tracker only knows what a camera has seen; the downward camera sees nothing above the
vehicle. So before the vehicle flies along its path, the forward camera must look where the
path goes: while approaching, the yaw reference turns toward a point of the path ahead
(:meth:`~.replanning.Replanner.look_ahead_m`), and the path reference waits at the nearest
path point (:meth:`~.replanning.Replanner.reference` with ``hold=True``) while that point's
bearing is outside the camera's azimuth range. A detour that leaves backwards is therefore
turned into before it is flown (Exp 2, conservative, open_field seed 34: flown facing the goal,
into a tree neither camera had seen).

The camera's azimuth range is taken along its top image row, the narrowest one for a camera
pitched down (for the 90°-wide forward camera pitched 60° down: ±36°, against ±63° at its
centre row), from the latest forward frame's intrinsics and pose.
"""

from __future__ import annotations

import math

import numpy as np
from llmland_schemas.arrays import FloatArray
from llmland_schemas.camera import CameraIntrinsics

#: A view narrower than this (rad) either side is no view of the way ahead (a camera whose top
#: row looks nearly straight down): nothing to wait for, so the approach never waits for ever.
MIN_VIEW_HALF_AZIMUTH_RAD = 0.2


def _azimuth(v: FloatArray) -> float:
    return math.atan2(float(v[1]), float(v[0]))


def view_half_azimuth_rad(k: CameraIntrinsics, t_world_camera: FloatArray) -> float:
    """Half the azimuth range (rad) a camera sees along its top image row, about that row's
    centre ray: ``min`` over the two top corners of the angle to the centre.

    ``k``: the camera's intrinsics; ``t_world_camera (4, 4)``: its optical-frame pose (x right,
    y down, z forward). Returns 0 when the top row looks straight down (no azimuth to speak of).
    """
    r = np.asarray(t_world_camera, dtype=float)[:3, :3]
    xn, yn = k.normalized([0.0, float(k.cx), float(k.width)], [0.0, 0.0, 0.0])  # top-left, top-centre, top-right
    rays = [r @ np.array([float(x), float(y), 1.0]) for x, y in zip(xn, yn, strict=True)]
    if any(float(np.hypot(ray[0], ray[1])) < 1e-9 for ray in rays):
        return 0.0
    centre = _azimuth(rays[1])
    return min(abs(math.remainder(_azimuth(rays[0]) - centre, 2 * math.pi)),
               abs(math.remainder(_azimuth(rays[2]) - centre, 2 * math.pi)))


def must_turn_first(pos_m: FloatArray, yaw_rad: float, ahead_m: FloatArray | None,
                    half_azimuth_rad: float | None, min_distance_m: float) -> bool:
    """Whether the vehicle at ``pos_m (3,)`` with heading ``yaw_rad`` must turn before flying on:
    the path point ahead ``ahead_m (3,)`` is farther than ``min_distance_m`` horizontally and its
    bearing is more than ``half_azimuth_rad`` off the heading. False without a point ahead, or
    without a known camera or one whose view is narrower than ``MIN_VIEW_HALF_AZIMUTH_RAD``
    (nothing to wait for: no heading could satisfy it)."""
    if ahead_m is None or half_azimuth_rad is None or half_azimuth_rad < MIN_VIEW_HALF_AZIMUTH_RAD:
        return False
    d = np.asarray(ahead_m, dtype=float)[:2] - np.asarray(pos_m, dtype=float)[:2]
    if float(np.linalg.norm(d)) <= min_distance_m:
        return False
    return abs(math.remainder(_azimuth(d) - yaw_rad, 2 * math.pi)) > half_azimuth_rad
