"""``open_field``: flat grass, a pad near the origin, a tree or two and a few rocks / crates, one walker.

Half the obstacles are drawn near the start→target flight path, the rest anywhere around it.
"""

from __future__ import annotations

import numpy as np
from llmland_schemas.arrays import FloatArray

from .. import shapes
from ..builder import WorldBuilder
from ..layout import PLACE_TRIES, Layout, draw_count, path_regions, pedestrian_count, sample_start
from ..model import World

#: The target is drawn uniformly in a square of this half-size (m) around the origin.
TARGET_HALF_RANGE_M = 1.0
PAD_RADIUS_RANGE_M = (0.9, 1.2)
#: Counts (inclusive ranges).
TREE_COUNT = (1, 2)
SMALL_OBSTACLE_COUNT = (2, 4)
PEDESTRIAN_COUNT = (1, 1)
#: Probability that an obstacle candidate lies near the flight path (else scattered).
NEAR_PATH_PROB = 0.5
#: Near the path: this fraction of the target→start vector along it, this lateral spread (m, 1 σ).
NEAR_PATH_ALONG_RANGE = (0.1, 1.1)
NEAR_PATH_LATERAL_SIGMA_M = 3.0
#: Scattered: uniform in a square of this half-size (m) around the path's midpoint.
SCATTER_HALF_M = 18.0
CONIFER_PROB = 0.4
BROADLEAF_TRUNK_RANGE_M = (1.8, 3.0)
CONIFER_TRUNK_RANGE_M = (0.8, 1.4)
CROWN_RADIUS_RANGE_M = (1.2, 2.2)
#: Probability that a small obstacle is a crate (else a rock).
CRATE_PROB = 0.4
#: Half-width (m) of the walkers' region around the flight path.
WALK_RADIUS_M = 4.0


def build(b: WorldBuilder, n_pedestrians: int | None) -> World:
    rng = b.rng
    target_xy = rng.uniform(-TARGET_HALF_RANGE_M, TARGET_HALF_RANGE_M, 2)
    start_xy, alt = sample_start(rng, target_xy, lambda q: True)
    b.surfaces.append(shapes.create_ground(b.client, b.crng))
    pad_r = b.add_pad(target_xy, PAD_RADIUS_RANGE_M)
    lay = Layout(target_xy, start_xy)
    mid = 0.5 * (start_xy + target_xy)
    d = start_xy - target_xy
    u = d / np.linalg.norm(d)
    nrm = np.array([-u[1], u[0]])

    def candidate() -> FloatArray:
        if rng.uniform() < NEAR_PATH_PROB:
            return (
                target_xy + rng.uniform(*NEAR_PATH_ALONG_RANGE) * d + rng.normal(0.0, NEAR_PATH_LATERAL_SIGMA_M) * nrm
            )
        return mid + rng.uniform(-SCATTER_HALF_M, SCATTER_HALF_M, 2)

    n_trees = draw_count(rng, TREE_COUNT)
    n_small = draw_count(rng, SMALL_OBSTACLE_COUNT)
    for _ in range(n_trees):
        conifer = bool(rng.uniform() < CONIFER_PROB)
        trunk_h = (
            float(rng.uniform(*BROADLEAF_TRUNK_RANGE_M)) if not conifer else float(rng.uniform(*CONIFER_TRUNK_RANGE_M))
        )
        crown_r = float(rng.uniform(*CROWN_RADIUS_RANGE_M))
        for _ in range(PLACE_TRIES):
            if b.try_tree(lay, candidate(), conifer, trunk_h, crown_r):
                break
    for _ in range(n_small):
        crate = bool(rng.uniform() < CRATE_PROB)
        for _ in range(PLACE_TRIES):
            xy = candidate()
            if (b.try_crate if crate else b.try_rock)(lay, xy):
                break
    n_ped = pedestrian_count(rng, PEDESTRIAN_COUNT, n_pedestrians)
    b.add_pedestrians(path_regions(n_ped, start_xy, target_xy, WALK_RADIUS_M), target_xy, lay)
    return World(
        b.name,
        b.seed,
        b.client,
        np.array([start_xy[0], start_xy[1], alt]),
        np.array([target_xy[0], target_xy[1], 0.0]),
        pad_r,
        b.objects,
        b.surfaces,
    )
