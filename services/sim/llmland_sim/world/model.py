"""The world model: objects (obstacles, actors, the pad) and the built :class:`World`."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from llmland_schemas.arrays import FloatArray

from .actors import KinematicActor
from .geometry import Footprint
from .terrain import Terrain

#: Every object class a world holds (the ground-truth labels).
OBJECT_CLASSES = ("person", "vehicle", "building", "tree", "bush", "shed", "rock", "pad")


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
