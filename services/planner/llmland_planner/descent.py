"""The final descent: fast and committed, with a flare (a real quadrotor sinks at 2–3 m/s).

Sink speed ``v`` (m/s, positive down) as a function of time and of the height ``h`` above the
ground: it grows at ``accel_mps2`` up to ``max_speed_mps`` and never exceeds the flare curve
``√(v_td² + 2·brake·(h − h_floor))``, which brings it down to ``touchdown_speed_mps`` at the
reference floor ``h_floor`` (:data:`REFERENCE_FLOOR_M`) with a constant deceleration
``brake_mps2``. The time to touchdown from any state is needed every tick by the hard-limit
gate, so :meth:`DescentProfile.time_to_touchdown_s` is closed form.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from llmland_schemas.arrays import FloatArray

#: the reference ends this far (m) above the touchdown point, at rest
REFERENCE_FLOOR_M = 0.03
#: a climb-out's heights are sampled for at most this long (s)
CLIMB_OUT_MAX_S = 30.0


@dataclass(frozen=True)
class DescentProfile:
    """Sink-rate profile of the final descent (SI units, speeds positive downward)."""

    max_speed_mps: float = 2.5
    accel_mps2: float = 4.0
    brake_mps2: float = 4.0
    touchdown_speed_mps: float = 0.3

    def flare_speed(self, h_m: float) -> float:
        """Largest sink speed (m/s) at height ``h_m`` from which the flare still stops in time."""
        d = max(h_m - REFERENCE_FLOOR_M, 0.0)
        return min(self.max_speed_mps, math.sqrt(self.touchdown_speed_mps ** 2 + 2.0 * self.brake_mps2 * d))

    def reference(self, h0_m: float, v0_mps: float, dt_s: float, count: int) -> tuple[FloatArray, FloatArray]:
        """Heights ``(count,)`` above touchdown and sink speeds ``(count,)`` from ``(h0, v0)``."""
        h_out, v_out = np.empty(count), np.empty(count)
        h, v = h0_m, max(0.0, v0_mps)
        for k in range(count):
            h_out[k], v_out[k] = h, v
            if h <= REFERENCE_FLOOR_M:
                h, v = REFERENCE_FLOOR_M, 0.0
                continue
            v = min(v + self.accel_mps2 * dt_s, self.flare_speed(h))
            h = max(REFERENCE_FLOOR_M, h - v * dt_s)
        return h_out, v_out

    def time_to_touchdown_s(self, h_m: float, v0_mps: float = 0.0, touchdown_h_m: float = REFERENCE_FLOOR_M) -> float:
        """Seconds from height ``h_m`` (sinking at ``v0_mps``) down to ``touchdown_h_m`` (≥ the floor).

        Phases: accelerate at ``accel`` until the speed meets ``max_speed`` or the flare
        curve, cruise at ``max_speed``, flare (constant deceleration) to ``touchdown_speed``
        at the floor; the flare's last part, below ``touchdown_h_m``, is not counted.
        """
        if h_m <= touchdown_h_m:
            return 0.0
        b, vt = self.brake_mps2, self.touchdown_speed_mps
        tail = max(0.0, touchdown_h_m - REFERENCE_FLOOR_M)
        return self._time_to_floor(h_m - REFERENCE_FLOOR_M, v0_mps) - (math.sqrt(vt * vt + 2.0 * b * tail) - vt) / b

    def _time_to_floor(self, d: float, v0_mps: float) -> float:
        if d <= 0.0:
            return 0.0
        a, b, vm, vt = self.accel_mps2, self.brake_mps2, self.max_speed_mps, self.touchdown_speed_mps
        v0 = min(max(0.0, v0_mps), self.flare_speed(d + REFERENCE_FLOOR_M))
        # height (above touchdown) where the flare curve reaches the cruise speed
        h_flare = (vm * vm - vt * vt) / (2.0 * b)
        # accelerating from v0: distance to reach v is (v² − v0²)/(2a); meets the flare curve
        # where (v² − v0²)/(2a) + (v² − vt²)/(2b) = d
        v_meet = math.sqrt(max(v0 * v0, (2.0 * d + v0 * v0 / a + vt * vt / b) / (1.0 / a + 1.0 / b)))
        if v_meet <= vm:  # no cruise: accelerate to v_meet, then flare
            return (v_meet - v0) / a + (v_meet - vt) / b
        d_acc = (vm * vm - v0 * v0) / (2.0 * a)
        d_cruise = max(0.0, d - d_acc - h_flare)
        return (vm - v0) / a + d_cruise / vm + (vm - vt) / b


def climb_out_heights(height_m: float, sink_mps: float, exit_height_m: float, climb_speed_mps: float,
                      accel_mps2: float, dt_s: float) -> FloatArray:
    """Heights (m) every ``dt_s`` of a climb-out started now, until above ``exit_height_m``.

    From ``height_m`` sinking at ``sink_mps`` (m/s, positive down): the vertical speed changes by at
    most ``accel_mps2`` (m/s²) per second, from the sink to ``climb_speed_mps`` up, and stays there.
    The first height is ``height_m``; the last is the first at or above ``exit_height_m`` (at
    most 30 s of samples).
    """
    if climb_speed_mps <= 0.0 or accel_mps2 <= 0.0 or dt_s <= 0.0:
        raise ValueError(f"climb speed, acceleration and step must be positive: {climb_speed_mps}, {accel_mps2}, "
                         f"{dt_s}")
    h, v = height_m, max(0.0, sink_mps)  # v positive down
    out = [h]
    while h < exit_height_m and len(out) * dt_s < CLIMB_OUT_MAX_S:
        v = max(v - accel_mps2 * dt_s, -climb_speed_mps)
        h -= v * dt_s
        out.append(h)
    return np.asarray(out)
