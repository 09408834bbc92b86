"""Landing logic: approach above the unsafe regions, descend only onto a disc that stays clear.

Phases:

- ``approach`` — fly (searched path, corridors, MPC) to the hover point above the target
  at ``cruise_altitude_m``, raised above the ``z_min`` of any region covering it;
- ``hold`` — hover there and turn on the spot (``scan_yaw_rate_rps``) so the forward-down
  camera looks all around; descend only once the scan has swept ``scan_sweep_rad`` since
  the hold began and the landing disc has been *reach-clear* for ``hold_clear_s``;
- ``descend`` — down along :func:`descent_profile` (fast high up, slow near the ground)
  while the disc stays reach-clear; otherwise back up to the hover point (``hold``). Below
  ``commit_height_m`` the descent is finished: touching down takes less time than climbing
  out of a person's reach would;
- ``touchdown`` — low and slow: thrust off.

*Reach-clear*: the disc is clear of every unsafe region, with each dynamic region grown by
``reach_speed_mps`` × the time the descent still needs. A person out of view (the camera
barely sees the horizon once the drone is low) can walk that far before the drone is down,
so a descent only starts when nobody known can reach the disc before touchdown.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum

import numpy as np

from .dynamics import FloatArray
from .regions import UnsafeRegion
from .settings import PlannerSettings


class Phase(StrEnum):
    APPROACH = "approach"
    HOLD = "hold"
    DESCEND = "descend"
    TOUCHDOWN = "touchdown"


def disc_clear(target_xy: FloatArray, radius_m: float, regions: list[UnsafeRegion],
               dynamic_reach_m: float = 0.0) -> bool:
    """True when no region's footprint (box in x, y) meets the disc around ``target_xy``.

    Dynamic regions count as grown by ``dynamic_reach_m`` (how far they may move meanwhile).
    """
    c = np.asarray(target_xy, dtype=float)[:2]
    for r in regions:
        nearest = np.clip(c, r.lo[:2], r.hi[:2])
        reach = dynamic_reach_m if r.is_dynamic else 0.0
        if float(np.linalg.norm(nearest - c)) < radius_m + reach:
            return False
    return True


def descent_speed(height_m: float, settings: PlannerSettings) -> float:
    """Commanded sink rate (m/s) at ``height_m`` above the touchdown point.

    ``√(2·a·h)`` (a constant-deceleration approach to the ground), within
    [``descent_min_speed_mps``, ``descent_speed_mps``].
    """
    s = settings
    v = math.sqrt(2.0 * s.descent_brake_mps2 * max(height_m, 0.0))
    return min(max(v, s.descent_min_speed_mps), s.descent_speed_mps)


def descent_profile(z0_m: float, ground_m: float, dt_s: float, count: int,
                    settings: PlannerSettings) -> tuple[FloatArray, FloatArray]:
    """Heights ``(count,)`` and vertical speeds ``(count,)`` of the descent from ``z0_m``.

    Ends 3 cm above ``ground_m`` at rest (the touchdown detector fires before that).
    """
    floor = ground_m + 0.03
    z = np.empty(count)
    vz = np.empty(count)
    h = z0_m
    for k in range(count):
        v = descent_speed(h - ground_m, settings) if h > floor else 0.0
        z[k], vz[k] = h, -v
        h = max(floor, h - v * dt_s)
    return z, vz


def time_to_touchdown(height_m: float, settings: PlannerSettings) -> float:
    """Seconds :func:`descent_speed` needs from ``height_m`` down to the touchdown height.

    Closed form (it runs every control tick): ``1/v(h)`` integrated over the three pieces
    of the profile — constant ``v_min`` low down, ``√(2·a·h)`` between, constant ``v_max``
    high up.
    """
    s = settings
    a, v_lo, v_hi = s.descent_brake_mps2, s.descent_min_speed_mps, s.descent_speed_mps
    h_lo, h_hi = v_lo ** 2 / (2.0 * a), v_hi ** 2 / (2.0 * a)  # where √(2·a·h) meets the limits

    def span(lo: float, hi: float) -> tuple[float, float]:  # [h_td, h] ∩ [lo, hi]
        return max(lo, s.touchdown_height_m), min(hi, height_m)

    t = 0.0
    lo, hi = span(0.0, h_lo)
    t += max(0.0, hi - lo) / v_lo
    lo, hi = span(h_lo, h_hi)
    if hi > lo:
        t += math.sqrt(2.0 * hi / a) - math.sqrt(2.0 * lo / a)
    lo, hi = span(h_hi, math.inf)
    t += max(0.0, hi - lo) / v_hi
    return t


def hover_altitude(target_m: FloatArray, regions: list[UnsafeRegion], settings: PlannerSettings) -> float:
    """Cruise altitude above ground, raised over any region that covers the hover point."""
    t = np.asarray(target_m, dtype=float)
    z = t[2] + settings.cruise_altitude_m
    for r in regions:
        if np.all(t[:2] >= r.lo[:2]) and np.all(t[:2] <= r.hi[:2]):
            z = max(z, float(r.hi[2]) + 0.5)
    return min(z, t[2] + settings.max_altitude_m)


@dataclass
class LandingLogic:
    """The phase machine. ``update`` returns the phase and the current goal point."""

    target_m: FloatArray
    settings: PlannerSettings
    phase: Phase = Phase.APPROACH
    _clear_since: float | None = None
    _scan_since: float | None = None

    def reach_clear(self, height_m: float, regions: list[UnsafeRegion]) -> bool:
        """The disc is clear, even of anyone who may walk in before touchdown from ``height_m``."""
        s = self.settings
        reach = s.reach_speed_mps * time_to_touchdown(height_m, s)
        return disc_clear(np.asarray(self.target_m)[:2], s.landing_disc_radius_m, regions, reach)

    def scan_done(self, t_s: float) -> bool:
        s = self.settings
        need = s.scan_sweep_rad / s.scan_yaw_rate_rps if s.scan_yaw_rate_rps > 0 else 0.0
        return self._scan_since is not None and t_s - self._scan_since >= need

    def _to_hold(self) -> None:
        self.phase = Phase.HOLD
        self._scan_since = None  # a new hold looks all around again before descending

    def update(self, pos_m: FloatArray, vel_mps: FloatArray, regions: list[UnsafeRegion],
               t_s: float) -> tuple[Phase, FloatArray]:
        s = self.settings
        tgt = np.asarray(self.target_m, dtype=float)
        pos, vel = np.asarray(pos_m, dtype=float), np.asarray(vel_mps, dtype=float)
        hover = np.array([tgt[0], tgt[1], hover_altitude(tgt, regions, s)])
        horiz = float(np.linalg.norm(pos[:2] - tgt[:2]))
        height = float(pos[2] - tgt[2])

        if self.phase == Phase.TOUCHDOWN:
            return self.phase, tgt
        if self.phase == Phase.DESCEND:
            if height < s.touchdown_height_m:
                self.phase = Phase.TOUCHDOWN
                return self.phase, tgt
            if height > s.commit_height_m and not self.reach_clear(height, regions):
                self._to_hold()
                self._clear_since = None
                return self.phase, hover
            return self.phase, tgt
        # The gate is judged from the hover height: the descent will start from there.
        if self.reach_clear(float(hover[2] - tgt[2]), regions):
            self._clear_since = t_s if self._clear_since is None else self._clear_since
        else:
            self._clear_since = None
        arrived = horiz < s.align_radius_m and abs(pos[2] - hover[2]) < 0.6 and float(np.linalg.norm(vel)) < 0.5
        if self.phase == Phase.APPROACH and arrived:
            self._to_hold()
        if self.phase == Phase.HOLD:
            if arrived and self._scan_since is None:
                self._scan_since = t_s
            if (arrived and self.scan_done(t_s) and self._clear_since is not None
                    and t_s - self._clear_since >= s.hold_clear_s):
                self.phase = Phase.DESCEND
                return self.phase, tgt
            if horiz > 2.0 * s.align_radius_m + 1.0:
                self.phase = Phase.APPROACH
        return self.phase, hover
