"""``forest_edge``: a meadow clearing with the pad, an irregular forest edge, a shed, uneven ground.

The forest lies in a seeded direction ``phi`` beyond an edge line that wobbles; the drone
starts on the meadow side. Lone trees and rocks dot the meadow, bushes line the edge.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial

import numpy as np
from llmland_schemas.arrays import FloatArray

from .. import shapes
from ..builder import WorldBuilder
from ..layout import PLACE_TRIES, Layout, draw_count, path_regions, pedestrian_count, sample_start
from ..model import World
from ..terrain import Terrain, terrain_heights

#: Height (m) of the flat ground plane under the terrain (and outside it).
FOREST_BASE_Z_M = -0.02
#: The target is drawn uniformly in a square of this half-size (m) around the origin.
TARGET_HALF_RANGE_M = 1.0
PAD_RADIUS_RANGE_M = (0.9, 1.2)
#: The forest edge lies this far (m) from the target; no tree stands within the clearing radius (m).
EDGE_DISTANCE_RANGE_M = (4.0, 7.0)
CLEARING_RADIUS_RANGE_M = (6.0, 8.0)
#: The drone starts within this angle (deg) of the direction away from the forest.
START_SPREAD_DEG = 70.0
#: Terrain grid: cells of this size (m), this many points a side; flat within the first radius
#: (m) of the target, full height beyond the second.
TERRAIN_CELL_M = 2.5
TERRAIN_POINTS = 41
TERRAIN_FLAT_RADII_M = (6.0, 11.0)
#: The edge line wobbles by these amplitudes (m) at these wavenumbers (rad/m).
EDGE_WOBBLE_AMPLITUDE_RANGE_M = (0.5, 1.5)
EDGE_WOBBLE_WAVENUMBER_RANGE = (0.1, 0.3)
EDGE_WOBBLE_PHASE_RAD = 1.0
#: The shed: off the forest direction by this angle (rad), this far (m) from the target.
SHED_ANGLE_RANGE_RAD = (0.5, math.pi - 0.3)
SHED_DISTANCE_RANGE_M = (7.0, 12.0)
SHED_LENGTH_RANGE_M = (2.5, 4.0)
SHED_WIDTH_RANGE_M = (2.0, 3.0)
SHED_WALL_HEIGHT_RANGE_M = (2.1, 2.5)
#: The shed's roof overhang in its footprint (m, total along x and y), its gap to the rest (m).
SHED_ROOF_OVERHANG_M = (0.5, 0.6)
SHED_GAP_M = 0.5
#: Forest trees: how many, drawn in a square of this half-size (m), tries per tree.
FOREST_TREE_COUNT = (32, 43)
FOREST_HALF_M = 38.0
FOREST_TRIES_PER_TREE = 15
FOREST_CONIFER_PROB = 0.5
CONIFER_TRUNK_RANGE_M = (0.6, 1.4)
BROADLEAF_TRUNK_RANGE_M = (1.8, 3.2)
CONIFER_CROWN_RANGE_M = (1.1, 2.0)
BROADLEAF_CROWN_RANGE_M = (1.3, 2.6)
#: Lone meadow trees: at least this far (m) out of the forest.
MEADOW_TREE_COUNT = (2, 4)
MEADOW_TREE_HALF_M = 30.0
MEADOW_TREE_EDGE_M = 3.0
MEADOW_CONIFER_PROB = 0.2
MEADOW_TRUNK_RANGE_M = (1.8, 3.0)
MEADOW_CROWN_RANGE_M = (1.3, 2.4)
#: Bushes along the edge: between these depths (m) into the forest.
BUSH_COUNT = (6, 10)
BUSH_HALF_M = 25.0
BUSH_DEPTH_RANGE_M = (-3.5, 1.5)
#: Rocks in the meadow: at least this far (m) out of the forest.
ROCK_COUNT = (2, 4)
ROCK_HALF_M = 20.0
ROCK_EDGE_M = 2.0
PEDESTRIAN_COUNT = (1, 2)
WALK_RADIUS_M = 4.5


@dataclass(frozen=True)
class _Edge:
    """The irregular forest edge: ``depth(q)`` is the signed distance (m) into the forest."""

    target_xy: FloatArray
    n_in: FloatArray  # unit vector towards the forest
    edge_d: float
    wobble_a: FloatArray
    wobble_k: FloatArray

    def depth(self, q: FloatArray) -> float:
        rel = q - self.target_xy
        along = float(rel @ np.array([-self.n_in[1], self.n_in[0]]))
        a, k = self.wobble_a, self.wobble_k
        edge = self.edge_d + a[0] * math.sin(k[0] * along) + a[1] * math.sin(k[1] * along + EDGE_WOBBLE_PHASE_RAD)
        return float(rel @ self.n_in) - edge


def _place_in_zone(
    b: WorldBuilder,
    target_xy: FloatArray,
    half_m: float,
    in_zone: Callable[[FloatArray], bool],
    place: Callable[[FloatArray], bool],
) -> None:
    """Try up to :data:`PLACE_TRIES` points in the square around the target until ``place`` succeeds."""
    for _ in range(PLACE_TRIES):
        xy = target_xy + b.rng.uniform(-half_m, half_m, 2)
        if not in_zone(xy):
            continue
        if place(xy):
            break


def _ground_and_pad(b: WorldBuilder, target_xy: FloatArray) -> tuple[Terrain, float, float]:
    """Terrain, ground plane and the pad; returns the terrain, the target's height (m) and the pad radius."""
    heights = terrain_heights(b.rng, TERRAIN_POINTS, TERRAIN_CELL_M, target_xy, TERRAIN_FLAT_RADII_M)
    terrain = Terrain(heights, TERRAIN_CELL_M, FOREST_BASE_Z_M)
    b.ground = terrain.height
    b.surfaces.append(shapes.create_ground(b.client, b.crng, FOREST_BASE_Z_M))
    b.surfaces.append(shapes.create_heightfield(b.client, b.crng, heights, TERRAIN_CELL_M))
    tz = terrain.height(float(target_xy[0]), float(target_xy[1]))
    pad_r = b.add_pad(target_xy, PAD_RADIUS_RANGE_M, ground_z_m=tz)
    return terrain, tz, pad_r


def _shed(b: WorldBuilder, lay: Layout, target_xy: FloatArray, phi: float) -> None:
    """A shed near the clearing, on the meadow side or along the edge."""
    rng = b.rng
    for _ in range(PLACE_TRIES):
        ang = phi + float(rng.uniform(*SHED_ANGLE_RANGE_RAD)) * (1 if rng.uniform() < 0.5 else -1)
        dist = float(rng.uniform(*SHED_DISTANCE_RANGE_M))
        xy = target_xy + dist * np.array([math.cos(ang), math.sin(ang)])
        size = (
            float(rng.uniform(*SHED_LENGTH_RANGE_M)),
            float(rng.uniform(*SHED_WIDTH_RANGE_M)),
            float(rng.uniform(*SHED_WALL_HEIGHT_RANGE_M)),
        )
        yaw = float(rng.uniform(-math.pi, math.pi))
        make_shed = partial(shapes.create_shed, b.client, b.crng, size_m=size, yaw_rad=yaw)
        fp_xy = (size[0] + SHED_ROOF_OVERHANG_M[0], size[1] + SHED_ROOF_OVERHANG_M[1])
        if b.try_box_object(lay, "shed", xy, fp_xy, shapes.shed_height(size), yaw, make_shed, SHED_GAP_M):
            break


def _forest(b: WorldBuilder, lay: Layout, edge: _Edge, clearing_r: float) -> None:
    """The forest's trees beyond the edge, outside the clearing."""
    rng, target_xy = b.rng, edge.target_xy
    n_forest = draw_count(rng, FOREST_TREE_COUNT)
    placed = 0
    for _ in range(n_forest * FOREST_TRIES_PER_TREE):
        if placed >= n_forest:
            break
        xy = target_xy + rng.uniform(-FOREST_HALF_M, FOREST_HALF_M, 2)
        if edge.depth(xy) < 0.0 or np.linalg.norm(xy - target_xy) < clearing_r:
            continue
        conifer = bool(rng.uniform() < FOREST_CONIFER_PROB)
        trunk_h = (
            float(rng.uniform(*CONIFER_TRUNK_RANGE_M)) if conifer else float(rng.uniform(*BROADLEAF_TRUNK_RANGE_M))
        )
        crown_r = (
            float(rng.uniform(*CONIFER_CROWN_RANGE_M)) if conifer else float(rng.uniform(*BROADLEAF_CROWN_RANGE_M))
        )
        placed += b.try_tree(lay, xy, conifer, trunk_h, crown_r)


def _meadow(b: WorldBuilder, lay: Layout, edge: _Edge, clearing_r: float) -> None:
    """Lone meadow trees, bushes along the edge, rocks in the meadow."""
    rng, target_xy = b.rng, edge.target_xy

    def meadow_tree(xy: FloatArray) -> bool:
        conifer = bool(rng.uniform() < MEADOW_CONIFER_PROB)
        trunk_h = float(rng.uniform(*MEADOW_TRUNK_RANGE_M))
        return b.try_tree(lay, xy, conifer, trunk_h, float(rng.uniform(*MEADOW_CROWN_RANGE_M)))

    def in_meadow(xy: FloatArray) -> bool:
        return not (edge.depth(xy) > -MEADOW_TREE_EDGE_M or np.linalg.norm(xy - target_xy) < clearing_r)

    for _ in range(draw_count(rng, MEADOW_TREE_COUNT)):
        _place_in_zone(b, target_xy, MEADOW_TREE_HALF_M, in_meadow, meadow_tree)
    lo, hi = BUSH_DEPTH_RANGE_M
    for _ in range(draw_count(rng, BUSH_COUNT)):
        _place_in_zone(b, target_xy, BUSH_HALF_M, lambda xy: lo < edge.depth(xy) < hi, partial(b.try_bush, lay))
    for _ in range(draw_count(rng, ROCK_COUNT)):
        _place_in_zone(
            b, target_xy, ROCK_HALF_M, lambda xy: not edge.depth(xy) > -ROCK_EDGE_M, partial(b.try_rock, lay)
        )


def build(b: WorldBuilder, n_pedestrians: int | None) -> World:
    rng = b.rng
    target_xy = rng.uniform(-TARGET_HALF_RANGE_M, TARGET_HALF_RANGE_M, 2)
    phi = float(rng.uniform(-math.pi, math.pi))
    n_in = np.array([math.cos(phi), math.sin(phi)])
    edge_d = float(rng.uniform(*EDGE_DISTANCE_RANGE_M))
    clearing_r = float(rng.uniform(*CLEARING_RADIUS_RANGE_M))
    meadow, spread = phi + math.pi, math.radians(START_SPREAD_DEG)
    start_xy, alt = sample_start(rng, target_xy, lambda q: True, (meadow - spread, meadow + spread))
    terrain, tz, pad_r = _ground_and_pad(b, target_xy)
    lay = Layout(target_xy, start_xy)
    _shed(b, lay, target_xy, phi)
    wobble_a = rng.uniform(*EDGE_WOBBLE_AMPLITUDE_RANGE_M, 2)
    wobble_k = rng.uniform(*EDGE_WOBBLE_WAVENUMBER_RANGE, 2)
    edge = _Edge(target_xy, n_in, edge_d, wobble_a, wobble_k)
    _forest(b, lay, edge, clearing_r)
    _meadow(b, lay, edge, clearing_r)
    n_ped = pedestrian_count(rng, PEDESTRIAN_COUNT, n_pedestrians)
    b.add_pedestrians(path_regions(n_ped, start_xy, target_xy, WALK_RADIUS_M), target_xy, lay)
    sz = terrain.height(float(start_xy[0]), float(start_xy[1]))
    return World(
        b.name,
        b.seed,
        b.client,
        np.array([start_xy[0], start_xy[1], sz + alt]),
        np.array([target_xy[0], target_xy[1], tz]),
        pad_r,
        b.objects,
        b.surfaces,
        terrain=terrain,
        meta={"forest_dir_rad": phi, "forest_edge_m": edge_d, "clearing_radius_m": clearing_r},
    )
