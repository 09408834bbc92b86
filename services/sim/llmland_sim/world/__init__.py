"""Seeded simulation worlds: body builders (:mod:`.shapes`), kinematic actors (:mod:`.actors`)
and the world layouts (:mod:`.worlds`)."""

from llmland_sim.world.actors import KinematicActor, LaneLoop, Pedestrian, PedMode, Vehicle, WalkRegion
from llmland_sim.world.worlds import (
    OBJECT_CLASSES,
    START_CLEARANCE_M,
    TARGET_CLEARANCE_M,
    WORLD_NAMES,
    Footprint,
    Terrain,
    World,
    WorldObject,
    build_world,
    footprint_distance,
)

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
