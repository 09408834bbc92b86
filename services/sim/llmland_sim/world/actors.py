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

import logging
import math
from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from enum import Enum

import numpy as np
import pybullet as p
from numpy.typing import NDArray

logger = logging.getLogger(__name__)

FloatArray = NDArray[np.float64]
#: A point / vector given as a sequence or a numpy array.
VecLike = Sequence[float] | NDArray[np.float64]
#: Ground height ``z = f(x, y)`` in metres.
GroundFn = Callable[[float, float], float]
#: ``True`` when a person may stand at ``(x, y)`` (no static obstacle there).
FreeFn = Callable[[float, float], bool]

#: Internal integration step of every actor (s).
INTERNAL_DT_S = 0.05

PED_SPEED_RANGE_MPS = (0.5, 1.5)
VEH_SPEED_RANGE_MPS = (3.0, 8.0)


def actor_rng(seed: int, index: int) -> np.random.Generator:
    """The private generator of actor ``index`` in the world of ``seed``."""
    return np.random.default_rng([seed % 2**63, 1, index])


def wrap_angle(a: float) -> float:
    """Wrap an angle to ``[-pi, pi)`` (rad)."""
    return (a + math.pi) % (2.0 * math.pi) - math.pi


def _flat_ground(x: float, y: float) -> float:
    return 0.0


@dataclass(frozen=True)
class WalkRegion:
    """A capsule on the ground: points within ``radius_m`` of the segment ``a_xy``–``b_xy`` (m).

    Convex, so a straight walk between two inside points never leaves it.
    """

    a_xy: tuple[float, float]
    b_xy: tuple[float, float]
    radius_m: float

    def distance_to_axis(self, xy: VecLike) -> float:
        """Distance (m) from ``xy`` to the capsule's axis segment."""
        a = np.asarray(self.a_xy, dtype=float)
        d = np.asarray(self.b_xy, dtype=float) - a
        q = np.asarray(xy, dtype=float)[:2] - a
        dd = float(d @ d)
        t = 0.0 if dd <= 0.0 else float(np.clip((q @ d) / dd, 0.0, 1.0))
        return float(np.linalg.norm(q - t * d))

    def contains(self, xy: VecLike, margin_m: float = 0.0) -> bool:
        """True when ``xy`` lies inside the capsule shrunk by ``margin_m``."""
        return self.distance_to_axis(xy) <= self.radius_m - margin_m

    def sample(self, rng: np.random.Generator, margin_m: float = 0.0) -> FloatArray:
        """Uniform random point (2,) of the capsule shrunk by ``margin_m`` (rejection sampling)."""
        r = max(self.radius_m - margin_m, 0.0)
        lo = np.minimum(self.a_xy, self.b_xy) - r
        hi = np.maximum(self.a_xy, self.b_xy) + r
        for _ in range(1000):
            q = rng.uniform(lo, hi)
            if self.distance_to_axis(q) <= r:
                return np.asarray(q, dtype=float)
        return 0.5 * (np.asarray(self.a_xy, dtype=float) + np.asarray(self.b_xy, dtype=float))

    def project(self, xy: VecLike, margin_m: float = 0.0) -> FloatArray:
        """Closest point (2,) of the capsule shrunk by ``margin_m`` to ``xy``."""
        a = np.asarray(self.a_xy, dtype=float)
        d = np.asarray(self.b_xy, dtype=float) - a
        q = np.asarray(xy, dtype=float)[:2]
        dd = float(d @ d)
        t = 0.0 if dd <= 0.0 else float(np.clip(((q - a) @ d) / dd, 0.0, 1.0))
        c = a + t * d
        off = q - c
        dist = float(np.linalg.norm(off))
        r = max(self.radius_m - margin_m, 0.0)
        if dist <= r:
            return q.copy()
        return c + off * (r / dist)


class KinematicActor(ABC):
    """Base class: fixed-grid integration, interpolation, pose/velocity and body syncing.

    Subclasses implement :meth:`_advance`, which moves the internal state by exactly
    :data:`INTERNAL_DT_S` and returns the new ``(x, y, yaw)``.
    """

    def __init__(self, actor_id: str, rng: np.random.Generator, ground_height: GroundFn | None) -> None:
        self.actor_id = actor_id
        self.rng = rng
        self._ground: GroundFn = ground_height or _flat_ground
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
        return float(np.clip((self._t_s - self._k * INTERNAL_DT_S) / INTERNAL_DT_S, 0.0, 1.0))

    def pose(self) -> tuple[FloatArray, float]:
        """``(position_m (3,), yaw_rad)``: ground point under the actor and heading."""
        a = self._alpha()
        xy = (1.0 - a) * self._prev[:2] + a * self._next[:2]
        yaw = wrap_angle(float(self._prev[2]) + a * wrap_angle(float(self._next[2] - self._prev[2])))
        z = self._ground(float(xy[0]), float(xy[1]))
        return np.array([xy[0], xy[1], z]), yaw

    def quat_xyzw(self) -> tuple[float, float, float, float]:
        """Orientation quaternion ``(x, y, z, w)``: rotation by ``yaw`` about world z."""
        _, yaw = self.pose()
        return (0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0))

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
        pos, _ = self.pose()
        p.resetBasePositionAndOrientation(self.body_id, pos.tolist(), self.quat_xyzw(), physicsClientId=self.client)


class PedMode(Enum):
    """Behaviour mode of a :class:`Pedestrian` over one internal interval."""

    WALK = "walk"
    TURN = "turn"  # rotating in place towards the next goal
    PAUSE = "pause"


class Pedestrian(KinematicActor):
    """A person wandering between random goals inside a :class:`WalkRegion`.

    Behaviour (all randomness from ``rng``):

    * goals are uniform in the region (0.8 m away from its border) or, with probability
      ``target_prob``, scattered around ``target_xy`` (e.g. the landing pad); a goal is only
      taken when the straight walk to it stays on free ground (``is_free``);
    * walking speed is drawn in [0.6, 1.4] m/s per leg and changes now and then (always
      within 0.5–1.5 m/s while walking, ramping at ≤ 0.8 m/s²);
    * heading turns smoothly (≤ 1.2 rad/s while walking); for turns larger than 120° the
      person first turns in place (≤ 1.8 rad/s) — speed 0;
    * pauses at goals (35 %, 1–5 s) and occasionally mid-walk; changes goal at random
      (≈ every 15 s on average) — unpredictable for a tracker;
    * never leaves the region nor steps onto blocked ground: a step that would do so is not
      taken, the person stops and picks a new goal instead.
    """

    WALK_TURN_RATE_RPS = 1.2
    INPLACE_TURN_RATE_RPS = 1.8
    TURN_IN_PLACE_RAD = 2.0 * math.pi / 3.0
    ACCEL_MPS2 = 0.8
    GOAL_REACHED_M = 0.4
    GOAL_MARGIN_M = 0.8
    GOAL_CHANGE_RATE_HZ = 1.0 / 15.0
    MID_PAUSE_RATE_HZ = 1.0 / 40.0
    SPEED_CHANGE_RATE_HZ = 1.0 / 8.0

    def __init__(
        self,
        actor_id: str,
        rng: np.random.Generator,
        region: WalkRegion,
        *,
        start_xy: VecLike | None = None,
        target_xy: VecLike | None = None,
        target_prob: float = 0.25,
        is_free: FreeFn | None = None,
        ground_height: GroundFn | None = None,
    ) -> None:
        super().__init__(actor_id, rng, ground_height)
        self.region = region
        self.target_xy = None if target_xy is None else np.asarray(target_xy, dtype=float)[:2]
        self.target_prob = target_prob
        self._is_free: FreeFn = is_free or (lambda x, y: True)
        if start_xy is None:
            start = self._sample_free_point(margin_m=0.5)
        else:
            start = np.asarray(start_xy, dtype=float)[:2]
        self._pos = start.copy()
        self._heading = float(rng.uniform(-math.pi, math.pi))
        self._speed = 0.0
        self._speed_pref = self._draw_speed()
        self._goal = self._pos.copy()
        self._mode = PedMode.PAUSE
        self._timer_s = float(rng.uniform(0.0, 1.5))
        self._seg_mode = PedMode.PAUSE
        self._start(float(start[0]), float(start[1]), self._heading)

    # ---------------------------------------------------------------- public state

    @property
    def mode(self) -> PedMode:
        """Mode used over the current internal interval (what ``velocity()`` reflects)."""
        return self._seg_mode

    @property
    def walking(self) -> bool:
        """True while walking (speed within 0.5–1.5 m/s)."""
        return self._seg_mode is PedMode.WALK

    @property
    def goal_xy(self) -> FloatArray:
        """Current goal (2,) in metres."""
        return self._goal.copy()

    # ---------------------------------------------------------------- behaviour

    def _draw_speed(self) -> float:
        return float(self.rng.uniform(0.6, 1.4))

    def _sample_free_point(self, margin_m: float) -> FloatArray:
        q = self.region.sample(self.rng, margin_m)
        for _ in range(200):
            if self._is_free(float(q[0]), float(q[1])):
                return q
            q = self.region.sample(self.rng, margin_m)
        logger.warning("%s: no free start point found in its region", self.actor_id)
        return q

    def _path_free(self, a: FloatArray, b: FloatArray) -> bool:
        n = max(2, int(math.ceil(float(np.linalg.norm(b - a)) / 0.25)) + 1)
        for s in np.linspace(0.0, 1.0, n):
            q = a + s * (b - a)
            if not self._is_free(float(q[0]), float(q[1])):
                return False
        return True

    def _choose_goal(self) -> bool:
        """Pick a new reachable goal; returns False (and keeps the old one) if none is found."""
        for _ in range(40):
            if self.target_xy is not None and self.rng.uniform() < self.target_prob:
                cand = self.target_xy + self.rng.normal(0.0, 1.2, 2)
                cand = self.region.project(cand, self.GOAL_MARGIN_M)
            else:
                cand = self.region.sample(self.rng, self.GOAL_MARGIN_M)
            if np.linalg.norm(cand - self._pos) < 1.5:
                continue
            if self._path_free(self._pos, cand):
                self._goal = cand
                self._speed_pref = self._draw_speed()
                return True
        return False

    def _begin_leg(self) -> None:
        """After a pause / block: choose a goal and start turning or walking."""
        if not self._choose_goal():
            self._mode = PedMode.PAUSE
            self._timer_s = float(self.rng.uniform(0.5, 2.0))
            return
        err = self._heading_error()
        self._mode = PedMode.TURN if abs(err) > self.TURN_IN_PLACE_RAD else PedMode.WALK
        if self._mode is PedMode.WALK:
            self._speed = max(self._speed, PED_SPEED_RANGE_MPS[0])

    def _heading_error(self) -> float:
        d = self._goal - self._pos
        return wrap_angle(math.atan2(float(d[1]), float(d[0])) - self._heading)

    def _turn_towards(self, rate_rps: float, h_s: float) -> float:
        err = self._heading_error()
        step = float(np.clip(err, -rate_rps * h_s, rate_rps * h_s))
        self._heading = wrap_angle(self._heading + step)
        return err - step

    def _advance(self, h_s: float) -> tuple[float, float, float]:
        mode = self._mode
        moved = False
        if mode is PedMode.PAUSE:
            self._timer_s -= h_s
            self._speed = 0.0
            if self._timer_s <= 0.0:
                self._begin_leg()
        elif mode is PedMode.TURN:
            self._speed = 0.0
            rest = self._turn_towards(self.INPLACE_TURN_RATE_RPS, h_s)
            if abs(rest) < 0.3:
                self._mode = PedMode.WALK
                self._speed = PED_SPEED_RANGE_MPS[0]
        else:
            moved = self._walk(h_s)
        if moved:
            self._seg_mode = PedMode.WALK
        else:
            self._seg_mode = PedMode.TURN if mode is PedMode.TURN else PedMode.PAUSE
            self._speed = 0.0 if self._mode is not PedMode.WALK else self._speed
        return float(self._pos[0]), float(self._pos[1]), self._heading

    def _walk(self, h_s: float) -> bool:
        """One walking step; returns True when the person moved."""
        rng = self.rng
        # random events (unpredictable behaviour)
        if rng.uniform() < self.GOAL_CHANGE_RATE_HZ * h_s:
            if self._choose_goal() and abs(self._heading_error()) > self.TURN_IN_PLACE_RAD:
                self._mode = PedMode.TURN
                return False
        if rng.uniform() < self.MID_PAUSE_RATE_HZ * h_s:
            self._mode = PedMode.PAUSE
            self._timer_s = float(rng.uniform(0.5, 3.0))
            return False
        if rng.uniform() < self.SPEED_CHANGE_RATE_HZ * h_s:
            self._speed_pref = self._draw_speed()
        err = self._turn_towards(self.WALK_TURN_RATE_RPS, h_s)
        if abs(err) > self.TURN_IN_PLACE_RAD:  # e.g. circling around a close goal: stop and turn
            self._mode = PedMode.TURN
            return False
        dv = float(np.clip(self._speed_pref - self._speed, -self.ACCEL_MPS2 * h_s, self.ACCEL_MPS2 * h_s))
        self._speed = float(np.clip(self._speed + dv, *PED_SPEED_RANGE_MPS))
        step = self._speed * h_s * np.array([math.cos(self._heading), math.sin(self._heading)])
        nxt = self._pos + step
        if not self.region.contains(nxt) or not self._is_free(float(nxt[0]), float(nxt[1])):
            self._mode = PedMode.PAUSE
            self._timer_s = float(rng.uniform(0.3, 1.5))
            return False
        self._pos = nxt
        if np.linalg.norm(self._goal - self._pos) < self.GOAL_REACHED_M:
            if rng.uniform() < 0.35:
                self._mode = PedMode.PAUSE
                self._timer_s = float(rng.uniform(1.0, 5.0))
            else:
                self._begin_leg()
        return True


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
