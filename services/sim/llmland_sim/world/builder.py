"""The world builder: seeded generators and the placement of pads, obstacles and actors.

A recipe (:mod:`.recipes`) decides *where* things go; the builder creates their pybullet
bodies, their :class:`~.model.WorldObject` and keeps the :class:`~.layout.Layout` guarantees.
Two generators derive from the seed: ``rng`` for the layout, ``crng`` for colours, so a
change of colours never moves an obstacle.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Sequence

import numpy as np
from llmland_schemas import WORLD_NAMES
from llmland_schemas.arrays import FloatArray, VecLike

from . import shapes
from .actors import LaneLoop, Pedestrian, Vehicle, WalkRegion, actor_rng
from .geometry import Footprint
from .layout import OBSTACLE_GAP_M, PED_START_CLEARANCE_M, Layout
from .model import WorldObject

logger = logging.getLogger(__name__)

#: Probability that a pad carries an "H" (else a cross).
H_MARKER_PROB = 0.7
#: Probability that a vehicle is a van (else a car).
VAN_PROB = 0.2
#: Objects sit this far (m) below the lowest ground point under them on uneven ground, and the
#: ground is sampled on a ring of this many points around them.
SINK_M = 0.05
SINK_RING_POINTS = 8
#: A tree's base sits this much (m) deeper, its trunk as much longer.
TREE_SINK_M = 0.1
#: Rocks: main lobe radius (m), extra lobes (inclusive count) of this size relative to it, this
#: far out (relative), lobe centres this high (relative to their radius).
ROCK_RADIUS_RANGE_M = (0.35, 0.8)
ROCK_EXTRA_LOBES = (0, 2)
ROCK_LOBE_RATIO_RANGE = (0.5, 0.8)
ROCK_LOBE_OFFSET = 0.6
ROCK_MAIN_LIFT = 0.3
ROCK_LOBE_LIFT = 0.2
#: Crates: length, width, height ranges (m).
CRATE_SIZE_RANGES_M = ((0.6, 1.6), (0.6, 1.4), (0.5, 1.3))
#: Bushes: lobes (inclusive count), lobe radius (m), offsets of the extra lobes (m), lift (relative).
BUSH_LOBES = (2, 4)
BUSH_LOBE_RADIUS_RANGE_M = (0.35, 0.7)
BUSH_LOBE_OFFSET_RANGE_M = (0.2, 0.55)
BUSH_LOBE_LIFT = 0.55
#: A walker's start is drawn this far (m) inside its region, up to this many times.
PED_START_MARGIN_M = 0.5
PED_START_TRIES = 500


class WorldBuilder:
    """Shared state while building one world: seeded generators, objects, surfaces, ids."""

    def __init__(self, client: int, name: str, seed: int) -> None:
        code = WORLD_NAMES.index(name) + 1
        s = seed % 2**63
        self.client = client
        self.name = name
        self.seed = seed
        self.rng = np.random.default_rng([s, 0, code])  # layout
        self.crng = np.random.default_rng([s, 2, code])  # colours
        self.objects: list[WorldObject] = []
        self.surfaces: list[int] = []
        self.counts: dict[str, int] = {}
        self.ground: Callable[[float, float], float] = lambda x, y: 0.0

    def next_id(self, cls: str) -> str:
        k = self.counts.get(cls, 0)
        self.counts[cls] = k + 1
        return f"{cls}_{k}"

    def add_static(
        self,
        cls: str,
        body_id: int,
        size_m: tuple[float, float, float],
        base_m: VecLike,
        yaw_rad: float,
        footprint: Footprint,
        ground_footprint: Footprint | None = None,
    ) -> WorldObject:
        center = np.array([footprint.center_xy[0], footprint.center_xy[1], float(base_m[2]) + 0.5 * size_m[2]])
        obj = WorldObject(
            obj_id=self.next_id(cls),
            cls=cls,
            body_id=body_id,
            dynamic=False,
            size_m=size_m,
            yaw_rad=yaw_rad,
            center_m=center,
            footprint=footprint,
            ground_footprint=ground_footprint or footprint,
        )
        self.objects.append(obj)
        return obj

    def add_pad(
        self,
        xy: VecLike,
        radius_range_m: tuple[float, float],
        ground_z_m: float = 0.0,
        surface_top_m: float = 0.0,
        yaw_rad: float = 0.0,
    ) -> float:
        """The landing pad at ``xy`` on a surface ``surface_top_m`` above the ground; returns its radius (m)."""
        rng = self.rng
        pad_r = float(rng.uniform(*radius_range_m))
        marker = "H" if rng.uniform() < H_MARKER_PROB else "cross"
        x, y = float(xy[0]), float(xy[1])
        body = shapes.create_landing_pad(
            self.client, self.crng, (x, y, ground_z_m + surface_top_m), pad_r, marker, yaw_rad
        )
        height = surface_top_m + shapes.PAD_TOP_M
        pad = WorldObject(
            self.next_id("pad"),
            "pad",
            body,
            False,
            (2 * pad_r, 2 * pad_r, height),
            center_m=np.array([x, y, ground_z_m + height / 2]),
            footprint=Footprint((x, y), pad_r),
        )
        self.objects.append(pad)
        return pad_r

    # ------------------------------------------------------------ placement of typical items

    def sink_z(self, xy: VecLike, radius_m: float) -> float:
        """Base height for an object of radius ``radius_m`` at ``xy``: lowest ground point, −5 cm."""
        x, y = float(xy[0]), float(xy[1])
        ring = np.linspace(0, 2 * math.pi, SINK_RING_POINTS, False)
        pts = [(x, y)] + [(x + radius_m * math.cos(a), y + radius_m * math.sin(a)) for a in ring]
        zs = [self.ground(px, py) for px, py in pts]
        return min(zs) - (SINK_M if max(zs) - min(zs) > 1e-6 else 0.0)

    def try_tree(
        self, lay: Layout, xy: VecLike, conifer: bool, trunk_h: float, crown_r: float, gap_m: float = OBSTACLE_GAP_M
    ) -> bool:
        fr = shapes.tree_footprint_radius(crown_r, conifer)
        fp = Footprint((float(xy[0]), float(xy[1])), fr)
        if not lay.fits(fp, gap_m):
            return False
        trunk_r = shapes.tree_trunk_radius(crown_r)
        gfp = Footprint(fp.center_xy, trunk_r)
        lay.add(fp, gfp)
        z = self.sink_z(xy, trunk_r) - TREE_SINK_M
        body = shapes.create_tree(self.client, self.crng, (xy[0], xy[1], z), trunk_h + TREE_SINK_M, crown_r, conifer)
        h = shapes.tree_height(trunk_h + TREE_SINK_M, crown_r, conifer)
        self.add_static("tree", body, (2 * fr, 2 * fr, h), (xy[0], xy[1], z), 0.0, fp, gfp)
        return True

    def try_rock(self, lay: Layout, xy: FloatArray) -> bool:
        rng = self.rng
        r0 = float(rng.uniform(*ROCK_RADIUS_RANGE_M))
        lobes = [(0.0, 0.0, ROCK_MAIN_LIFT * r0, r0)]
        for _ in range(int(rng.integers(ROCK_EXTRA_LOBES[0], ROCK_EXTRA_LOBES[1] + 1))):
            a = float(rng.uniform(0, 2 * math.pi))
            rk = r0 * float(rng.uniform(*ROCK_LOBE_RATIO_RANGE))
            off = ROCK_LOBE_OFFSET * r0
            lobes.append((off * math.cos(a), off * math.sin(a), ROCK_LOBE_LIFT * rk, rk))
        return self._place_lobed(lay, xy, "rock", lobes, shapes.create_rock)

    def try_crate(self, lay: Layout, xy: FloatArray) -> bool:
        rng = self.rng
        size = (
            float(rng.uniform(*CRATE_SIZE_RANGES_M[0])),
            float(rng.uniform(*CRATE_SIZE_RANGES_M[1])),
            float(rng.uniform(*CRATE_SIZE_RANGES_M[2])),
        )
        yaw = float(rng.uniform(-math.pi, math.pi))
        fp = Footprint((float(xy[0]), float(xy[1])), half_xy=(size[0] / 2, size[1] / 2), yaw_rad=yaw)
        if not lay.fits(fp):
            return False
        lay.add(fp)
        z = self.sink_z(xy, fp.bounding_radius())
        body = shapes.create_crate(self.client, self.crng, (xy[0], xy[1], z), size, yaw)
        self.add_static("rock", body, size, (xy[0], xy[1], z), yaw, fp)
        return True

    def try_bush(self, lay: Layout, xy: FloatArray) -> bool:
        rng = self.rng
        lobes = []
        for k in range(int(rng.integers(BUSH_LOBES[0], BUSH_LOBES[1] + 1))):
            r = float(rng.uniform(*BUSH_LOBE_RADIUS_RANGE_M))
            off = 0.0 if k == 0 else float(rng.uniform(*BUSH_LOBE_OFFSET_RANGE_M))
            a = float(rng.uniform(0, 2 * math.pi))
            lobes.append((off * math.cos(a), off * math.sin(a), BUSH_LOBE_LIFT * r, r))
        return self._place_lobed(lay, xy, "bush", lobes, shapes.create_bush)

    def _place_lobed(self, lay: Layout, xy: FloatArray, cls: str, lobes: list[tuple[float, float, float, float]],
                     create: Callable[..., int]) -> bool:
        """Place an object made of sphere lobes ``(dx, dy, z, r)`` (m) if its disc footprint fits."""
        fr = max(math.hypot(x, y) + r for x, y, _, r in lobes)
        fp = Footprint((float(xy[0]), float(xy[1])), fr)
        if not lay.fits(fp):
            return False
        lay.add(fp)
        z = self.sink_z(xy, fr)
        body = create(self.client, self.crng, (xy[0], xy[1], z), lobes)
        h = max(zc + r for _, _, zc, r in lobes)
        self.add_static(cls, body, (2 * fr, 2 * fr, h), (xy[0], xy[1], z), 0.0, fp)
        return True

    def try_box_object(
        self,
        lay: Layout,
        cls: str,
        xy: VecLike,
        size_xy: tuple[float, float],
        height_m: float,
        yaw: float,
        create: Callable[[tuple[float, float, float]], int],
        gap_m: float = OBSTACLE_GAP_M,
    ) -> bool:
        """Place a rectangular object; ``create(base_m)`` builds its body."""
        fp = Footprint((float(xy[0]), float(xy[1])), half_xy=(size_xy[0] / 2, size_xy[1] / 2), yaw_rad=yaw)
        if not lay.fits(fp, gap_m):
            return False
        lay.add(fp)
        base = (float(xy[0]), float(xy[1]), self.sink_z(xy, fp.bounding_radius()))
        body = create(base)
        self.add_static(cls, body, (size_xy[0], size_xy[1], height_m), base, yaw, fp)
        return True

    # ------------------------------------------------------------ actors

    def add_pedestrians(
        self,
        regions: Sequence[tuple[WalkRegion, float]],
        target_xy: FloatArray,
        lay: Layout,
        extra_blocked: Callable[[float, float], bool] | None = None,
    ) -> None:
        """One pedestrian per ``(region, target_prob)``."""

        def is_free(x: float, y: float) -> bool:
            if extra_blocked is not None and extra_blocked(x, y):
                return False
            return lay.is_free(x, y)

        for region, target_prob in regions:
            k = self.counts.get("person", 0)
            ped = Pedestrian(
                f"person_{k}",
                actor_rng(self.seed, k),
                region,
                start_xy=self._pedestrian_start(region, lay, is_free, k),
                target_xy=target_xy,
                target_prob=target_prob,
                is_free=is_free,
                ground_height=self.ground,
            )
            pos, yaw = ped.pose()
            body = shapes.create_person(self.client, self.crng, pos, yaw)
            ped.attach(self.client, body)
            obj = WorldObject(self.next_id("person"), "person", body, True, (0.3, 0.62, shapes.PERSON_HEIGHT_M))
            obj.actor = ped
            self.objects.append(obj)

    def _pedestrian_start(
        self, region: WalkRegion, lay: Layout, is_free: Callable[[float, float], bool], k: int
    ) -> FloatArray | None:
        """A free start in ``region`` at least :data:`PED_START_CLEARANCE_M` from the drone start."""
        rng = actor_rng(self.seed, 1000 + k)
        for _ in range(PED_START_TRIES):
            q = region.sample(rng, margin_m=PED_START_MARGIN_M)
            if is_free(float(q[0]), float(q[1])) and np.linalg.norm(q - lay.start_xy[:2]) >= PED_START_CLEARANCE_M:
                return q
        logger.warning("no pedestrian start %.0f m from the drone start; sampling anywhere", PED_START_CLEARANCE_M)
        return None

    def add_vehicle_actor(self, loop: LaneLoop, index: int) -> None:
        veh = Vehicle(f"vehicle_actor_{index}", actor_rng(self.seed, 100 + index), loop, ground_height=self.ground)
        kind = "van" if self.rng.uniform() < VAN_PROB else "car"
        pos, yaw = veh.pose()
        body = shapes.create_car(self.client, self.crng, pos, yaw, kind)
        veh.attach(self.client, body)
        size = shapes.VAN_SIZE_M if kind == "van" else shapes.CAR_SIZE_M
        obj = WorldObject(self.next_id("vehicle"), "vehicle", body, True, size)
        obj.actor = veh
        self.objects.append(obj)
