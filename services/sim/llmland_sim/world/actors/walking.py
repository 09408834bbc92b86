"""Walking actors: a pedestrian wandering between random goals inside a capsule-shaped region."""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from enum import Enum

import numpy as np
from llmland_schemas.arrays import FloatArray, VecLike

from .base import FreeFn, GroundFn, KinematicActor, wrap_angle

logger = logging.getLogger(__name__)

PED_SPEED_RANGE_MPS = (0.5, 1.5)


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
