"""Physical and control constants of the default LLM-Land quadrotor.

All quantities are SI (see ``docs/conventions.md``). Body frame is FLU, world frame is
z-up, collective thrust acts along body ``+z``.

Rotor layout ("X" configuration, seen from above, body x forward, y left)::

        front
      0       3          rotor 0: front-left  (+x, +y)  spins CCW (+z)
        \\   /            rotor 1: rear-left   (-x, +y)  spins CW  (-z)
         [ ]             rotor 2: rear-right  (-x, -y)  spins CCW (+z)
        /   \\            rotor 3: front-right (+x, -y)  spins CW  (-z)
      1       2

A rotor spinning CCW (angular velocity along body ``+z``) exerts a reaction torque
along ``-z`` on the airframe, and vice versa.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

GRAVITY_MPS2 = 9.81  # m/s², magnitude of gravity (acts along world -z)


@dataclass(frozen=True)
class QuadParams:
    """Immutable constants of the simulated quadrotor (units in the comments)."""

    # --- rigid body -------------------------------------------------------------------
    mass_kg: float = 1.0  # kg
    arm_length_m: float = 0.16  # m, distance from the centre of mass to each rotor axis
    # kg m², principal moments (body x, y, z). A 0.2 kg central box plus 4 × 0.2 kg
    # motor/rotor point masses at 0.16 m (I = Σ m r²/2 per in-plane axis) gives ~[0.0055,
    # 0.0055, 0.0105]; frame/battery spread raises it to these plausible values.
    inertia_diag_kgm2: tuple[float, float, float] = (0.0075, 0.0075, 0.013)
    gravity_mps2: float = GRAVITY_MPS2  # m/s²

    # --- rotors -----------------------------------------------------------------------
    kf_n_per_radps2: float = 6.0e-6  # N/(rad/s)², rotor thrust = kf · w²
    km_nm_per_radps2: float = 9.6e-8  # N m/(rad/s)², reaction torque = km · w² (km/kf = 0.016 m)
    # rad/s, rotor speed limits; 4 · kf · 1011² ≈ 24.53 N ≈ 2.5 · m · g
    max_rotor_speed_radps: float = 1011.0
    min_rotor_speed_radps: float = 0.0  # rad/s
    motor_time_constant_s: float = 0.03  # s, first-order lag of the rotor speed
    # +1: rotor spins CCW seen from above (angular velocity along body +z); -1: CW.
    rotor_spin_dirs: tuple[int, int, int, int] = (1, -1, 1, -1)

    # --- aerodynamics -----------------------------------------------------------------
    linear_drag_ns_per_m: float = 0.1  # N/(m/s), isotropic drag force = -c · v_world

    # --- body-rate controller (angular-acceleration gains, torque = J · gain · error) --
    rate_kp_per_s: tuple[float, float, float] = (40.0, 40.0, 12.0)  # 1/s on rate error
    rate_ki_per_s2: tuple[float, float, float] = (10.0, 10.0, 5.0)  # 1/s² on ∫ rate error
    rate_kd: tuple[float, float, float] = (0.75, 0.75, 0.2)  # dimensionless, on measured dω/dt
    # rad, anti-windup clamp on the integral of the rate error ∫(ω_cmd - ω)dt (per axis)
    rate_integral_limit_rad: tuple[float, float, float] = (0.3, 0.3, 0.3)

    # --- command limits -----------------------------------------------------------------
    max_roll_pitch_rate_rps: float = 6.0  # rad/s, |p|, |q| command saturation
    max_yaw_rate_rps: float = 3.0  # rad/s, |r| command saturation
    max_tilt_rad: float = math.radians(35.0)  # rad, enforced by planners, not by the sim

    # --- geometry ---------------------------------------------------------------------
    collision_radius_m: float = 0.25  # m, bounding sphere radius for planners/collision
    body_box_m: tuple[float, float, float] = (0.4, 0.4, 0.1)  # m, URDF collision box size

    @property
    def mass(self) -> float:
        """Alias of ``mass_kg``, kg."""
        return self.mass_kg

    @property
    def inertia_kgm2(self) -> np.ndarray:
        """Inertia matrix J (3, 3) in kg m², body frame."""
        return np.diag(np.asarray(self.inertia_diag_kgm2, dtype=float))

    @property
    def hover_thrust_n(self) -> float:
        """Collective thrust that balances gravity, N (m · g)."""
        return self.mass_kg * self.gravity_mps2

    @property
    def max_rotor_thrust_n(self) -> float:
        """Thrust of one rotor at maximum speed, N."""
        return self.kf_n_per_radps2 * self.max_rotor_speed_radps**2

    @property
    def max_thrust_n(self) -> float:
        """Collective thrust with all 4 rotors at maximum speed, N (≈ 2.5 · m · g)."""
        return 4.0 * self.max_rotor_thrust_n

    @property
    def hover_rotor_speed_radps(self) -> float:
        """Rotor speed at which the 4 rotors together carry m · g, rad/s."""
        return math.sqrt(self.hover_thrust_n / (4.0 * self.kf_n_per_radps2))

    @property
    def torque_thrust_ratio_m(self) -> float:
        """Reaction-torque / thrust ratio km / kf, m."""
        return self.km_nm_per_radps2 / self.kf_n_per_radps2

    @property
    def rotor_positions_m(self) -> np.ndarray:
        """Rotor hub positions (4, 3) in the body frame, m (X configuration)."""
        d = self.arm_length_m / math.sqrt(2.0)
        return np.array([[d, d, 0.0], [-d, d, 0.0], [-d, -d, 0.0], [d, -d, 0.0]], dtype=float)

    @property
    def max_body_rates_rps(self) -> np.ndarray:
        """Per-axis command saturation (3,) for (p, q, r), rad/s."""
        return np.array([self.max_roll_pitch_rate_rps, self.max_roll_pitch_rate_rps, self.max_yaw_rate_rps])


DEFAULT_PARAMS = QuadParams()
