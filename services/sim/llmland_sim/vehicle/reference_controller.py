"""Reference position controller (pure numpy): the test oracle and early demo pilot.

It outputs exactly what the planner sends: body rates (p, q, r) in rad/s and the
collective thrust in N. Cascade:

1. position P (speed-limited) -> desired velocity; velocity P -> desired acceleration
   (norm-limited), plus gravity compensation -> desired thrust vector ``F`` (world, N);
2. tilt limit: the horizontal part of ``F`` is scaled so that ``angle(F, z) ≤ 35°``;
3. desired attitude ``R_d = [b1 b2 b3]`` with ``b3 = F/|F|`` and the heading from the
   desired yaw; collective thrust ``T = F · (R e3)`` (projected on the current body z);
4. geometric SO(3) attitude error ``e_R = ½ vee(R_dᵀ R - Rᵀ R_d)`` (body frame) and
   body-rate command ``ω = -K_att ⊙ e_R``, saturated to ±(6, 6, 3) rad/s.

Also holds the small rotation helpers (quaternion ``(x, y, z, w)`` <-> matrix, ZYX Euler)
shared by the vehicle package.
"""

from __future__ import annotations

import math

import numpy as np

from llmland_sim.vehicle.params import DEFAULT_PARAMS, QuadParams


def quat_to_rotmat(quat_xyzw: np.ndarray) -> np.ndarray:
    """Rotation matrix (3, 3) mapping body vectors to world, from a quaternion (x, y, z, w)."""
    x, y, z, w = (float(c) for c in quat_xyzw)
    n = math.sqrt(x * x + y * y + z * z + w * w)  # scalar maths: called every physics substep
    x, y, z, w = x / n, y / n, z / n, w / n
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def rotmat_to_euler_zyx(rot: np.ndarray) -> np.ndarray:
    """ZYX Euler angles (roll φ, pitch θ, yaw ψ) (3,) rad of ``R = Rz(ψ) Ry(θ) Rx(φ)``."""
    r = np.asarray(rot, dtype=float)
    roll = math.atan2(r[2, 1], r[2, 2])
    pitch = -math.asin(float(np.clip(r[2, 0], -1.0, 1.0)))
    yaw = math.atan2(r[1, 0], r[0, 0])
    return np.array([roll, pitch, yaw])


def euler_zyx_to_rotmat(roll_rad: float, pitch_rad: float, yaw_rad: float) -> np.ndarray:
    """``R = Rz(ψ) @ Ry(θ) @ Rx(φ)`` (3, 3), body -> world."""
    cr, sr = math.cos(roll_rad), math.sin(roll_rad)
    cp, sp = math.cos(pitch_rad), math.sin(pitch_rad)
    cy, sy = math.cos(yaw_rad), math.sin(yaw_rad)
    rx = np.array([[1.0, 0.0, 0.0], [0.0, cr, -sr], [0.0, sr, cr]])
    ry = np.array([[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]])
    rz = np.array([[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]])
    out: np.ndarray = rz @ ry @ rx
    return out


def _vee(m: np.ndarray) -> np.ndarray:
    """Vector (3,) of a skew-symmetric matrix (3, 3)."""
    return np.array([m[2, 1], m[0, 2], m[1, 0]])


def _clip_norm(v: np.ndarray, max_norm: float) -> np.ndarray:
    n = float(np.linalg.norm(v))
    if n > max_norm > 0.0:
        return v * (max_norm / n)
    return v


class ReferencePositionController:
    """Cascaded geometric position controller producing (body rates, thrust).

    Attributes (settable):
        max_speed_mps: cap on the commanded velocity norm, m/s (default 2.0).
        max_accel_mps2: cap on the commanded acceleration norm (excl. gravity), m/s².
        max_tilt_rad: tilt limit of the thrust vector, rad (default 35°).
        kp_pos_per_s: position gain (3,), 1/s (desired velocity per metre of error).
        kv_vel_per_s: velocity gain (3,), 1/s (desired acceleration per m/s of error).
        k_att_per_s: attitude gain (3,), 1/s (body rate per rad of attitude error).
    """

    def __init__(
        self,
        params: QuadParams = DEFAULT_PARAMS,
        max_speed_mps: float = 2.0,
        max_accel_mps2: float = 4.0,
    ) -> None:
        self.params = params
        self.max_speed_mps = max_speed_mps
        self.max_accel_mps2 = max_accel_mps2
        self.max_tilt_rad = params.max_tilt_rad
        self.kp_pos_per_s = np.array([1.6, 1.6, 2.0])
        self.kv_vel_per_s = np.array([4.0, 4.0, 5.0])
        self.k_att_per_s = np.array([8.0, 8.0, 3.0])
        self.min_thrust_frac = 0.1  # fraction of m·g kept as a floor on the thrust vector z

    def desired_force(
        self,
        pos_m: np.ndarray,
        vel_mps: np.ndarray,
        target_pos_m: np.ndarray,
        target_vel_mps: np.ndarray | None = None,
    ) -> np.ndarray:
        """Desired thrust vector (3,) in world frame, N (tilt-limited)."""
        p = self.params
        e_pos = np.asarray(target_pos_m, dtype=float) - np.asarray(pos_m, dtype=float)
        v_ff = np.zeros(3) if target_vel_mps is None else np.asarray(target_vel_mps, dtype=float)
        v_des = _clip_norm(self.kp_pos_per_s * e_pos + v_ff, self.max_speed_mps)
        a_des = _clip_norm(self.kv_vel_per_s * (v_des - np.asarray(vel_mps, dtype=float)), self.max_accel_mps2)
        f = p.mass_kg * (a_des + np.array([0.0, 0.0, p.gravity_mps2]))
        f[2] = max(f[2], self.min_thrust_frac * p.hover_thrust_n)
        f_xy_max = f[2] * math.tan(self.max_tilt_rad)
        f[:2] = _clip_norm(f[:2], f_xy_max)
        return f

    def update(
        self,
        pos_m: np.ndarray,
        vel_mps: np.ndarray,
        quat_xyzw: np.ndarray,
        target_pos_m: np.ndarray,
        target_vel_mps: np.ndarray | None = None,
        target_yaw_rad: float = 0.0,
    ) -> tuple[np.ndarray, float]:
        """Compute the command for the current state.

        Args:
            pos_m: position (3,) world, m.
            vel_mps: velocity (3,) world, m/s.
            quat_xyzw: attitude quaternion (4,) (x, y, z, w), body -> world.
            target_pos_m: target position (3,) world, m.
            target_vel_mps: optional velocity feed-forward (3,) world, m/s.
            target_yaw_rad: desired heading ψ, rad.

        Returns:
            ``(body_rates_rps (3,) rad/s, thrust_n N)``.
        """
        p = self.params
        rot = quat_to_rotmat(quat_xyzw)
        f = self.desired_force(pos_m, vel_mps, target_pos_m, target_vel_mps)
        b3 = f / np.linalg.norm(f)
        b1c = np.array([math.cos(target_yaw_rad), math.sin(target_yaw_rad), 0.0])
        b2 = np.cross(b3, b1c)
        b2 /= np.linalg.norm(b2)  # b3 is within 35° of z, so b3 × b1c never vanishes
        b1 = np.cross(b2, b3)
        rot_des = np.column_stack([b1, b2, b3])
        e_rot = 0.5 * _vee(rot_des.T @ rot - rot.T @ rot_des)
        rates = np.clip(-self.k_att_per_s * e_rot, -p.max_body_rates_rps, p.max_body_rates_rps)
        thrust = float(np.clip(np.dot(f, rot[:, 2]), 0.0, p.max_thrust_n))
        return rates, thrust
