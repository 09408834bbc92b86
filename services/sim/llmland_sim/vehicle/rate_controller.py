"""Low-level body-rate controller (pure numpy): ControlCommand -> rotor speed commands.

Per axis, with the rate error ``e = ω_cmd - ω`` (body frame, rad/s)::

    τ = J · (Kp · e + Ki · ∫e dt - Kd · dω/dt) + ω × (J ω)

The D term acts on the measured rate only (no derivative kick when the zero-order-held
command steps); it damps the motor lag so Kp can be high. With the motor time constant
``τm`` the small-signal loop is ``τm s² + (1 + Kd) s + Kp`` (≈ ζ 0.8, ωn 37 rad/s for
the default roll/pitch gains).

The integral is clamped (anti-windup) and frozen while the rotors saturate. The torque
and collective thrust go through the X mixer; when a rotor would exceed its maximum
thrust the collective is lowered first (attitude has priority over climb), then each
rotor thrust is clipped to ``[0, max]`` and converted to a speed ``sqrt(f / kf)``.
"""

from __future__ import annotations

import numpy as np

from llmland_sim.vehicle.params import DEFAULT_PARAMS, QuadParams
from llmland_sim.vehicle.rotors import Mixer, clip_finite


def _cross3(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a × b`` of two 3-vectors (``np.cross`` without its axis handling)."""
    a0, a1, a2 = a.tolist()
    b0, b1, b2 = b.tolist()
    return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])


class RateController:
    """PD(+I) body-rate controller with gyroscopic feed-forward and mixer.

    Runs at the physics rate (call :meth:`update` every physics substep).
    """

    def __init__(self, params: QuadParams = DEFAULT_PARAMS) -> None:
        self.params = params
        self.mixer = Mixer(params)
        self._J = params.inertia_kgm2  # (3, 3) kg m²
        self._kp = np.asarray(params.rate_kp_per_s, dtype=float)
        self._ki = np.asarray(params.rate_ki_per_s2, dtype=float)
        self._kd = np.asarray(params.rate_kd, dtype=float)
        self._i_lim = np.asarray(params.rate_integral_limit_rad, dtype=float)
        self._rate_lim = params.max_body_rates_rps
        self.integral_rad = np.zeros(3)  # (3,) rad, ∫ rate error dt
        self._prev_rate: np.ndarray | None = None
        self._saturated = False
        self.last_torque_nm = np.zeros(3)  # (3,) N m, last requested body torque
        self.last_rotor_thrusts_n = np.zeros(4)  # (4,) N, last (clipped) rotor thrusts

    def reset(self) -> None:
        """Clear the integrator and the derivative memory."""
        self.integral_rad = np.zeros(3)
        self._prev_rate = None
        self._saturated = False
        self.last_torque_nm = np.zeros(3)
        self.last_rotor_thrusts_n = np.zeros(4)

    def saturate_rates(self, body_rates_rps: np.ndarray) -> np.ndarray:
        """Clip commanded body rates (3,) to ±(6, 6, 3) rad/s (per params)."""
        return clip_finite(np.asarray(body_rates_rps, dtype=float), -self._rate_lim, self._rate_lim)

    def compute_torque(self, rates_cmd_rps: np.ndarray, rates_meas_rps: np.ndarray, dt_s: float) -> np.ndarray:
        """Desired body torque (3,) N m for commanded/measured body rates (3,) rad/s."""
        omega = np.asarray(rates_meas_rps, dtype=float)
        err = self.saturate_rates(rates_cmd_rps) - omega
        if dt_s > 0.0 and not self._saturated:
            self.integral_rad = clip_finite(self.integral_rad + err * dt_s, -self._i_lim, self._i_lim)
        if self._prev_rate is None or dt_s <= 0.0:
            rate_dot = np.zeros(3)
        else:
            rate_dot = (omega - self._prev_rate) / dt_s
        self._prev_rate = omega.copy()
        ang_acc = self._kp * err + self._ki * self.integral_rad - self._kd * rate_dot  # rad/s²
        torque: np.ndarray = self._J @ ang_acc + _cross3(omega, self._J @ omega)
        return torque

    def allocate(self, thrust_n: float, torque_nm: np.ndarray) -> np.ndarray:
        """Rotor thrusts (4,) N for a collective thrust (N) and body torque (3,) N m.

        Lowers the collective when a rotor would exceed its maximum, then clips to
        ``[0, max_rotor_thrust_n]``. Sets the saturation flag used for anti-windup.
        """
        f_max = self.params.max_rotor_thrust_n
        f = self.mixer.thrusts_from_wrench(thrust_n, torque_nm, clip=False)
        f_hi, f_lo = float(f.max()), float(f.min())
        excess = f_hi - f_max
        if excess > 0.0:
            shift = min(excess, max(f_lo, 0.0))
            f, f_hi, f_lo = f - shift, f_hi - shift, f_lo - shift
        self._saturated = f_hi > f_max + 1e-9 or f_lo < -1e-9
        return clip_finite(f, 0.0, f_max)

    def update(
        self,
        body_rates_cmd_rps: np.ndarray,
        thrust_cmd_n: float,
        body_rates_meas_rps: np.ndarray,
        dt_s: float,
    ) -> np.ndarray:
        """One controller step; returns rotor speed commands (4,) in rad/s.

        Args:
            body_rates_cmd_rps: commanded (p, q, r) (3,) rad/s, body frame (saturated here).
            thrust_cmd_n: commanded collective thrust, N (clipped to ``[0, max_thrust_n]``).
            body_rates_meas_rps: measured (p, q, r) (3,) rad/s, body frame.
            dt_s: time since the previous call, s.
        """
        thrust = min(max(float(thrust_cmd_n), 0.0), self.params.max_thrust_n)
        torque = self.compute_torque(body_rates_cmd_rps, body_rates_meas_rps, dt_s)
        f = self.allocate(thrust, torque)
        self.last_torque_nm = torque
        self.last_rotor_thrusts_n = f
        speeds: np.ndarray = np.sqrt(f / self.params.kf_n_per_radps2)
        return speeds
