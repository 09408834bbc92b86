"""Rotor/motor model and the X-configuration mixer (pure numpy, no pybullet).

Conventions: body frame FLU, rotor order and spin directions as documented in
:mod:`llmland_sim.vehicle.params`. A wrench is ``[T, tau_x, tau_y, tau_z]`` with the
collective thrust ``T`` in N along body ``+z`` and body torques in N m.
"""

from __future__ import annotations

import math

import numpy as np

from llmland_sim.vehicle.params import DEFAULT_PARAMS, QuadParams


def clip_finite(a: np.ndarray, lo: np.ndarray | float, hi: np.ndarray | float) -> np.ndarray:
    """``np.clip`` for finite input through the ufuncs alone: the vehicle models run it several
    times per physics substep on 3- and 4-vectors, where ``np.clip``'s Python dispatch cost more
    than the maths."""
    out: np.ndarray = np.minimum(np.maximum(a, lo), hi)
    return out


class Mixer:
    """Linear map between the 4 rotor thrusts and the body wrench (X configuration).

    ``wrench = A @ thrusts`` with rows: collective thrust, roll torque
    ``Σ y_i f_i``, pitch torque ``-Σ x_i f_i`` and yaw (reaction) torque
    ``-Σ s_i (km/kf) f_i`` where ``s_i`` is the spin direction of rotor ``i``.
    """

    def __init__(self, params: QuadParams = DEFAULT_PARAMS) -> None:
        self.params = params
        pos = params.rotor_positions_m
        spin = np.asarray(params.rotor_spin_dirs, dtype=float)
        c = params.torque_thrust_ratio_m
        self.allocation: np.ndarray = np.vstack(
            [np.ones(4), pos[:, 1], -pos[:, 0], -spin * c]
        )  # (4, 4): thrusts N -> [T N, tau N m]
        self.allocation_inv: np.ndarray = np.linalg.inv(self.allocation)  # (4, 4)

    def thrusts_from_wrench(self, thrust_n: float, torque_nm: np.ndarray, clip: bool = True) -> np.ndarray:
        """Rotor thrusts (4,) in N that produce ``thrust_n`` and body ``torque_nm`` (3,).

        With ``clip`` each rotor thrust is limited to ``[0, max_rotor_thrust_n]`` (the
        resulting wrench then differs from the request when saturated).
        """
        wrench = np.concatenate(([float(thrust_n)], np.asarray(torque_nm, dtype=float)))
        thrusts: np.ndarray = self.allocation_inv @ wrench
        if clip:
            thrusts = np.clip(thrusts, 0.0, self.params.max_rotor_thrust_n)
        return thrusts

    def wrench_from_thrusts(self, rotor_thrusts_n: np.ndarray) -> tuple[float, np.ndarray]:
        """Collective thrust (N) and body torque (3,) N m of rotor thrusts (4,) N.

        The yaw entry is the rotors' reaction torque assuming ``km · w² = (km/kf) · f``.
        """
        w = self.allocation @ np.asarray(rotor_thrusts_n, dtype=float)
        return float(w[0]), w[1:].copy()


class RotorModel:
    """Four rotors with first-order motor lag and speed saturation.

    The speed obeys ``tau · dw/dt = w_cmd - w``, integrated exactly for a held command:
    ``w[k+1] = w_cmd + (w[k] - w_cmd) · exp(-dt / tau)``.
    """

    def __init__(self, params: QuadParams = DEFAULT_PARAMS) -> None:
        self.params = params
        self._spin = np.asarray(params.rotor_spin_dirs, dtype=float)
        self._positions = params.rotor_positions_m
        self.speeds_radps: np.ndarray = np.zeros(4)  # (4,) rad/s, current rotor speeds
        self.reset()

    def reset(self, speeds_radps: np.ndarray | float | None = None) -> None:
        """Set the rotor speeds (rad/s); ``None`` means the hover speed on all rotors."""
        if speeds_radps is None:
            speeds_radps = self.params.hover_rotor_speed_radps
        self.speeds_radps = self.saturate(np.broadcast_to(speeds_radps, (4,)).astype(float))

    def saturate(self, speeds_radps: np.ndarray) -> np.ndarray:
        """Clip rotor speeds (4,) to the physical range, rad/s."""
        return clip_finite(np.asarray(speeds_radps, dtype=float), self.params.min_rotor_speed_radps,
                           self.params.max_rotor_speed_radps)

    def speeds_for_thrusts(self, rotor_thrusts_n: np.ndarray) -> np.ndarray:
        """Steady-state rotor speeds (4,) rad/s giving thrusts (4,) N (``sqrt(f/kf)``)."""
        f = np.maximum(np.asarray(rotor_thrusts_n, dtype=float), 0.0)
        return self.saturate(np.sqrt(f / self.params.kf_n_per_radps2))

    def step(self, speed_cmd_radps: np.ndarray, dt_s: float) -> np.ndarray:
        """Advance the motor lag by ``dt_s`` seconds; return the new speeds (4,) rad/s."""
        if dt_s < 0.0:
            raise ValueError(f"dt_s must be >= 0, got {dt_s}")
        cmd = self.saturate(speed_cmd_radps)
        alpha = math.exp(-dt_s / self.params.motor_time_constant_s)
        self.speeds_radps = cmd + (self.speeds_radps - cmd) * alpha
        return self.speeds_radps.copy()

    @property
    def thrusts_n(self) -> np.ndarray:
        """Per-rotor thrust (4,) in N along body +z: ``kf · w²``."""
        return self.params.kf_n_per_radps2 * self.speeds_radps**2

    @property
    def reaction_torques_nm(self) -> np.ndarray:
        """Per-rotor reaction torque about body z (4,) in N m: ``-s_i · km · w²``."""
        return -self._spin * self.params.km_nm_per_radps2 * self.speeds_radps**2

    def body_wrench(self) -> tuple[float, np.ndarray]:
        """Collective thrust (N, body +z) and body torque (3,) N m of the current speeds.

        Roll/pitch torques come from the thrust lever arms ``r_i × (0, 0, f_i)``; the yaw
        torque is the sum of the reaction torques.
        """
        f = self.thrusts_n
        torque = np.array(
            [
                float(np.dot(self._positions[:, 1], f)),
                float(-np.dot(self._positions[:, 0], f)),
                float(np.sum(self.reaction_torques_nm)),
            ]
        )
        return float(np.sum(f)), torque
