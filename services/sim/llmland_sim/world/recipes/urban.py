"""``urban``: a street with traffic, rows of buildings, a parking row with the pad in one spot, a plaza.

Layout (world y grows north): the parking row runs along x through the target; the street
lies north of it; buildings line the street's north side, its south side (leaving the plaza
around the target open) and the plaza's back. Pedestrians walk the south sidewalk and around
the flight path, never on the road.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import partial

import numpy as np
from llmland_schemas.arrays import FloatArray

from .. import shapes
from ..actors import LaneLoop, WalkRegion
from ..builder import VAN_PROB, WorldBuilder
from ..layout import PLACE_TRIES, Layout, draw_count, path_regions, pedestrian_count, sample_start
from ..model import World

#: The target is drawn uniformly in a square of this half-size (m) around the origin.
TARGET_HALF_RANGE_M = 0.5
PAD_RADIUS_RANGE_M = (0.9, 1.15)
#: The street's centre line lies this far (m) north of the target; it runs x ∈ ±STREET_HALF_LENGTH_M.
STREET_OFFSET_RANGE_M = (9.5, 12.0)
STREET_HALF_LENGTH_M = 70.0
STREET_HALF_WIDTH_M = 3.5
SIDEWALK_WIDTH_M = 2.5
#: Half-width (m, along x) of the open plaza around the target.
PLAZA_HALF_X_RANGE_M = (13.0, 16.0)
#: Parking row: cars oriented along y, spots this wide (m) along x, ±PARKING_SPOTS around the pad's spot.
PARKING_HALF_DEPTH_M = 3.0
PARKING_SPOT_WIDTH_M = 2.7
PARKING_SPOTS = 6
#: Spots closer than this (in spots) to the pad's stay free.
PAD_SPOT_KEEP = 2
PARKED_COUNT = (2, 4)
#: Parked cars sit this far (m) off the spot centre, at most (x, y).
PARKED_JITTER_X_M = 0.1
PARKED_JITTER_Y_M = 0.15
LOT_RGBA = (0.26, 0.26, 0.28, 1.0)
LINE_RGBA = (0.92, 0.92, 0.92, 1.0)
LINE_HALF_WIDTH_M = 0.05
LINE_HALF_LENGTH_M = 2.5
#: The drone starts south of the street and at least this far (m) beyond the parking row.
START_LOT_MARGIN_M = 1.5
#: Building rows span x ∈ ±BUILDING_ROW_HALF_LENGTH_M; sizes (m) along the row, deep, tall.
BUILDING_ROW_HALF_LENGTH_M = 65.0
BUILDING_ROW_START_RANGE_M = (0.0, 3.0)
BUILDING_WIDTH_RANGE_M = (8.0, 16.0)
BUILDING_DEPTH_RANGE_M = (8.0, 14.0)
BUILDING_HEIGHT_RANGE_M = (6.0, 22.0)
BUILDING_SPACING_RANGE_M = (1.0, 5.0)
#: Fronts stand this far (m) back from the sidewalk edge; the plaza's back row this far south.
BUILDING_SETBACK_RANGE_M = (0.5, 2.0)
PLAZA_BACK_RANGE_M = (11.0, 14.0)
BUILDING_GAP_M = 0.5
#: The roof slab of :func:`~..shapes.create_building` (m).
ROOF_SLAB_M = 0.2
PLAZA_TREE_COUNT = (1, 3)
PLAZA_TREE_CROWN_RANGE_M = (1.2, 2.0)
PLAZA_TREE_TRUNK_RANGE_M = (2.2, 3.2)
#: Plaza trees stay this far (m) inside the plaza.
PLAZA_TREE_MARGIN_M = 2
MOVING_COUNT = (1, 2)
#: Driving cars loop over x ∈ ±LANE_HALF_LENGTH_M; two cars split it, ±LANE_SPLIT_M apart.
LANE_HALF_LENGTH_M = 55.0
LANE_SPLIT_M = 3.0
PEDESTRIAN_COUNT = (2, 3)
#: The sidewalk walker's region: ± this (m) along x around the target, this far (m) inside the kerb.
SIDEWALK_WALK_HALF_M = 25.0
SIDEWALK_WALK_INSET_M = 0.3
WALK_RADIUS_M = 3.5


@dataclass(frozen=True)
class _Site:
    """The drawn dimensions everything else is placed by (m)."""

    tx: float
    ty: float
    street_y: float
    plaza_half_x: float

    @property
    def curb_y(self) -> float:
        """South edge of the south sidewalk."""
        return self.street_y - STREET_HALF_WIDTH_M - SIDEWALK_WIDTH_M


def _lay_surfaces(b: WorldBuilder, site: _Site) -> None:
    """Ground, the street, the parking row and its lines."""
    client, tx, ty = b.client, site.tx, site.ty
    b.surfaces.append(shapes.create_ground(client, b.crng))
    b.surfaces += shapes.create_street(
        client,
        b.crng,
        (-STREET_HALF_LENGTH_M, site.street_y),
        (STREET_HALF_LENGTH_M, site.street_y),
        2 * STREET_HALF_WIDTH_M,
        SIDEWALK_WIDTH_M,
    )
    spot_w = PARKING_SPOT_WIDTH_M
    lot_half_x = (PARKING_SPOTS + 0.5) * spot_w
    lot = [(tx, ty, lot_half_x, PARKING_HALF_DEPTH_M, 0.0)]
    b.surfaces.append(shapes.create_flat_rects(client, b.crng, lot, LOT_RGBA, shapes.STREET_TOP_M))
    lines = [
        (tx + (k + 0.5) * spot_w, ty, LINE_HALF_WIDTH_M, LINE_HALF_LENGTH_M, 0.0)
        for k in range(-PARKING_SPOTS - 1, PARKING_SPOTS + 1)
    ]
    b.surfaces.append(shapes.create_flat_rects(client, b.crng, lines, LINE_RGBA, shapes.MARKING_TOP_M))


def _park_cars(b: WorldBuilder, lay: Layout, site: _Site) -> None:
    """Parked cars in the row, never in the pad's spot or its neighbours."""
    rng = b.rng
    spots = [k for k in range(-PARKING_SPOTS, PARKING_SPOTS + 1) if abs(k) >= PAD_SPOT_KEEP]
    n_parked = draw_count(rng, PARKED_COUNT)
    chosen = rng.choice(len(spots), size=n_parked, replace=False)
    for idx in sorted(int(i) for i in chosen):
        k = spots[idx]
        kind = "van" if rng.uniform() < VAN_PROB else "car"
        size = shapes.VAN_SIZE_M if kind == "van" else shapes.CAR_SIZE_M
        yaw = math.pi / 2 if rng.uniform() < 0.5 else -math.pi / 2
        xy = (
            site.tx + k * PARKING_SPOT_WIDTH_M + float(rng.uniform(-PARKED_JITTER_X_M, PARKED_JITTER_X_M)),
            site.ty + float(rng.uniform(-PARKED_JITTER_Y_M, PARKED_JITTER_Y_M)),
        )
        make_car = partial(shapes.create_car, b.client, b.crng, yaw_rad=yaw, kind=kind)
        fp_xy = (size[0] + 2 * shapes.VEHICLE_OVERHANG_M, size[1])
        b.try_box_object(lay, "vehicle", xy, fp_xy, size[2], yaw, make_car)


def _building_row(b: WorldBuilder, lay: Layout, x0: float, x1: float, front_y: float, facing_north: bool) -> None:
    """Buildings side by side from ``x0`` to ``x1`` (m), fronts on ``front_y``."""
    rng = b.rng
    x = x0 + float(rng.uniform(*BUILDING_ROW_START_RANGE_M))
    while True:
        width = float(rng.uniform(*BUILDING_WIDTH_RANGE_M))
        if x + width > x1:
            break
        depth = float(rng.uniform(*BUILDING_DEPTH_RANGE_M))
        height = float(rng.uniform(*BUILDING_HEIGHT_RANGE_M))
        cy = front_y + depth / 2 if not facing_north else front_y - depth / 2
        yaw = -math.pi / 2 if not facing_north else math.pi / 2
        make_building = partial(shapes.create_building, b.client, b.crng, size_m=(depth, width, height), yaw_rad=yaw)
        ov = 2 * shapes.BUILDING_OVERHANG_M
        fp_xy = (depth + ov, width + ov)
        b.try_box_object(
            lay, "building", (x + width / 2, cy), fp_xy, height + ROOF_SLAB_M, yaw, make_building, BUILDING_GAP_M
        )
        x += width + float(rng.uniform(*BUILDING_SPACING_RANGE_M))


def _buildings(b: WorldBuilder, lay: Layout, site: _Site) -> float:
    """The street's two rows and the plaza's back row; returns the back row's front (m)."""
    rng, tx, half, px = b.rng, site.tx, BUILDING_ROW_HALF_LENGTH_M, site.plaza_half_x
    north_front = site.street_y + STREET_HALF_WIDTH_M + SIDEWALK_WIDTH_M + float(rng.uniform(*BUILDING_SETBACK_RANGE_M))
    _building_row(b, lay, -half, half, north_front, facing_north=False)
    south_front = site.curb_y - float(rng.uniform(*BUILDING_SETBACK_RANGE_M))
    _building_row(b, lay, -half, tx - px, south_front, facing_north=True)
    _building_row(b, lay, tx + px, half, south_front, facing_north=True)
    back_front = site.ty - float(rng.uniform(*PLAZA_BACK_RANGE_M))
    _building_row(b, lay, tx - px, tx + px, back_front, facing_north=True)
    return back_front


def _plaza_trees(b: WorldBuilder, lay: Layout, site: _Site, back_front: float) -> None:
    rng, tx, m = b.rng, site.tx, PLAZA_TREE_MARGIN_M
    for _ in range(draw_count(rng, PLAZA_TREE_COUNT)):
        crown_r = float(rng.uniform(*PLAZA_TREE_CROWN_RANGE_M))
        trunk_h = float(rng.uniform(*PLAZA_TREE_TRUNK_RANGE_M))
        for _ in range(PLACE_TRIES):
            txy = np.array(
                [
                    tx + rng.uniform(-site.plaza_half_x + m, site.plaza_half_x - m),
                    rng.uniform(back_front + m, site.curb_y - m),
                ]
            )
            if abs(txy[1] - site.ty) < PARKING_HALF_DEPTH_M + crown_r:
                continue
            if b.try_tree(lay, txy, False, trunk_h, crown_r):
                break


def _traffic(b: WorldBuilder, site: _Site) -> None:
    """Driving cars on disjoint loops, so they never drive through each other."""
    n_moving = draw_count(b.rng, MOVING_COUNT)
    lane = STREET_HALF_WIDTH_M / 2
    far, split = LANE_HALF_LENGTH_M, LANE_SPLIT_M
    spans = [(-far, far)] if n_moving == 1 else [(-far, -split), (split, far)]
    for j, (xa, xb) in enumerate(spans):
        b.add_vehicle_actor(LaneLoop((xa, site.street_y), (xb, site.street_y), lane), j)


def _pedestrians(
    b: WorldBuilder, lay: Layout, site: _Site, start_xy: FloatArray, target_xy: FloatArray, n_pedestrians: int | None
) -> None:
    """One walker on the south sidewalk, the others around the flight path (not on the road)."""
    n_ped = pedestrian_count(b.rng, PEDESTRIAN_COUNT, n_pedestrians)
    sw_y = site.street_y - STREET_HALF_WIDTH_M - SIDEWALK_WIDTH_M / 2
    regions: list[tuple[WalkRegion, float]] = []
    if n_ped >= 1:
        tx, half, inset = site.tx, SIDEWALK_WALK_HALF_M, SIDEWALK_WIDTH_M / 2 - SIDEWALK_WALK_INSET_M
        regions.append((WalkRegion((tx - half, sw_y), (tx + half, sw_y), inset), 0.0))
    regions += path_regions(max(n_ped - 1, 0), start_xy, target_xy, WALK_RADIUS_M)

    def on_road(x: float, y: float) -> bool:
        return abs(y - site.street_y) < STREET_HALF_WIDTH_M

    b.add_pedestrians(regions, target_xy, lay, on_road)


def build(b: WorldBuilder, n_pedestrians: int | None) -> World:
    rng = b.rng
    target_xy = rng.uniform(-TARGET_HALF_RANGE_M, TARGET_HALF_RANGE_M, 2)
    tx, ty = float(target_xy[0]), float(target_xy[1])
    street_y = ty + float(rng.uniform(*STREET_OFFSET_RANGE_M))
    site = _Site(tx, ty, street_y, float(rng.uniform(*PLAZA_HALF_X_RANGE_M)))

    def start_ok(q: FloatArray) -> bool:
        south = q[1] <= street_y - STREET_HALF_WIDTH_M
        return bool(south and abs(q[1] - ty) >= PARKING_HALF_DEPTH_M + START_LOT_MARGIN_M)

    start_xy, alt = sample_start(rng, target_xy, start_ok)
    _lay_surfaces(b, site)
    pad_r = b.add_pad((tx, ty), PAD_RADIUS_RANGE_M, surface_top_m=shapes.STREET_TOP_M, yaw_rad=math.pi / 2)
    lay = Layout(target_xy, start_xy)
    _park_cars(b, lay, site)
    back_front = _buildings(b, lay, site)
    _plaza_trees(b, lay, site, back_front)
    _traffic(b, site)
    _pedestrians(b, lay, site, start_xy, target_xy, n_pedestrians)
    return World(
        b.name,
        b.seed,
        b.client,
        np.array([start_xy[0], start_xy[1], alt]),
        np.array([tx, ty, 0.0]),
        pad_r,
        b.objects,
        b.surfaces,
        meta={"street_y_m": street_y, "street_half_width_m": STREET_HALF_WIDTH_M, "sidewalk_width_m": SIDEWALK_WIDTH_M},
    )
