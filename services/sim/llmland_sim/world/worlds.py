"""Seeded worlds for the pybullet simulator: ``open_field``, ``urban`` and ``forest_edge``.

``build_world(client, name, seed)`` creates the ground, the landing pad at the target, the
static obstacles and the moving actors (pedestrians, cars) in a pybullet client and returns
a :class:`World`. Everything is drawn from generators derived from ``seed``: the same seed
gives the same object list, positions, colours and actor trajectories; different seeds give
different worlds.

Frames and units per ``docs/conventions.md``: world ENU, metres, radians. The ground is
``z = 0`` except in ``forest_edge`` (gentle heightfield terrain; query
:meth:`World.ground_height`). ``target_m`` is the ground point at the pad centre;
``start_m`` the drone start (2.5–4 m above the ground, 8–10 m away horizontally).

Guarantees (enforced at placement, checked by the tests):

* every static obstacle's footprint is ≥ :data:`TARGET_CLEARANCE_M` from the target;
* every static obstacle's footprint is ≥ :data:`START_CLEARANCE_M` from the start (x, y);
* static obstacle footprints do not overlap each other.

Footprints are exact oriented rectangles or discs (the object's full horizontal extent,
e.g. a tree's crown). Walking actors avoid the *ground* footprints (a tree's trunk, the
rest as above).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import partial

import numpy as np
from numpy.typing import NDArray

from llmland_sim.world import shapes
from llmland_sim.world.actors import (
    KinematicActor,
    LaneLoop,
    Pedestrian,
    Vehicle,
    WalkRegion,
    actor_rng,
)

logger = logging.getLogger(__name__)

FloatArray = NDArray[np.float64]
#: A point / vector given as a sequence or a numpy array.
VecLike = Sequence[float] | NDArray[np.float64]

WORLD_NAMES = ("open_field", "urban", "forest_edge")
OBJECT_CLASSES = ("person", "vehicle", "building", "tree", "bush", "shed", "rock", "pad")

#: Guaranteed horizontal clearance (m) between the target and any static obstacle footprint.
TARGET_CLEARANCE_M = 2.5
#: Clearance used when placing obstacles (m); a margin above the guarantee.
_TARGET_PLACE_CLEARANCE_M = 3.0
#: Guaranteed horizontal clearance (m) between the start (x, y) and any static footprint.
START_CLEARANCE_M = 2.0
#: Pedestrians start at least this far (m, horizontally) from the drone start: a person
#: already inside the drone's buffer at t = 0 would score a close call no planner could avoid.
PED_START_CLEARANCE_M = 5.0
#: Minimum gap (m) between static obstacle footprints.
OBSTACLE_GAP_M = 0.2
#: Probability that a pedestrian near the flight path picks its next goal around the target.
PATH_TARGET_PROB = 0.3
#: Height (m) of the flat ground plane under the ``forest_edge`` terrain (and outside it).
FOREST_BASE_Z_M = -0.02


# --------------------------------------------------------------------------- footprints


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

    @property
    def is_rect(self) -> bool:
        """True for a rectangle footprint."""
        return self.half_xy is not None

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


# --------------------------------------------------------------------------- terrain


class Terrain:
    """Heightfield ground, exactly as pybullet triangulates it.

    ``heights_m[i, j]`` is the height at ``x = (j - (nx-1)/2) * cell_m``,
    ``y = (i - (ny-1)/2) * cell_m``; each cell is split along the diagonal from ``(j+1, i)``
    to ``(j, i+1)``. Outside the grid the ground is flat at ``outside_z_m``.
    """

    def __init__(self, heights_m: FloatArray, cell_m: float, outside_z_m: float) -> None:
        self.heights_m = np.asarray(heights_m, dtype=float)
        self.cell_m = float(cell_m)
        self.outside_z_m = float(outside_z_m)
        ny, nx = self.heights_m.shape
        self.half_x_m = 0.5 * (nx - 1) * self.cell_m
        self.half_y_m = 0.5 * (ny - 1) * self.cell_m

    def height(self, x: float, y: float) -> float:
        """Ground height (m) at world ``(x, y)``."""
        if not (-self.half_x_m <= x <= self.half_x_m and -self.half_y_m <= y <= self.half_y_m):
            return self.outside_z_m
        ny, nx = self.heights_m.shape
        fx = (x + self.half_x_m) / self.cell_m
        fy = (y + self.half_y_m) / self.cell_m
        j = min(int(math.floor(fx)), nx - 2)
        i = min(int(math.floor(fy)), ny - 2)
        u, v = fx - j, fy - i
        h = self.heights_m
        h00, h10, h01, h11 = h[i, j], h[i, j + 1], h[i + 1, j], h[i + 1, j + 1]
        if u + v <= 1.0:
            return float(h00 + (h10 - h00) * u + (h01 - h00) * v)
        return float(h11 + (h01 - h11) * (1.0 - u) + (h10 - h11) * (1.0 - v))


def _smoothstep(x: FloatArray) -> FloatArray:
    t = np.clip(x, 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def _terrain_heights(
    rng: np.random.Generator, n: int, cell_m: float, target_xy: FloatArray, flat_r_m: tuple[float, float]
) -> FloatArray:
    """Gentle positive terrain (n, n): Gaussian mounds + undulation, flat near the target."""
    xs = (np.arange(n) - (n - 1) / 2.0) * cell_m
    gx, gy = np.meshgrid(xs, xs)
    h = np.zeros_like(gx)
    half = xs[-1]
    for _ in range(int(rng.integers(7, 12))):
        c = rng.uniform(-0.9 * half, 0.9 * half, 2)
        amp = rng.uniform(0.25, 0.8)
        sig = rng.uniform(4.0, 9.0)
        h += amp * np.exp(-((gx - c[0]) ** 2 + (gy - c[1]) ** 2) / (2.0 * sig**2))
    k = rng.uniform(0.15, 0.35, 2)
    ph = rng.uniform(0.0, 2.0 * math.pi, 2)
    h += 0.06 * (2.0 + np.sin(k[0] * gx + ph[0]) + np.sin(k[1] * gy + ph[1]))
    r = np.hypot(gx - target_xy[0], gy - target_xy[1])
    h *= _smoothstep((r - flat_r_m[0]) / (flat_r_m[1] - flat_r_m[0]))
    edge = np.minimum(half - np.abs(gx), half - np.abs(gy))
    h *= _smoothstep(edge / 6.0)
    return np.maximum(h, 0.0)


# --------------------------------------------------------------------------- world objects


@dataclass(eq=False)
class WorldObject:
    """An object of the world (obstacle, actor or the landing pad).

    Attributes:
        obj_id: unique id such as ``"person_0"``, ``"tree_3"`` (class name + index).
        cls: one of :data:`OBJECT_CLASSES` (crates / boxes are class ``"rock"``).
        body_id: pybullet body id (what segmentation images contain).
        dynamic: True for moving actors (pedestrians, driving cars).
        size_m: extents ``(x, y, z)`` along the object's local axes (m).
        yaw_rad: heading of the local x axis (static objects; actors: see :meth:`yaw`).
        center_m: (3,) centre of the static object's bounding box (m).
        footprint: horizontal extent used by the clearance guarantees (static objects).
        ground_footprint: extent on the ground that walking actors avoid (static objects).
        actor: the kinematic actor driving a dynamic object.
    """

    obj_id: str
    cls: str
    body_id: int
    dynamic: bool
    size_m: tuple[float, float, float]
    yaw_rad: float = 0.0
    center_m: FloatArray = field(default_factory=lambda: np.zeros(3))
    footprint: Footprint | None = None
    ground_footprint: Footprint | None = None
    actor: KinematicActor | None = None

    def position(self) -> FloatArray:
        """Current centre (3,) of the object's bounding box in the world frame (m)."""
        if self.actor is not None:
            pos, _ = self.actor.pose()
            return pos + np.array([0.0, 0.0, 0.5 * self.size_m[2]])
        return self.center_m.copy()

    def velocity(self) -> FloatArray:
        """Current velocity (3,) in m/s (zeros for static objects)."""
        if self.actor is not None:
            return self.actor.velocity()
        return np.zeros(3)

    def yaw(self) -> float:
        """Current heading of the local x axis (rad)."""
        if self.actor is not None:
            return self.actor.pose()[1]
        return self.yaw_rad

    @property
    def is_obstacle(self) -> bool:
        """True for static obstacles (everything static except the pad)."""
        return not self.dynamic and self.cls != "pad"


class World:
    """A built world: objects, actors, start / target and ground queries.

    Attributes:
        name, seed: what :func:`build_world` was called with.
        client: pybullet physics client id.
        start_m: (3,) drone start position (m).
        target_m: (3,) landing target: ground point at the pad centre (m).
        pad_radius_m: landing pad radius (m).
        objects: all :class:`WorldObject` (pad, static obstacles, actors).
        actors: the kinematic actors, in ``objects`` order.
        body_to_object: pybullet body id → ``obj_id`` for every object (segmentation).
        surface_body_ids: ground / terrain / street / paint bodies (not objects).
        time_s: simulated time the actors have been stepped to (s).
        meta: layout parameters (e.g. ``street_y_m`` in urban), for logging / reports.
    """

    def __init__(
        self,
        name: str,
        seed: int,
        client: int,
        start_m: FloatArray,
        target_m: FloatArray,
        pad_radius_m: float,
        objects: list[WorldObject],
        surface_body_ids: list[int],
        terrain: Terrain | None = None,
        ground_z_m: float = 0.0,
        meta: dict[str, float] | None = None,
    ) -> None:
        self.name = name
        self.seed = seed
        self.client = client
        self.start_m = np.asarray(start_m, dtype=float)
        self.target_m = np.asarray(target_m, dtype=float)
        self.pad_radius_m = float(pad_radius_m)
        self.objects = objects
        self.actors: list[KinematicActor] = [o.actor for o in objects if o.actor is not None]
        self.body_to_object: dict[int, str] = {o.body_id: o.obj_id for o in objects}
        self.surface_body_ids = surface_body_ids
        self.time_s = 0.0
        self.meta: dict[str, float] = dict(meta or {})
        self._terrain = terrain
        self._ground_z_m = float(ground_z_m)
        self._by_id = {o.obj_id: o for o in objects}

    def ground_height(self, x: float, y: float) -> float:
        """Height (m) of the ground (what collides and is rendered) at ``(x, y)``."""
        if self._terrain is not None:
            return self._terrain.height(x, y)
        return self._ground_z_m

    def step_actors(self, dt_s: float) -> None:
        """Advance every actor by ``dt_s`` seconds of simulated time and move their bodies."""
        for a in self.actors:
            a.step(dt_s)
        self.time_s += dt_s

    def people(self) -> list[WorldObject]:
        """The pedestrians."""
        return [o for o in self.objects if o.cls == "person"]

    def vehicles(self) -> list[WorldObject]:
        """Parked and driving vehicles."""
        return [o for o in self.objects if o.cls == "vehicle"]

    def static_obstacles(self) -> list[WorldObject]:
        """Static obstacles (buildings, trees, bushes, sheds, rocks, parked cars)."""
        return [o for o in self.objects if o.is_obstacle]

    def get(self, obj_id: str) -> WorldObject:
        """The object with id ``obj_id`` (KeyError if unknown)."""
        return self._by_id[obj_id]

    def object_of_body(self, body_id: int) -> WorldObject | None:
        """The object owning pybullet body ``body_id`` (None for ground, streets, unknown)."""
        oid = self.body_to_object.get(int(body_id))
        return None if oid is None else self._by_id[oid]

    def summary(self) -> str:
        """One-line description (counts per class) for logs."""
        counts: dict[str, int] = {}
        for o in self.objects:
            counts[o.cls] = counts.get(o.cls, 0) + 1
        parts = ", ".join(f"{k}={v}" for k, v in sorted(counts.items()))
        return (
            f"{self.name}(seed={self.seed}) start={np.round(self.start_m, 2).tolist()} "
            f"target={np.round(self.target_m, 2).tolist()} {parts}"
        )


# --------------------------------------------------------------------------- layout helpers


class _Layout:
    """Rejection-sampling placement of static obstacles with the clearance guarantees."""

    def __init__(self, target_xy: FloatArray, start_xy: FloatArray) -> None:
        self.target_xy = target_xy
        self.start_xy = start_xy
        self.footprints: list[Footprint] = []
        self.ground_footprints: list[Footprint] = []

    def fits(self, fp: Footprint, gap_m: float = OBSTACLE_GAP_M) -> bool:
        if fp.distance_to_point(self.target_xy) < _TARGET_PLACE_CLEARANCE_M:
            return False
        if fp.distance_to_point(self.start_xy) < START_CLEARANCE_M + 0.2:
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

    def is_free(self, x: float, y: float, margin_m: float = 0.45) -> bool:
        """True when a person (radius ~0.25 m) fits at ``(x, y)``."""
        q = (x, y)
        for g in self.ground_footprints:
            if abs(x - g.center_xy[0]) > g.bounding_radius() + margin_m + 0.01:
                continue
            if g.distance_to_point(q) < margin_m:
                return False
        return True


class _Builder:
    """Shared state while building one world."""

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

    # ------------------------------------------------------------ placement of typical items

    def sink_z(self, xy: VecLike, radius_m: float) -> float:
        """Base height for an object of radius ``radius_m`` at ``xy``: lowest ground point, −5 cm."""
        x, y = float(xy[0]), float(xy[1])
        pts = [(x, y)] + [
            (x + radius_m * math.cos(a), y + radius_m * math.sin(a)) for a in np.linspace(0, 2 * math.pi, 8, False)
        ]
        zs = [self.ground(px, py) for px, py in pts]
        return min(zs) - (0.05 if max(zs) - min(zs) > 1e-6 else 0.0)

    def try_tree(
        self, lay: _Layout, xy: VecLike, conifer: bool, trunk_h: float, crown_r: float, gap_m: float = OBSTACLE_GAP_M
    ) -> bool:
        fr = shapes.tree_footprint_radius(crown_r, conifer)
        fp = Footprint((float(xy[0]), float(xy[1])), fr)
        if not lay.fits(fp, gap_m):
            return False
        trunk_r = float(np.clip(0.08 * crown_r + 0.06, 0.1, 0.35))
        gfp = Footprint(fp.center_xy, trunk_r)
        lay.add(fp, gfp)
        z = self.sink_z(xy, trunk_r) - 0.1
        body = shapes.create_tree(self.client, self.crng, (xy[0], xy[1], z), trunk_h + 0.1, crown_r, conifer)
        h = shapes.tree_height(trunk_h + 0.1, crown_r, conifer)
        self.add_static("tree", body, (2 * fr, 2 * fr, h), (xy[0], xy[1], z), 0.0, fp, gfp)
        return True

    def try_rock(self, lay: _Layout, xy: FloatArray) -> bool:
        rng = self.rng
        r0 = float(rng.uniform(0.35, 0.8))
        lobes = [(0.0, 0.0, 0.3 * r0, r0)]
        for _ in range(int(rng.integers(0, 3))):
            a = float(rng.uniform(0, 2 * math.pi))
            rk = r0 * float(rng.uniform(0.5, 0.8))
            lobes.append((0.6 * r0 * math.cos(a), 0.6 * r0 * math.sin(a), 0.2 * rk, rk))
        fr = max(math.hypot(x, y) + r for x, y, _, r in lobes)
        fp = Footprint((float(xy[0]), float(xy[1])), fr)
        if not lay.fits(fp):
            return False
        lay.add(fp)
        z = self.sink_z(xy, fr)
        body = shapes.create_rock(self.client, self.crng, (xy[0], xy[1], z), lobes)
        h = max(zc + r for _, _, zc, r in lobes)
        self.add_static("rock", body, (2 * fr, 2 * fr, h), (xy[0], xy[1], z), 0.0, fp)
        return True

    def try_crate(self, lay: _Layout, xy: FloatArray) -> bool:
        rng = self.rng
        size = (float(rng.uniform(0.6, 1.6)), float(rng.uniform(0.6, 1.4)), float(rng.uniform(0.5, 1.3)))
        yaw = float(rng.uniform(-math.pi, math.pi))
        fp = Footprint((float(xy[0]), float(xy[1])), half_xy=(size[0] / 2, size[1] / 2), yaw_rad=yaw)
        if not lay.fits(fp):
            return False
        lay.add(fp)
        z = self.sink_z(xy, fp.bounding_radius())
        body = shapes.create_crate(self.client, self.crng, (xy[0], xy[1], z), size, yaw)
        self.add_static("rock", body, size, (xy[0], xy[1], z), yaw, fp)
        return True

    def try_bush(self, lay: _Layout, xy: FloatArray) -> bool:
        rng = self.rng
        lobes = []
        for k in range(int(rng.integers(2, 5))):
            r = float(rng.uniform(0.35, 0.7))
            off = 0.0 if k == 0 else float(rng.uniform(0.2, 0.55))
            a = float(rng.uniform(0, 2 * math.pi))
            lobes.append((off * math.cos(a), off * math.sin(a), 0.55 * r, r))
        fr = max(math.hypot(x, y) + r for x, y, _, r in lobes)
        fp = Footprint((float(xy[0]), float(xy[1])), fr)
        if not lay.fits(fp):
            return False
        lay.add(fp)
        z = self.sink_z(xy, fr)
        body = shapes.create_bush(self.client, self.crng, (xy[0], xy[1], z), lobes)
        h = max(zc + r for _, _, zc, r in lobes)
        self.add_static("bush", body, (2 * fr, 2 * fr, h), (xy[0], xy[1], z), 0.0, fp)
        return True

    def try_box_object(
        self,
        lay: _Layout,
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
        lay: _Layout,
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

    def _pedestrian_start(self, region: WalkRegion, lay: _Layout, is_free: Callable[[float, float], bool],
                          k: int) -> FloatArray | None:
        """A free start in ``region`` at least :data:`PED_START_CLEARANCE_M` from the drone start."""
        rng = actor_rng(self.seed, 1000 + k)
        for _ in range(500):
            q = region.sample(rng, margin_m=0.5)
            if is_free(float(q[0]), float(q[1])) and np.linalg.norm(q - lay.start_xy[:2]) >= PED_START_CLEARANCE_M:
                return q
        logger.warning("no pedestrian start %.0f m from the drone start; sampling anywhere", PED_START_CLEARANCE_M)
        return None

    def add_vehicle_actor(self, loop: LaneLoop, index: int) -> None:
        veh = Vehicle(f"vehicle_actor_{index}", actor_rng(self.seed, 100 + index), loop, ground_height=self.ground)
        kind = "van" if self.rng.uniform() < 0.2 else "car"
        pos, yaw = veh.pose()
        body = shapes.create_car(self.client, self.crng, pos, yaw, kind)
        veh.attach(self.client, body)
        size = shapes.VAN_SIZE_M if kind == "van" else shapes.CAR_SIZE_M
        obj = WorldObject(self.next_id("vehicle"), "vehicle", body, True, size)
        obj.actor = veh
        self.objects.append(obj)


def _sample_start(
    rng: np.random.Generator,
    target_xy: FloatArray,
    accept: Callable[[FloatArray], bool],
    angle_range: tuple[float, float] = (-math.pi, math.pi),
) -> tuple[FloatArray, float]:
    """Start (x, y) 8–10 m from the target in a seeded direction, and altitude 2.5–4 m."""
    for _ in range(500):
        theta = float(rng.uniform(*angle_range))
        dist = float(rng.uniform(8.0, 10.0))
        xy = target_xy + dist * np.array([math.cos(theta), math.sin(theta)])
        if accept(xy):
            return xy, float(rng.uniform(2.5, 4.0))
    raise RuntimeError("no admissible drone start found")


def _default_count(rng: np.random.Generator, lo: int, hi: int, override: int | None) -> int:
    drawn = int(rng.integers(lo, hi + 1))  # always drawn: layout independent of the override
    if override is None:
        return drawn
    if override < 0:
        raise ValueError("n_pedestrians must be >= 0")
    return override


def _path_regions(
    n: int, start_xy: FloatArray, target_xy: FloatArray, radius_m: float
) -> list[tuple[WalkRegion, float]]:
    """``n`` walk regions around the start→target segment (with target attraction)."""
    region = WalkRegion((float(start_xy[0]), float(start_xy[1])), (float(target_xy[0]), float(target_xy[1])), radius_m)
    return [(region, PATH_TARGET_PROB) for _ in range(n)]


# --------------------------------------------------------------------------- worlds


def _build_open_field(b: _Builder, n_pedestrians: int | None) -> World:
    rng = b.rng
    target_xy = rng.uniform(-1.0, 1.0, 2)
    start_xy, alt = _sample_start(rng, target_xy, lambda q: True)
    b.surfaces.append(shapes.create_ground(b.client, b.crng))
    pad_r = float(rng.uniform(0.9, 1.2))
    marker = "H" if rng.uniform() < 0.7 else "cross"
    pad_body = shapes.create_landing_pad(b.client, b.crng, (target_xy[0], target_xy[1], 0.0), pad_r, marker)
    pad_fp = Footprint((float(target_xy[0]), float(target_xy[1])), pad_r)
    b.objects.append(
        WorldObject(
            b.next_id("pad"),
            "pad",
            pad_body,
            False,
            (2 * pad_r, 2 * pad_r, shapes.PAD_TOP_M),
            center_m=np.array([target_xy[0], target_xy[1], shapes.PAD_TOP_M / 2]),
            footprint=pad_fp,
        )
    )
    lay = _Layout(target_xy, start_xy)
    mid = 0.5 * (start_xy + target_xy)
    d = start_xy - target_xy
    u = d / np.linalg.norm(d)
    nrm = np.array([-u[1], u[0]])

    def candidate() -> FloatArray:
        if rng.uniform() < 0.5:  # near the flight path
            return target_xy + rng.uniform(0.1, 1.1) * d + rng.normal(0.0, 3.0) * nrm
        return mid + rng.uniform(-18.0, 18.0, 2)

    n_trees = int(rng.integers(1, 3))
    n_small = int(rng.integers(2, 5))
    for _ in range(n_trees):
        conifer = bool(rng.uniform() < 0.4)
        trunk_h = float(rng.uniform(1.8, 3.0)) if not conifer else float(rng.uniform(0.8, 1.4))
        crown_r = float(rng.uniform(1.2, 2.2))
        for _ in range(100):
            if b.try_tree(lay, candidate(), conifer, trunk_h, crown_r):
                break
    for _ in range(n_small):
        crate = bool(rng.uniform() < 0.4)
        for _ in range(100):
            xy = candidate()
            if (b.try_crate if crate else b.try_rock)(lay, xy):
                break
    n_ped = _default_count(rng, 1, 1, n_pedestrians)
    b.add_pedestrians(_path_regions(n_ped, start_xy, target_xy, 4.0), target_xy, lay)
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


def _build_urban(b: _Builder, n_pedestrians: int | None) -> World:
    rng = b.rng
    client = b.client
    target_xy = rng.uniform(-0.5, 0.5, 2)
    tx, ty = float(target_xy[0]), float(target_xy[1])
    street_y = ty + float(rng.uniform(9.5, 12.0))
    street_half_w, sidewalk_w = 3.5, 2.5
    curb_y = street_y - street_half_w - sidewalk_w  # south edge of the south sidewalk
    plaza_half_x = float(rng.uniform(13.0, 16.0))
    lot_half_y = 3.0  # parking row: cars oriented along y, spots 2.7 m wide along x
    spot_w = 2.7

    def start_ok(q: FloatArray) -> bool:
        return bool(q[1] <= street_y - street_half_w and abs(q[1] - ty) >= lot_half_y + 1.5)

    start_xy, alt = _sample_start(rng, target_xy, start_ok)
    b.surfaces.append(shapes.create_ground(client, b.crng))
    b.surfaces += shapes.create_street(
        client, b.crng, (-70.0, street_y), (70.0, street_y), 2 * street_half_w, sidewalk_w
    )
    # parking lot (asphalt) with the landing pad in one of its spots
    n_spots = 6
    lot_half_x = (n_spots + 0.5) * spot_w
    b.surfaces.append(
        shapes.create_flat_rects(
            client, b.crng, [(tx, ty, lot_half_x, lot_half_y, 0.0)], (0.26, 0.26, 0.28, 1.0), shapes.STREET_TOP_M
        )
    )
    lines = [(tx + (k + 0.5) * spot_w, ty, 0.05, 2.5, 0.0) for k in range(-n_spots - 1, n_spots + 1)]
    b.surfaces.append(shapes.create_flat_rects(client, b.crng, lines, (0.92, 0.92, 0.92, 1.0), shapes.MARKING_TOP_M))
    pad_r = float(rng.uniform(0.9, 1.15))
    marker = "H" if rng.uniform() < 0.7 else "cross"
    pad_body = shapes.create_landing_pad(client, b.crng, (tx, ty, shapes.STREET_TOP_M), pad_r, marker, math.pi / 2)
    pad_h = shapes.STREET_TOP_M + shapes.PAD_TOP_M
    b.objects.append(
        WorldObject(
            b.next_id("pad"),
            "pad",
            pad_body,
            False,
            (2 * pad_r, 2 * pad_r, pad_h),
            center_m=np.array([tx, ty, pad_h / 2]),
            footprint=Footprint((tx, ty), pad_r),
        )
    )
    lay = _Layout(target_xy, start_xy)

    # parked cars in the row (never in the pad's spot or its neighbours)
    spots = [k for k in range(-n_spots, n_spots + 1) if abs(k) >= 2]
    n_parked = int(rng.integers(2, 5))
    chosen = rng.choice(len(spots), size=n_parked, replace=False)
    for idx in sorted(int(i) for i in chosen):
        k = spots[idx]
        kind = "van" if rng.uniform() < 0.2 else "car"
        size = shapes.VAN_SIZE_M if kind == "van" else shapes.CAR_SIZE_M
        yaw = math.pi / 2 if rng.uniform() < 0.5 else -math.pi / 2
        xy = (tx + k * spot_w + float(rng.uniform(-0.1, 0.1)), ty + float(rng.uniform(-0.15, 0.15)))

        make_car = partial(shapes.create_car, client, b.crng, yaw_rad=yaw, kind=kind)
        fp_xy = (size[0] + 2 * shapes.VEHICLE_OVERHANG_M, size[1])
        b.try_box_object(lay, "vehicle", xy, fp_xy, size[2], yaw, make_car)

    def add_building_row(x0: float, x1: float, front_y: float, facing_north: bool) -> None:
        x = x0 + float(rng.uniform(0.0, 3.0))
        while True:
            width = float(rng.uniform(8.0, 16.0))
            if x + width > x1:
                break
            depth = float(rng.uniform(8.0, 14.0))
            height = float(rng.uniform(6.0, 22.0))
            cy = front_y + depth / 2 if not facing_north else front_y - depth / 2
            yaw = -math.pi / 2 if not facing_north else math.pi / 2
            make_building = partial(shapes.create_building, client, b.crng, size_m=(depth, width, height), yaw_rad=yaw)
            ov = 2 * shapes.BUILDING_OVERHANG_M
            fp_xy = (depth + ov, width + ov)
            b.try_box_object(lay, "building", (x + width / 2, cy), fp_xy, height + 0.2, yaw, make_building, 0.5)
            x += width + float(rng.uniform(1.0, 5.0))

    north_front = street_y + street_half_w + sidewalk_w + float(rng.uniform(0.5, 2.0))
    add_building_row(-65.0, 65.0, north_front, facing_north=False)
    south_front = curb_y - float(rng.uniform(0.5, 2.0))
    add_building_row(-65.0, tx - plaza_half_x, south_front, facing_north=True)
    add_building_row(tx + plaza_half_x, 65.0, south_front, facing_north=True)
    back_front = ty - float(rng.uniform(11.0, 14.0))
    add_building_row(tx - plaza_half_x, tx + plaza_half_x, back_front, facing_north=True)

    # plaza trees
    for _ in range(int(rng.integers(1, 4))):
        crown_r = float(rng.uniform(1.2, 2.0))
        trunk_h = float(rng.uniform(2.2, 3.2))
        for _ in range(100):
            txy = np.array(
                [tx + rng.uniform(-plaza_half_x + 2, plaza_half_x - 2), rng.uniform(back_front + 2, curb_y - 2)]
            )
            if abs(txy[1] - ty) < lot_half_y + crown_r:
                continue
            if b.try_tree(lay, txy, False, trunk_h, crown_r):
                break

    # driving cars: disjoint loops so they never drive through each other
    n_moving = int(rng.integers(1, 3))
    lane = street_half_w / 2
    spans = [(-55.0, 55.0)] if n_moving == 1 else [(-55.0, -3.0), (3.0, 55.0)]
    for j, (xa, xb) in enumerate(spans):
        b.add_vehicle_actor(LaneLoop((xa, street_y), (xb, street_y), lane), j)

    # pedestrians: one on the south sidewalk, the others around the flight path (not on the road)
    n_ped = _default_count(rng, 2, 3, n_pedestrians)
    sw_y = street_y - street_half_w - sidewalk_w / 2
    regions: list[tuple[WalkRegion, float]] = []
    if n_ped >= 1:
        regions.append((WalkRegion((tx - 25.0, sw_y), (tx + 25.0, sw_y), sidewalk_w / 2 - 0.3), 0.0))
    regions += _path_regions(max(n_ped - 1, 0), start_xy, target_xy, 3.5)

    def on_road(x: float, y: float) -> bool:
        return abs(y - street_y) < street_half_w

    b.add_pedestrians(regions, target_xy, lay, on_road)

    return World(
        b.name,
        b.seed,
        client,
        np.array([start_xy[0], start_xy[1], alt]),
        np.array([tx, ty, 0.0]),
        pad_r,
        b.objects,
        b.surfaces,
        meta={"street_y_m": street_y, "street_half_width_m": street_half_w, "sidewalk_width_m": sidewalk_w},
    )


def _build_forest_edge(b: _Builder, n_pedestrians: int | None) -> World:
    rng = b.rng
    client = b.client
    target_xy = rng.uniform(-1.0, 1.0, 2)
    phi = float(rng.uniform(-math.pi, math.pi))
    n_in = np.array([math.cos(phi), math.sin(phi)])  # towards the forest
    edge_d = float(rng.uniform(4.0, 7.0))
    clearing_r = float(rng.uniform(6.0, 8.0))
    meadow = phi + math.pi
    spread = math.radians(70.0)
    start_xy, alt = _sample_start(rng, target_xy, lambda q: True, (meadow - spread, meadow + spread))

    cell, n = 2.5, 41
    heights = _terrain_heights(rng, n, cell, target_xy, (6.0, 11.0))
    terrain = Terrain(heights, cell, FOREST_BASE_Z_M)
    b.ground = terrain.height
    b.surfaces.append(shapes.create_ground(client, b.crng, FOREST_BASE_Z_M))
    b.surfaces.append(shapes.create_heightfield(client, b.crng, heights, cell))
    tz = terrain.height(float(target_xy[0]), float(target_xy[1]))
    pad_r = float(rng.uniform(0.9, 1.2))
    marker = "H" if rng.uniform() < 0.7 else "cross"
    pad_body = shapes.create_landing_pad(client, b.crng, (target_xy[0], target_xy[1], tz), pad_r, marker)
    b.objects.append(
        WorldObject(
            b.next_id("pad"),
            "pad",
            pad_body,
            False,
            (2 * pad_r, 2 * pad_r, shapes.PAD_TOP_M),
            center_m=np.array([target_xy[0], target_xy[1], tz + shapes.PAD_TOP_M / 2]),
            footprint=Footprint((float(target_xy[0]), float(target_xy[1])), pad_r),
        )
    )
    lay = _Layout(target_xy, start_xy)

    # shed near the clearing, on the meadow side or along the edge
    for _ in range(100):
        ang = phi + float(rng.uniform(0.5, math.pi - 0.3)) * (1 if rng.uniform() < 0.5 else -1)
        dist = float(rng.uniform(7.0, 12.0))
        xy = target_xy + dist * np.array([math.cos(ang), math.sin(ang)])
        size = (float(rng.uniform(2.5, 4.0)), float(rng.uniform(2.0, 3.0)), float(rng.uniform(2.1, 2.5)))
        yaw = float(rng.uniform(-math.pi, math.pi))
        make_shed = partial(shapes.create_shed, client, b.crng, size_m=size, yaw_rad=yaw)
        if b.try_box_object(
            lay, "shed", xy, (size[0] + 0.5, size[1] + 0.6), shapes.shed_height(size), yaw, make_shed, 0.5
        ):
            break

    wobble_a = rng.uniform(0.5, 1.5, 2)
    wobble_k = rng.uniform(0.1, 0.3, 2)

    def forest_depth(q: FloatArray) -> float:
        """Signed distance (m) into the forest from an irregular edge line."""
        rel = q - target_xy
        along = float(rel @ np.array([-n_in[1], n_in[0]]))
        edge = edge_d + wobble_a[0] * math.sin(wobble_k[0] * along) + wobble_a[1] * math.sin(wobble_k[1] * along + 1.0)
        return float(rel @ n_in) - edge

    n_forest = int(rng.integers(32, 44))
    placed = 0
    for _ in range(n_forest * 15):
        if placed >= n_forest:
            break
        xy = target_xy + rng.uniform(-38.0, 38.0, 2)
        if forest_depth(xy) < 0.0 or np.linalg.norm(xy - target_xy) < clearing_r:
            continue
        conifer = bool(rng.uniform() < 0.5)
        trunk_h = float(rng.uniform(0.6, 1.4)) if conifer else float(rng.uniform(1.8, 3.2))
        crown_r = float(rng.uniform(1.1, 2.0)) if conifer else float(rng.uniform(1.3, 2.6))
        placed += b.try_tree(lay, xy, conifer, trunk_h, crown_r)
    for _ in range(int(rng.integers(2, 5))):  # lone meadow trees
        for _ in range(100):
            xy = target_xy + rng.uniform(-30.0, 30.0, 2)
            if forest_depth(xy) > -3.0 or np.linalg.norm(xy - target_xy) < clearing_r:
                continue
            if b.try_tree(
                lay, xy, bool(rng.uniform() < 0.2), float(rng.uniform(1.8, 3.0)), float(rng.uniform(1.3, 2.4))
            ):
                break
    for _ in range(int(rng.integers(6, 11))):  # bushes along the edge
        for _ in range(100):
            xy = target_xy + rng.uniform(-25.0, 25.0, 2)
            if not -3.5 < forest_depth(xy) < 1.5:
                continue
            if b.try_bush(lay, xy):
                break
    for _ in range(int(rng.integers(2, 5))):  # rocks in the meadow
        for _ in range(100):
            xy = target_xy + rng.uniform(-20.0, 20.0, 2)
            if forest_depth(xy) > -2.0:
                continue
            if b.try_rock(lay, xy):
                break

    n_ped = _default_count(rng, 1, 2, n_pedestrians)
    b.add_pedestrians(_path_regions(n_ped, start_xy, target_xy, 4.5), target_xy, lay)
    sz = terrain.height(float(start_xy[0]), float(start_xy[1]))
    return World(
        b.name,
        b.seed,
        client,
        np.array([start_xy[0], start_xy[1], sz + alt]),
        np.array([target_xy[0], target_xy[1], tz]),
        pad_r,
        b.objects,
        b.surfaces,
        terrain=terrain,
        meta={"forest_dir_rad": phi, "forest_edge_m": edge_d, "clearing_radius_m": clearing_r},
    )


_BUILDERS: dict[str, Callable[[_Builder, int | None], World]] = {
    "open_field": _build_open_field,
    "urban": _build_urban,
    "forest_edge": _build_forest_edge,
}


def build_world(
    client: int,
    name: str,
    seed: int,
    *,
    n_pedestrians: int | None = None,
    renderer: str = "auto",
) -> World:
    """Create world ``name`` (one of :data:`WORLD_NAMES`) from ``seed`` in pybullet ``client``.

    The world creates its own ground; call it on an empty client (e.g. right after
    ``p.connect`` or ``p.resetSimulation``).

    Args:
        client: pybullet physics client id.
        name: ``"open_field"``, ``"urban"`` or ``"forest_edge"``.
        seed: world seed (any int; the same seed gives the same world).
        n_pedestrians: override the world's default number of pedestrians
            (open_field 1, urban 2–3, forest_edge 1–2); the rest of the layout is unchanged.
        renderer: ``"auto"`` / ``"egl"`` first load pybullet's EGL renderer plugin into the
            client when available (it only sees bodies created after it is loaded, see
            :func:`llmland_sim.camera.prepare_renderer`); ``"tiny"`` skips that.
    """
    if name not in _BUILDERS:
        raise ValueError(f"unknown world {name!r}; expected one of {WORLD_NAMES}")
    if renderer != "tiny":
        from llmland_sim.camera import prepare_renderer

        prepare_renderer(client, renderer)
    world = _BUILDERS[name](_Builder(client, name, seed), n_pedestrians)
    logger.info("built world %s", world.summary())
    return world
