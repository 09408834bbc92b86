"""Deterministic kinematic actors: walking pedestrians and vehicles driving a street loop.

Motion depends only on the actor's seed and on simulated time. Each actor integrates its
own behaviour on a fixed internal grid of :data:`INTERNAL_DT_S` seconds (all random draws
happen there, from the actor's private ``numpy.random.Generator``) and reports poses by
linear interpolation between the two grid states around the current time. Hence the
trajectory does not depend on how ``step(dt_s)`` is called (240 Hz physics or 20 Hz camera
give the same path up to float rounding), nor on physics or wall clock.

Poses are in the world frame (ENU, metres, ``docs/conventions.md``): ``position`` is the
ground contact point under the actor's centre (feet / wheels), ``yaw`` the heading of its
local ``+x`` (facing / driving direction) in radians from world ``+x``.

When an actor has a pybullet body attached (mass 0), every ``step`` moves it with
``resetBasePositionAndOrientation``.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Callable

import numpy as np
import pybullet as p
from llmland_schemas.arrays import FloatArray

from ..shapes.primitives import quat_yaw

#: A point / vector given as a sequence or a numpy array.
#: Ground height ``z = f(x, y)`` in metres.
GroundFn = Callable[[float, float], float]
#: ``True`` when a person may stand at ``(x, y)`` (no static obstacle there).
FreeFn = Callable[[float, float], bool]

#: Internal integration step of every actor (s).
INTERNAL_DT_S = 0.05


def actor_rng(seed: int, index: int) -> np.random.Generator:
    """The private generator of actor ``index`` in the world of ``seed``."""
    return np.random.default_rng([seed % 2**63, 1, index])


def wrap_angle(a: float) -> float:
    """Wrap an angle to ``[-pi, pi)`` (rad)."""
    return (a + math.pi) % (2.0 * math.pi) - math.pi


def flat_ground(x: float, y: float) -> float:
    return 0.0


class KinematicActor(ABC):
    """Base class: fixed-grid integration, interpolation, pose/velocity and body syncing.

    Subclasses implement :meth:`_advance`, which moves the internal state by exactly
    :data:`INTERNAL_DT_S` and returns the new ``(x, y, yaw)``.
    """

    def __init__(self, actor_id: str, rng: np.random.Generator, ground_height: GroundFn | None) -> None:
        self.actor_id = actor_id
        self.rng = rng
        self._ground: GroundFn = ground_height or flat_ground
        self._t_s = 0.0
        self._k = 0  # index of the grid state at or before _t_s
        self._prev = np.zeros(3)  # (x, y, yaw) at k * h
        self._next = np.zeros(3)  # (x, y, yaw) at (k + 1) * h
        self.client: int | None = None
        self.body_id: int | None = None

    def _start(self, x: float, y: float, yaw: float) -> None:
        """Set the initial state and compute the first grid step (call at the end of __init__)."""
        self._prev = np.array([x, y, wrap_angle(yaw)])
        self._next = np.asarray(self._advance(INTERNAL_DT_S), dtype=float)

    @abstractmethod
    def _advance(self, h_s: float) -> tuple[float, float, float]:
        """Advance the behaviour by ``h_s`` seconds; return the new ``(x, y, yaw)``."""

    @property
    def time_s(self) -> float:
        """Simulated time this actor has been stepped to (s)."""
        return self._t_s

    def step(self, dt_s: float) -> None:
        """Advance simulated time by ``dt_s`` ≥ 0 seconds and move the attached body."""
        if dt_s < 0.0:
            raise ValueError("dt_s must be non-negative")
        self._t_s += dt_s
        h = INTERNAL_DT_S
        while self._t_s >= (self._k + 1) * h - 1e-9:
            self._k += 1
            self._prev = self._next
            self._next = np.asarray(self._advance(h), dtype=float)
        self.sync_body()

    def _alpha(self) -> float:
        """Interpolation weight in ``[0, 1]`` of the current time between the two grid states."""
        return min(1.0, max(0.0, (self._t_s - self._k * INTERNAL_DT_S) / INTERNAL_DT_S))

    def _pose_xyz_yaw(self) -> tuple[float, float, float, float]:
        """``(x, y, z, yaw)`` of :meth:`pose` as Python floats (scalar maths: this runs for every
        actor at every physics substep, where numpy's per-call overhead dominated the sim)."""
        a = self._alpha()
        x0, y0, yaw0 = self._prev.tolist()
        x1, y1, yaw1 = self._next.tolist()
        x = (1.0 - a) * x0 + a * x1
        y = (1.0 - a) * y0 + a * y1
        yaw = wrap_angle(yaw0 + a * wrap_angle(yaw1 - yaw0))
        return x, y, self._ground(x, y), yaw

    def pose(self) -> tuple[FloatArray, float]:
        """``(position_m (3,), yaw_rad)``: ground point under the actor and heading."""
        x, y, z, yaw = self._pose_xyz_yaw()
        return np.array([x, y, z]), yaw

    def quat_xyzw(self) -> tuple[float, float, float, float]:
        """Orientation quaternion ``(x, y, z, w)``: rotation by ``yaw`` about world z."""
        return quat_yaw(self._pose_xyz_yaw()[3])

    def velocity(self) -> FloatArray:
        """World-frame velocity (3,) in m/s over the current internal interval."""
        v = (self._next[:2] - self._prev[:2]) / INTERNAL_DT_S
        z0 = self._ground(float(self._prev[0]), float(self._prev[1]))
        z1 = self._ground(float(self._next[0]), float(self._next[1]))
        return np.array([v[0], v[1], (z1 - z0) / INTERNAL_DT_S])

    def attach(self, client: int, body_id: int) -> None:
        """Attach a mass-0 pybullet body that follows this actor; moves it to the current pose."""
        self.client = client
        self.body_id = body_id
        self.sync_body()

    def sync_body(self) -> None:
        """Move the attached body (if any) to the current pose."""
        if self.body_id is None or self.client is None:
            return
        x, y, z, yaw = self._pose_xyz_yaw()
        p.resetBasePositionAndOrientation(self.body_id, (x, y, z), quat_yaw(yaw), physicsClientId=self.client)
