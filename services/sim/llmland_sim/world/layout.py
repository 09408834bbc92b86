"""Placement rules shared by every world recipe: clearance guarantees and seeded draws.

Guarantees (enforced at placement, checked by the tests):

* every static obstacle's footprint is ≥ :data:`TARGET_CLEARANCE_M` from the target;
* every static obstacle's footprint is ≥ :data:`START_CLEARANCE_M` from the start (x, y);
* static obstacle footprints do not overlap each other (:data:`OBSTACLE_GAP_M` apart).

Walking actors avoid the *ground* footprints (a tree's trunk, the rest as above).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from llmland_schemas.arrays import FloatArray

from .actors import WalkRegion
from .geometry import Footprint, footprint_distance

#: Guaranteed horizontal clearance (m) between the target and any static obstacle footprint.
TARGET_CLEARANCE_M = 2.5
#: Clearance used when placing obstacles (m); a margin above the guarantee.
TARGET_PLACE_CLEARANCE_M = 3.0
#: Guaranteed horizontal clearance (m) between the start (x, y) and any static footprint.
START_CLEARANCE_M = 2.0
#: Margin (m) added to :data:`START_CLEARANCE_M` when placing obstacles.
START_PLACE_MARGIN_M = 0.2
#: Pedestrians start at least this far (m, horizontally) from the drone start: a person
#: already inside the drone's buffer at t = 0 would score a close call no planner could avoid.
PED_START_CLEARANCE_M = 5.0
#: Minimum gap (m) between static obstacle footprints.
OBSTACLE_GAP_M = 0.2
#: Probability that a pedestrian near the flight path picks its next goal around the target.
PATH_TARGET_PROB = 0.3
#: A person (radius ~0.25 m) fits where the ground footprints are this far (m) away.
PERSON_FIT_MARGIN_M = 0.45
#: Placement attempts for one obstacle before it is given up.
PLACE_TRIES = 100
#: Drone start: this far (m) from the target horizontally, this high (m) above the ground.
START_DISTANCE_RANGE_M = (8.0, 10.0)
START_ALTITUDE_RANGE_M = (2.5, 4.0)
#: Attempts at an admissible drone start.
START_TRIES = 500


class Layout:
    """Rejection-sampling placement of static obstacles with the clearance guarantees."""

    def __init__(self, target_xy: FloatArray, start_xy: FloatArray) -> None:
        self.target_xy = target_xy
        self.start_xy = start_xy
        self.footprints: list[Footprint] = []
        self.ground_footprints: list[Footprint] = []

    def fits(self, fp: Footprint, gap_m: float = OBSTACLE_GAP_M) -> bool:
        """True when ``fp`` keeps the target / start clearances and ``gap_m`` to every placed footprint."""
        if fp.distance_to_point(self.target_xy) < TARGET_PLACE_CLEARANCE_M:
            return False
        if fp.distance_to_point(self.start_xy) < START_CLEARANCE_M + START_PLACE_MARGIN_M:
            return False
        c = np.asarray(fp.center_xy)
        r = fp.bounding_radius()
        for o in self.footprints:
            if np.linalg.norm(c - np.asarray(o.center_xy)) > r + o.bounding_radius() + gap_m:
                continue
            if footprint_distance(fp, o) < gap_m:
                return False
        return True

    def add(self, fp: Footprint, ground_fp: Footprint | None = None) -> None:
        self.footprints.append(fp)
        self.ground_footprints.append(ground_fp or fp)

    def is_free(self, x: float, y: float, margin_m: float = PERSON_FIT_MARGIN_M) -> bool:
        """True when a person (radius ~0.25 m) fits at ``(x, y)``."""
        q = (x, y)
        for g in self.ground_footprints:
            if abs(x - g.center_xy[0]) > g.bounding_radius() + margin_m + 0.01:
                continue
            if g.distance_to_point(q) < margin_m:
                return False
        return True


def sample_start(
    rng: np.random.Generator,
    target_xy: FloatArray,
    accept: Callable[[FloatArray], bool],
    angle_range: tuple[float, float] = (-math.pi, math.pi),
) -> tuple[FloatArray, float]:
    """Start (x, y) 8–10 m from the target in a seeded direction, and altitude 2.5–4 m."""
    for _ in range(START_TRIES):
        theta = float(rng.uniform(*angle_range))
        dist = float(rng.uniform(*START_DISTANCE_RANGE_M))
        xy = target_xy + dist * np.array([math.cos(theta), math.sin(theta)])
        if accept(xy):
            return xy, float(rng.uniform(*START_ALTITUDE_RANGE_M))
    raise RuntimeError("no admissible drone start found")


def draw_count(rng: np.random.Generator, count_range: tuple[int, int]) -> int:
    """A seeded count in ``[lo, hi]`` (both inclusive)."""
    lo, hi = count_range
    return int(rng.integers(lo, hi + 1))


def pedestrian_count(rng: np.random.Generator, count_range: tuple[int, int], override: int | None) -> int:
    """The world's pedestrian count, or ``override``; the draw is always made (same layout either way)."""
    drawn = draw_count(rng, count_range)
    if override is None:
        return drawn
    if override < 0:
        raise ValueError("n_pedestrians must be >= 0")
    return override


def path_regions(
    n: int, start_xy: FloatArray, target_xy: FloatArray, radius_m: float
) -> list[tuple[WalkRegion, float]]:
    """``n`` walk regions around the start→target segment (with target attraction)."""
    region = WalkRegion((float(start_xy[0]), float(start_xy[1])), (float(target_xy[0]), float(target_xy[1])), radius_m)
    return [(region, PATH_TARGET_PROB) for _ in range(n)]
