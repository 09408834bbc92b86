"""Scripted test scenarios layered on a seeded world (``MissionGoal.scenario``).

``walk-in:<distance_m>,<speed_mps>`` — the world's first pedestrian is replaced by a person who
stands ``distance_m`` from the landing target (on a side drawn from the seed) and, as soon as
the vehicle starts its final descent (sinking faster than :data:`TRIGGER_SINK_MPS` lower than
:data:`TRIGGER_HEIGHT_M` above the target: the planner flies higher outside the final descent),
walks straight to the target: first a step
to :data:`STEP_SPEED_MPS`, then accelerating at :data:`ACCEL_MPS2` up to ``speed_mps``. Within
the planner's stated bounds (≤ 1.6 m/s) it tests the hard-limit guarantee; above them (a runner),
what happens when an assumption fails.
"""

from __future__ import annotations

import math
import re

import numpy as np
from llmland_schemas.messages import SCENARIO_PATTERN

from .actors import KinematicActor, wrap_angle
from .worlds import World

#: the descent has started once the vehicle sinks faster than this (m/s) ...
TRIGGER_SINK_MPS = 0.5
#: ... lower than this (m) above the target
TRIGGER_HEIGHT_M = 3.3
#: a standing person's first step (m/s) and their acceleration after it (m/s²)
STEP_SPEED_MPS = 0.5
ACCEL_MPS2 = 2.0
#: the walker stops this close (m) to the target
STOP_AT_M = 0.3


class WalkInPerson(KinematicActor):
    """Stands still until :meth:`trigger`, then walks straight to ``target_xy``."""

    def __init__(self, actor_id: str, start_xy: np.ndarray, target_xy: np.ndarray, speed_mps: float) -> None:
        super().__init__(actor_id, np.random.default_rng(0), None)
        self.target_xy = np.asarray(target_xy, dtype=float)[:2]
        self.max_speed_mps = speed_mps
        self.speed_mps = 0.0
        self.triggered = False
        d = self.target_xy - start_xy
        self._xy = np.asarray(start_xy, dtype=float)[:2].copy()
        self._yaw = math.atan2(float(d[1]), float(d[0]))
        self._start(float(self._xy[0]), float(self._xy[1]), self._yaw)

    def trigger(self) -> None:
        self.triggered = True

    def _advance(self, h_s: float) -> tuple[float, float, float]:
        d = self.target_xy - self._xy
        dist = float(np.linalg.norm(d))
        if self.triggered and dist > STOP_AT_M:
            self.speed_mps = min(self.max_speed_mps, max(self.speed_mps + ACCEL_MPS2 * h_s, STEP_SPEED_MPS))
            self._yaw = math.atan2(float(d[1]), float(d[0]))
            self._xy = self._xy + min(self.speed_mps * h_s, dist - STOP_AT_M) * d / dist
        else:
            self.speed_mps = 0.0
        return float(self._xy[0]), float(self._xy[1]), wrap_angle(self._yaw)


class Scenario:
    """A scripted scenario bound to one world; :meth:`on_tick` watches the vehicle."""

    def __init__(self, spec: str, world: World, seed: int) -> None:
        if not re.match(SCENARIO_PATTERN, spec):
            raise ValueError(f"unknown scenario {spec!r}; known: walk-in:<distance_m>,<speed_mps>")
        distance, speed = (float(v) for v in spec.split(":", 1)[1].split(","))
        people = world.people()
        if not people:
            raise ValueError("the walk-in scenario needs a world with at least one pedestrian")
        obj = people[0]
        bearing = float(np.random.default_rng([seed, 0x5CE]).uniform(-math.pi, math.pi))
        target = np.asarray(world.target_m, dtype=float)[:2]
        start = target + distance * np.array([math.cos(bearing), math.sin(bearing)])
        walker = WalkInPerson(obj.obj_id, start, target, speed)
        old = obj.actor
        world.actors = [walker if a is old else a for a in world.actors]
        obj.actor = walker
        if old is not None and old.client is not None and old.body_id is not None:
            walker.attach(old.client, old.body_id)
        self.walker = walker
        self.ground_m = float(world.target_m[2])

    def on_tick(self, pos_m: np.ndarray, vel_mps: np.ndarray) -> None:
        if not self.walker.triggered and -float(vel_mps[2]) > TRIGGER_SINK_MPS \
                and float(pos_m[2]) - self.ground_m < TRIGGER_HEIGHT_M:
            self.walker.trigger()
