"""Quadrotor model used by the MPC: Euler-angle kinematics with body-rate/thrust inputs.

State ``x = [p (3), v (3), roll, pitch, yaw]`` (shape ``(9,)``; m, m/s, rad), world frame
ENU, ``z`` up. Input ``u = [p_rate, q_rate, r_rate, thrust_n]`` (shape ``(4,)``; body rates
in rad/s, FLU body frame, collective thrust in N along body ``+z``).

Continuous dynamics (``R = Rz(ψ) Ry(θ) Rx(φ)``, ``W`` the ZYX Euler-rate matrix)::

    ṗ = v
    v̇ = R e_z · T / m − g e_z − drag · v
    [φ̇, θ̇, ψ̇] = W(φ, θ) · ω

Every function accepts a leading batch dimension (``(M, 9)``/``(M, 4)``) so the MPC can
linearise its whole horizon with a handful of vectorised numpy calls. The discrete model is
one RK4 step with zero-order-hold input; :func:`linearize_discrete` returns the *exact*
derivative of that RK4 map (variational RK4), so ``A_d x̄ + B_d ū + c_d == step(x̄, ū)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from llmland_schemas.arrays import FloatArray

NX = 9
NU = 4


@dataclass(frozen=True)
class ModelParams:
    """Physical parameters and input/attitude limits of the MPC model (SI units)."""

    mass_kg: float = 1.0
    g_mps2: float = 9.81
    drag_per_s: float = 0.0
    thrust_min_frac: float = 0.2
    thrust_max_frac: float = 2.0
    max_roll_rate_rps: float = 6.0
    max_pitch_rate_rps: float = 6.0
    max_yaw_rate_rps: float = 3.0
    max_tilt_rad: float = math.radians(35.0)

    @property
    def hover_thrust_n(self) -> float:
        """Thrust (N) that balances gravity when level."""
        return self.mass_kg * self.g_mps2

    @property
    def u_min(self) -> FloatArray:
        """Lower input bounds ``(4,)``: rates (rad/s) and thrust (N)."""
        return np.array([-self.max_roll_rate_rps, -self.max_pitch_rate_rps,
                         -self.max_yaw_rate_rps, self.thrust_min_frac * self.hover_thrust_n])

    @property
    def u_max(self) -> FloatArray:
        """Upper input bounds ``(4,)``: rates (rad/s) and thrust (N)."""
        return np.array([self.max_roll_rate_rps, self.max_pitch_rate_rps,
                         self.max_yaw_rate_rps, self.thrust_max_frac * self.hover_thrust_n])

    @property
    def u_hover(self) -> FloatArray:
        """Hover input ``(4,)``: zero rates, thrust = m·g."""
        return np.array([0.0, 0.0, 0.0, self.hover_thrust_n])


@lru_cache(maxsize=64)
def _jacobian_templates(m: int, drag_hex: str) -> tuple[FloatArray, FloatArray]:
    """The state-independent entries of ``(∂f/∂x, ∂f/∂u)`` for a batch of ``m``: ``ṗ = v``, the drag
    (keyed by ``float.hex``, which tells ``-0.0`` from ``0.0``), ``φ̇`` from ``p``. Read-only:
    callers copy them."""
    jac_a = np.zeros((m, NX, NX))
    jac_b = np.zeros((m, NX, NU))
    idx = np.arange(3)
    jac_a[:, idx, idx + 3] = 1.0
    jac_a[:, idx + 3, idx + 3] = -float.fromhex(drag_hex)
    jac_b[:, 6, 0] = 1.0
    jac_a.flags.writeable = False
    jac_b.flags.writeable = False
    return jac_a, jac_b


def _f_and_jac(x: FloatArray, u: FloatArray, params: ModelParams,
               with_jac: bool = True) -> tuple[FloatArray, FloatArray | None, FloatArray | None]:
    """Batched dynamics and Jacobians; ``x (M, 9)``, ``u (M, 4)`` → ``(M, 9), (M, 9, 9), (M, 9, 4)``.

    Written entry by entry into preallocated arrays (no stacking, no fancy indexing: half the time
    of the stacked form, the MPC's linearisation runs it four times a tick), each entry the same
    operations in the same order as the formulas in the module docstring."""
    m = x.shape[0]
    phi, th, psi = x[:, 6], x[:, 7], x[:, 8]
    wp, wq, wr, thrust = u[:, 0], u[:, 1], u[:, 2], u[:, 3]
    sf, cf = np.sin(phi), np.cos(phi)
    st, ct = np.sin(th), np.cos(th)
    sp, cp = np.sin(psi), np.cos(psi)
    tt = st / ct
    ez = np.empty((m, 3))  # third column of R = Rz Ry Rx (body z axis in world)
    ez[:, 0] = cp * st * cf + sp * sf
    ez[:, 1] = sp * st * cf - cp * sf
    ez[:, 2] = ct * cf
    a_t = thrust / params.mass_kg
    dx = np.empty((m, NX))
    dx[:, 0:3] = x[:, 3:6]
    dx[:, 3:6] = ez * a_t[:, None] - params.drag_per_s * x[:, 3:6]
    dx[:, 5] -= params.g_mps2
    sq_cr = sf * wq + cf * wr
    cq_sr = cf * wq - sf * wr
    dx[:, 6] = wp + tt * sq_cr
    dx[:, 7] = cq_sr
    dx[:, 8] = sq_cr / ct
    if not with_jac:
        return dx, None, None
    template_a, template_b = _jacobian_templates(m, float(params.drag_per_s).hex())
    jac_a, jac_b = template_a.copy(), template_b.copy()
    # ∂(ez · a_t)/∂(φ, θ, ψ)
    jac_a[:, 3, 6] = (-cp * st * sf + sp * cf) * a_t
    jac_a[:, 4, 6] = (-sp * st * sf - cp * cf) * a_t
    jac_a[:, 5, 6] = (-ct * sf) * a_t
    jac_a[:, 3, 7] = (cp * ct * cf) * a_t
    jac_a[:, 4, 7] = (sp * ct * cf) * a_t
    jac_a[:, 5, 7] = (-st * cf) * a_t
    jac_a[:, 3, 8] = (-sp * st * cf + cp * sf) * a_t
    jac_a[:, 4, 8] = ez[:, 0] * a_t
    jac_a[:, 5, 8] = 0.0 * a_t
    # the Euler-rate map W(φ, θ) · ω
    inv_c2 = 1.0 / (ct * ct)
    jac_a[:, 6, 6] = tt * cq_sr
    jac_a[:, 6, 7] = sq_cr * inv_c2
    jac_a[:, 7, 6] = -sq_cr
    jac_a[:, 8, 6] = cq_sr / ct
    jac_a[:, 8, 7] = sq_cr * st * inv_c2
    jac_b[:, 3:6, 3] = ez / params.mass_kg
    jac_b[:, 6, 1] = tt * sf
    jac_b[:, 6, 2] = tt * cf
    jac_b[:, 7, 1] = cf
    jac_b[:, 7, 2] = -sf
    jac_b[:, 8, 1] = sf / ct
    jac_b[:, 8, 2] = cf / ct
    return dx, jac_a, jac_b


def _as_batch(x: FloatArray, u: FloatArray) -> tuple[FloatArray, FloatArray, bool]:
    xb = np.atleast_2d(np.asarray(x, dtype=float))
    ub = np.atleast_2d(np.asarray(u, dtype=float))
    return xb, ub, np.ndim(x) == 1


def f(x: FloatArray, u: FloatArray, params: ModelParams) -> FloatArray:
    """Continuous-time state derivative ``ẋ``; ``x (9,)|(M, 9)``, ``u (4,)|(M, 4)``."""
    xb, ub, single = _as_batch(x, u)
    dx, _, _ = _f_and_jac(xb, ub, params, with_jac=False)
    return dx[0] if single else dx


def jacobians(x: FloatArray, u: FloatArray, params: ModelParams) -> tuple[FloatArray, FloatArray]:
    """Analytic ``(A_c (9, 9), B_c (9, 4))`` = ``(∂f/∂x, ∂f/∂u)``; batched inputs add a leading ``M``."""
    xb, ub, single = _as_batch(x, u)
    _, ja, jb = _f_and_jac(xb, ub, params)
    assert ja is not None and jb is not None
    return (ja[0], jb[0]) if single else (ja, jb)


def step(x: FloatArray, u: FloatArray, dt: float, params: ModelParams) -> FloatArray:
    """One RK4 step of ``dt`` seconds with input held constant; returns ``x⁺`` like ``x``."""
    xb, ub, single = _as_batch(x, u)
    k1, _, _ = _f_and_jac(xb, ub, params, with_jac=False)
    k2, _, _ = _f_and_jac(xb + 0.5 * dt * k1, ub, params, with_jac=False)
    k3, _, _ = _f_and_jac(xb + 0.5 * dt * k2, ub, params, with_jac=False)
    k4, _, _ = _f_and_jac(xb + dt * k3, ub, params, with_jac=False)
    xn = xb + (dt / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    return xn[0] if single else xn


def linearize_discrete(x_bar: FloatArray, u_bar: FloatArray, dt: float,
                       params: ModelParams) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Discrete affine model of the RK4 step about ``(x̄, ū)``.

    Returns ``(A_d (9, 9), B_d (9, 4), c_d (9,))`` (leading ``M`` when batched) such that
    ``x_{k+1} ≈ A_d x_k + B_d u_k + c_d``; ``A_d``/``B_d`` are the exact derivatives of
    :func:`step`, and the model is exact at ``(x̄, ū)``.
    """
    xb, ub, single = _as_batch(x_bar, u_bar)
    m = xb.shape[0]
    eye = np.broadcast_to(np.eye(NX), (m, NX, NX))
    k1, a1, b1 = _f_and_jac(xb, ub, params)
    assert a1 is not None and b1 is not None
    k2, a2, b2 = _f_and_jac(xb + 0.5 * dt * k1, ub, params)
    assert a2 is not None and b2 is not None
    d2x = a2 @ (eye + 0.5 * dt * a1)
    d2u = a2 @ (0.5 * dt * b1) + b2
    k3, a3, b3 = _f_and_jac(xb + 0.5 * dt * k2, ub, params)
    assert a3 is not None and b3 is not None
    d3x = a3 @ (eye + 0.5 * dt * d2x)
    d3u = a3 @ (0.5 * dt * d2u) + b3
    k4, a4, b4 = _f_and_jac(xb + dt * k3, ub, params)
    assert a4 is not None and b4 is not None
    d4x = a4 @ (eye + dt * d3x)
    d4u = a4 @ (dt * d3u) + b4
    h6 = dt / 6.0
    x_next = xb + h6 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    a_d = eye + h6 * (a1 + 2.0 * d2x + 2.0 * d3x + d4x)
    b_d = h6 * (b1 + 2.0 * d2u + 2.0 * d3u + d4u)
    c_d = x_next - np.einsum("mij,mj->mi", a_d, xb) - np.einsum("mij,mj->mi", b_d, ub)
    if single:
        return a_d[0], b_d[0], c_d[0]
    return a_d, b_d, c_d
