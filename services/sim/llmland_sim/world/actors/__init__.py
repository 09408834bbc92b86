"""Deterministic kinematic actors: walking pedestrians (:mod:`.walking`) and vehicles driving a
street loop (:mod:`.driving`), on the fixed-step base of :mod:`.base`."""

from .base import INTERNAL_DT_S, FreeFn, GroundFn, KinematicActor, actor_rng, wrap_angle
from .driving import VEH_SPEED_RANGE_MPS, LaneLoop, Vehicle
from .walking import PED_SPEED_RANGE_MPS, Pedestrian, PedMode, WalkRegion

__all__ = [
    "INTERNAL_DT_S",
    "PED_SPEED_RANGE_MPS",
    "VEH_SPEED_RANGE_MPS",
    "FreeFn",
    "GroundFn",
    "KinematicActor",
    "LaneLoop",
    "PedMode",
    "Pedestrian",
    "Vehicle",
    "WalkRegion",
    "actor_rng",
    "wrap_angle",
]
