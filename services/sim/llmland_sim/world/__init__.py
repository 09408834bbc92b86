"""Seeded simulation worlds: body builders (:mod:`.shapes`), kinematic actors (:mod:`.actors`),
the world model (:mod:`.model`), placement (:mod:`.layout`, :mod:`.builder`), one recipe per
world (:mod:`.recipes`) and :func:`build_world` (:mod:`.worlds`)."""

from llmland_schemas import WORLD_NAMES

from llmland_sim.world.actors import KinematicActor, LaneLoop, Pedestrian, PedMode, Vehicle, WalkRegion
from llmland_sim.world.geometry import Footprint, footprint_distance
from llmland_sim.world.layout import START_CLEARANCE_M, TARGET_CLEARANCE_M
from llmland_sim.world.model import OBJECT_CLASSES, World, WorldObject
from llmland_sim.world.terrain import Terrain
from llmland_sim.world.worlds import build_world

__all__ = [
    "OBJECT_CLASSES",
    "START_CLEARANCE_M",
    "TARGET_CLEARANCE_M",
    "WORLD_NAMES",
    "Footprint",
    "KinematicActor",
    "LaneLoop",
    "PedMode",
    "Pedestrian",
    "Terrain",
    "Vehicle",
    "WalkRegion",
    "World",
    "WorldObject",
    "build_world",
    "footprint_distance",
]
