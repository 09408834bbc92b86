"""Landing logic: approach above the unsafe regions, descend only onto a clear disc.

Phases:

- ``approach`` — fly (searched path, corridors, MPC) to the hover point above the target
  at ``cruise_altitude_m``, raised above the ``z_min`` of any region covering it;
- ``hold`` — hover there while the landing disc is not clear of every unsafe region;
- ``descend`` — straight down at ``descent_speed_mps`` while the disc stays clear; an
  intrusion sends the vehicle back up to the hover point (``hold``);
- ``touchdown`` — low and slow: thrust off.
"""

from __future__ import annotations

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


def disc_clear(target_xy: FloatArray, radius_m: float, regions: list[UnsafeRegion]) -> bool:
    """True when no region's footprint (box in x, y) meets the disc around ``target_xy``."""
    c = np.asarray(target_xy, dtype=float)[:2]
    for r in regions:
        nearest = np.clip(c, r.lo[:2], r.hi[:2])
        if float(np.linalg.norm(nearest - c)) < radius_m:
            return False
    return True


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

    def update(self, pos_m: FloatArray, vel_mps: FloatArray, regions: list[UnsafeRegion],
               t_s: float) -> tuple[Phase, FloatArray]:
        s = self.settings
        tgt = np.asarray(self.target_m, dtype=float)
        pos, vel = np.asarray(pos_m, dtype=float), np.asarray(vel_mps, dtype=float)
        hover = np.array([tgt[0], tgt[1], hover_altitude(tgt, regions, s)])
        clear = disc_clear(tgt[:2], s.landing_disc_radius_m, regions)
        if clear:
            self._clear_since = t_s if self._clear_since is None else self._clear_since
        else:
            self._clear_since = None
        horiz = float(np.linalg.norm(pos[:2] - tgt[:2]))
        height = float(pos[2] - tgt[2])

        if self.phase == Phase.TOUCHDOWN:
            return self.phase, tgt
        if self.phase == Phase.DESCEND:
            if height < s.touchdown_height_m:
                self.phase = Phase.TOUCHDOWN
                return self.phase, tgt
            if not clear:
                self.phase = Phase.HOLD
                return self.phase, hover
            return self.phase, tgt
        arrived = horiz < s.align_radius_m and abs(pos[2] - hover[2]) < 0.6 and float(np.linalg.norm(vel)) < 0.5
        if self.phase == Phase.APPROACH and arrived:
            self.phase = Phase.HOLD
        if self.phase == Phase.HOLD:
            if arrived and self._clear_since is not None and t_s - self._clear_since >= s.hold_clear_s:
                self.phase = Phase.DESCEND
                return self.phase, tgt
            if horiz > 2.0 * s.align_radius_m + 1.0:
                self.phase = Phase.APPROACH
        return self.phase, hover
