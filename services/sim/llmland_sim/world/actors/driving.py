"""Driving actors: a vehicle going round a closed loop along a straight street."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from llmland_schemas.arrays import FloatArray

from .base import GroundFn, KinematicActor, wrap_angle

VEH_SPEED_RANGE_MPS = (3.0, 8.0)


@dataclass(frozen=True)
class LaneLoop:
    """Closed driving loop along a straight street (right-hand traffic), metres.

    Forward leg from ``a_xy`` to ``b_xy`` on the lane ``lane_offset_m`` to the right of the
    centre line, a U-turn of radius ``lane_offset_m`` around ``b_xy``, the return leg on the
    other lane and a U-turn around ``a_xy``. Arc length ``s`` starts at the forward lane's
    beginning.
    """

    a_xy: tuple[float, float]
    b_xy: tuple[float, float]
    lane_offset_m: float

    @property
    def straight_m(self) -> float:
        """Length of one straight leg (m)."""
        return float(np.linalg.norm(np.subtract(self.b_xy, self.a_xy)))

    @property
    def perimeter_m(self) -> float:
        """Total loop length (m)."""
        return 2.0 * self.straight_m + 2.0 * math.pi * self.lane_offset_m

    def pose_at(self, s_m: float) -> tuple[float, float, float]:
        """``(x, y, yaw)`` at arc length ``s_m`` (wrapped onto the loop)."""
        a = np.asarray(self.a_xy, dtype=float)
        b = np.asarray(self.b_xy, dtype=float)
        length = self.straight_m
        u = (b - a) / length
        left = np.array([-u[1], u[0]])
        r = self.lane_offset_m
        yaw0 = math.atan2(u[1], u[0])
        s = s_m % self.perimeter_m
        turn = math.pi * r
        if s < length:
            q = a - r * left + s * u
            return float(q[0]), float(q[1]), yaw0
        s -= length
        if s < turn:
            ang = s / r  # turning left around b
            q = b + r * (math.sin(ang) * u - math.cos(ang) * left)
            return float(q[0]), float(q[1]), wrap_angle(yaw0 + ang)
        s -= turn
        if s < length:
            q = b + r * left - s * u
            return float(q[0]), float(q[1]), wrap_angle(yaw0 + math.pi)
        s -= length
        ang = s / r
        q = a + r * (-math.sin(ang) * u + math.cos(ang) * left)
        return float(q[0]), float(q[1]), wrap_angle(yaw0 + math.pi + ang)

    def distance_to_next_turn(self, s_m: float) -> float:
        """Arc length (m) from ``s_m`` to the start of the next U-turn (0 inside a turn)."""
        length, turn = self.straight_m, math.pi * self.lane_offset_m
        s = s_m % self.perimeter_m
        if s < length:
            return length - s
        if s < length + turn:
            return 0.0
        if s < 2 * length + turn:
            return 2 * length + turn - s
        return 0.0


class Vehicle(KinematicActor):
    """A car driving round a :class:`LaneLoop` at 3–8 m/s.

    The cruise speed is redrawn in [3, 8] m/s at random (≈ every 6 s); the car accelerates at
    ≤ 1.5 m/s² and brakes (≤ 2 m/s²) so that it takes the U-turns at 3 m/s.
    """

    ACCEL_MPS2 = 1.5
    BRAKE_MPS2 = 2.0
    TURN_SPEED_MPS = 3.0
    SPEED_CHANGE_RATE_HZ = 1.0 / 6.0

    def __init__(
        self,
        actor_id: str,
        rng: np.random.Generator,
        loop: LaneLoop,
        *,
        start_s_m: float | None = None,
        ground_height: GroundFn | None = None,
    ) -> None:
        super().__init__(actor_id, rng, ground_height)
        self.loop = loop
        self._s = float(rng.uniform(0.0, loop.perimeter_m)) if start_s_m is None else float(start_s_m)
        self._cruise = float(rng.uniform(*VEH_SPEED_RANGE_MPS))
        self._speed = self._allowed(self._cruise)
        self._seg_speed = self._speed
        x, y, yaw = loop.pose_at(self._s)
        self._start(x, y, yaw)

    @property
    def speed_mps(self) -> float:
        """Current speed along the loop (m/s)."""
        return self._speed

    def _allowed(self, cruise: float) -> float:
        d = self.loop.distance_to_next_turn(self._s)
        cap = math.sqrt(self.TURN_SPEED_MPS**2 + 2.0 * self.BRAKE_MPS2 * d)
        return float(np.clip(min(cruise, cap), *VEH_SPEED_RANGE_MPS))

    def _advance(self, h_s: float) -> tuple[float, float, float]:
        if self.rng.uniform() < self.SPEED_CHANGE_RATE_HZ * h_s:
            self._cruise = float(self.rng.uniform(*VEH_SPEED_RANGE_MPS))
        target = self._allowed(self._cruise)
        dv = float(np.clip(target - self._speed, -self.BRAKE_MPS2 * h_s, self.ACCEL_MPS2 * h_s))
        self._speed = float(np.clip(self._speed + dv, *VEH_SPEED_RANGE_MPS))
        self._s = (self._s + self._speed * h_s) % self.loop.perimeter_m
        self._seg_speed = self._speed
        return self.loop.pose_at(self._s)

    def velocity(self) -> FloatArray:
        """World-frame velocity (3,) in m/s: current speed along the current heading."""
        _, yaw = self.pose()
        vz = super().velocity()[2]
        return np.array([self._seg_speed * math.cos(yaw), self._seg_speed * math.sin(yaw), vz])
