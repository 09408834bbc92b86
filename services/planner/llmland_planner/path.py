"""Time-parametrised paths from the kinodynamic search and their resampling.

A :class:`Path` holds samples ``t (M,)`` s, ``p (M, 3)`` m, ``v (M, 3)`` m/s in the world
frame. The search builds it from constant-acceleration primitives (quadratic in time) and a
final cubic "one-shot" to rest at the goal. Sample times include every piece boundary, so
cubic Hermite interpolation between samples (using ``p`` and ``v``) reproduces the pieces
exactly; :func:`resample` uses it to produce the MPC reference.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from llmland_schemas.arrays import FloatArray

SHOT_T_FACTORS = np.array([1.0, 1.15, 1.3, 1.5, 1.75, 2.0, 2.5, 3.0, 4.0, 6.0])


@dataclass
class Path:
    """Sampled path: ``t (M,)`` s from 0, ``p (M, 3)`` m, ``v (M, 3)`` m/s."""

    t: FloatArray
    p: FloatArray
    v: FloatArray
    cost: float = 0.0
    expansions: int = 0

    @property
    def duration_s(self) -> float:
        """Time (s) from the first to the last sample."""
        return float(self.t[-1] - self.t[0])

    @classmethod
    def from_pieces(cls, chain: list[tuple[FloatArray, FloatArray, FloatArray]],
                    shot: tuple[FloatArray, float], tau_s: float, cost: float,
                    expansions: int, sample_dt_s: float = 0.05) -> Path:
        """Assemble from primitive nodes ``[(p, v, a_next)]`` and the final cubic shot.

        ``shot = (coeffs (4, 3), duration_s)``, ``p(t) = Σ_i coeffs[i] t^i``.
        """
        ts_l: list[FloatArray] = []
        ps_l: list[FloatArray] = []
        vs_l: list[FloatArray] = []
        t0 = 0.0
        n_sub = max(1, math.ceil(tau_s / sample_dt_s))
        local = np.linspace(0.0, tau_s, n_sub + 1)[:-1]
        for p, v, a in chain[:-1]:
            pos, vel = sample_primitive(p, v, a[None], local)
            ts_l.append(t0 + local)
            ps_l.append(pos[0])
            vs_l.append(vel[0])
            t0 += tau_s
        coeffs, dur = shot
        n_shot = max(1, math.ceil(dur / sample_dt_s))
        local_s = np.linspace(0.0, dur, n_shot + 1)
        pos_s, vel_s = sample_cubic(coeffs, local_s)
        ts_l.append(t0 + local_s)
        ps_l.append(pos_s)
        vs_l.append(vel_s)
        return cls(np.concatenate(ts_l), np.concatenate(ps_l), np.concatenate(vs_l),
                   cost, expansions)


def sample_primitive(p: FloatArray, v: FloatArray, acc: FloatArray,
                     ts: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Constant-acceleration rollouts: ``p, v (3,)``, ``acc (M, 3)``, ``ts (S,)`` → ``(M, S, 3)`` ×2."""
    t = ts[None, :, None]
    a = acc[:, None, :]
    pos = p + v * t + 0.5 * a * t * t
    vel = v + a * t
    return pos, vel


def sample_cubic(coeffs: FloatArray, ts: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Evaluate ``p(t) = Σ c_i t^i`` (``coeffs (4, 3)``) at ``ts (S,)`` → ``(S, 3)`` ×2."""
    t = ts[:, None]
    c0, c1, c2, c3 = coeffs
    pos = c0 + t * (c1 + t * (c2 + t * c3))
    vel = c1 + t * (2.0 * c2 + 3.0 * t * c3)
    return pos, vel


def cubic_to_rest(p: FloatArray, v: FloatArray, goal: FloatArray, rho: float,
                  v_max: float, a_max: float) -> tuple[FloatArray, float, float] | None:
    """Cheapest feasible cubic from ``(p, v)`` to ``(goal, 0)`` over a grid of durations.

    Cost ``ρ·T + ∫‖a‖² dt``; feasibility: ``‖v(t)‖ ≤ v_max``, ``|a_d(t)| ≤ a_max``.
    Returns ``(coeffs (4, 3), T_s, cost)`` or ``None``.
    """
    d = goal - p
    t_lb = max(float(np.linalg.norm(d)) / v_max, float(np.max(np.abs(v))) / a_max, 0.2)
    tt = t_lb * SHOT_T_FACTORS[:, None]  # (K, 1)
    a2 = (3.0 * d - 2.0 * v * tt) / tt ** 2
    a3 = (-2.0 * d + v * tt) / tt ** 3
    t1 = tt[:, 0]
    energy = (4.0 * np.sum(a2 * a2, 1) * t1 + 12.0 * np.sum(a2 * a3, 1) * t1 ** 2
              + 12.0 * np.sum(a3 * a3, 1) * t1 ** 3)
    cost = rho * t1 + energy
    acc_ok = np.all(np.abs(2.0 * a2) <= a_max + 1e-9, 1) & np.all(
        np.abs(2.0 * a2 + 6.0 * a3 * tt) <= a_max + 1e-9, 1)
    s = np.linspace(0.0, 1.0, 12)[None, :, None] * tt[:, :, None]  # (K, 12, 1)
    vel = v + 2.0 * a2[:, None, :] * s + 3.0 * a3[:, None, :] * s * s
    vel_ok = np.all(np.linalg.norm(vel, axis=2) <= v_max + 1e-9, axis=1)
    feasible = np.flatnonzero(acc_ok & vel_ok)
    if feasible.size == 0:
        return None
    k = int(feasible[np.argmin(cost[feasible])])
    coeffs = np.stack([p, v, a2[k], a3[k]])
    return coeffs, float(t1[k]), float(cost[k])


def resample(path: Path, dt: float, t_start: float | None = None,
             count: int | None = None) -> Path:
    """Samples every ``dt`` s from ``t_start`` (default: path start).

    ``count`` fixes the number of samples (e.g. ``N + 1`` for an MPC window); times past the
    end hold the final position with zero velocity. Interpolation is cubic Hermite.
    """
    t0 = float(path.t[0]) if t_start is None else float(t_start)
    if count is None:
        count = int(math.floor((float(path.t[-1]) - t0) / dt + 1e-9)) + 1
        count = max(count, 1)
    tq: FloatArray = t0 + dt * np.arange(count, dtype=float)
    tc = np.clip(tq, path.t[0], path.t[-1])
    i = np.clip(np.searchsorted(path.t, tc, side="right") - 1, 0, len(path.t) - 2)
    h = path.t[i + 1] - path.t[i]
    s = ((tc - path.t[i]) / h)[:, None]
    hv = h[:, None]
    p0, p1, v0, v1 = path.p[i], path.p[i + 1], path.v[i], path.v[i + 1]
    pos = ((2 * s**3 - 3 * s**2 + 1) * p0 + (s**3 - 2 * s**2 + s) * hv * v0
           + (-2 * s**3 + 3 * s**2) * p1 + (s**3 - s**2) * hv * v1)
    vel = ((6 * s**2 - 6 * s) * p0 + (3 * s**2 - 4 * s + 1) * hv * v0
           + (-6 * s**2 + 6 * s) * p1 + (3 * s**2 - 2 * s) * hv * v1) / hv
    past = tq > path.t[-1]
    vel[past] = 0.0
    return Path(tq, pos, vel, path.cost, path.expansions)
