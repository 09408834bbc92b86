"""Drone poses and ground-truth facts for rendering training data (imports the simulator).

Only :mod:`llmland_vle.training` imports this module; the run-time service never does.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from llmland_schemas.arrays import FloatArray
from numpy.typing import NDArray

from ..captions import colour_word

#: The urban parking row around the target (mirrors the sim's layout constants: 6.5 spots
#: of 2.7 m either side, 3 m half depth).
LOT_HALF_X_M = 6.5 * 2.7
LOT_HALF_Y_M = 3.0
#: How often a render is aimed at an object of a class (relative weights).
FOCUS_WEIGHT = {"person": 5.0, "vehicle": 2.0, "shed": 1.5, "rock": 1.5, "bush": 1.0, "tree": 0.5, "building": 0.7}


def surface_at(world: Any, x: float, y: float) -> str:
    """Surface word under world point (x, y): grass, road, sidewalk or parking lot."""
    if world.name != "urban":
        return "grass"
    sy = float(world.meta["street_y_m"])
    hw = float(world.meta["street_half_width_m"])
    sw = float(world.meta["sidewalk_width_m"])
    if abs(y - sy) < hw and abs(x) < 70.0:
        return "road"
    if abs(y - sy) < hw + sw and abs(x) < 70.0:
        return "sidewalk"
    tx, ty = float(world.target_m[0]), float(world.target_m[1])
    if abs(x - tx) < LOT_HALF_X_M and abs(y - ty) < LOT_HALF_Y_M:
        return "parking lot"
    return "grass"


def _inside_static(world: Any, xy: FloatArray, z: float, clearance_m: float = 0.6) -> bool:
    for o in world.static_obstacles():
        fp = o.footprint
        if fp is None:
            continue
        top = float(o.center_m[2]) + 0.5 * float(o.size_m[2])
        if fp.distance_to_point(xy) < clearance_m and z < top + clearance_m:
            return True
    return False


def sample_pose(world: Any, rng: np.random.Generator) -> tuple[FloatArray, tuple[float, float, float, float]]:
    """A drone position and attitude quaternion (x, y, z, w) looking at something in the world."""
    import pybullet as p

    objs = [o for o in world.objects if o.cls != "pad"]
    target = np.asarray(world.target_m[:2], dtype=float)
    u = rng.uniform()
    if u < 0.65 and objs:
        w = np.array([FOCUS_WEIGHT.get(o.cls, 1.0) for o in objs])
        focus = np.asarray(objs[int(rng.choice(len(objs), p=w / w.sum()))].position()[:2], dtype=float)
    elif u < 0.85:
        focus = target.copy()
    else:
        focus = target + rng.uniform(-15.0, 15.0, 2)
    xy, alt, dist = target.copy(), 3.0, 5.0
    for _ in range(60):
        dist = float(rng.uniform(2.0, 16.0))
        bearing = float(rng.uniform(-math.pi, math.pi))
        xy = focus + dist * np.array([math.cos(bearing), math.sin(bearing)])
        alt = float(rng.uniform(1.0, 8.0))
        if not _inside_static(world, xy, world.ground_height(xy[0], xy[1]) + alt):
            break
    z = world.ground_height(float(xy[0]), float(xy[1])) + alt
    yaw = math.atan2(focus[1] - xy[1], focus[0] - xy[0]) + float(rng.normal(0.0, 0.35))
    depression = math.atan2(alt, dist)
    pitch = 0.5 * float(np.clip(depression - math.radians(45.0), -0.35, 0.35)) + float(rng.normal(0.0, 0.08))
    roll = float(rng.normal(0.0, 0.07))
    quat = p.getQuaternionFromEuler([roll, pitch, yaw])
    return np.array([xy[0], xy[1], z]), (float(quat[0]), float(quat[1]), float(quat[2]), float(quat[3]))


def object_colour(cls: str, rgb: NDArray[np.uint8], rows: NDArray[np.intp], cols: NDArray[np.intp]) -> str:
    """Colour word of an object from its pixels; for a person, from the shirt rows."""
    if cls == "person" and rows.size >= 8:
        top, bot = int(rows.min()), int(rows.max())
        lo, hi = top + 0.2 * (bot - top), top + 0.5 * (bot - top)
        sel = (rows >= lo) & (rows <= hi)
        if int(sel.sum()) >= 4:
            rows, cols = rows[sel], cols[sel]
    return colour_word(rgb[rows, cols].reshape(-1, 3).mean(axis=0))
