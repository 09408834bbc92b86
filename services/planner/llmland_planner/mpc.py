"""Real-time-iteration MPC (one QP per tick) on the Euler-angle quadrotor model, via clarabel.

Each tick linearises the RK4 model (:mod:`llmland_planner.dynamics`) about the previous
solution shifted by one step (cold start: constant state, hover input), refreshes the values
of a QP whose sparsity pattern was fixed at construction (:mod:`llmland_planner.mpc_layout`),
and solves it once. ``solve`` is meant to be called once per ``dt``.

Cost ``½ Σ ‖x_k − x_ref,k‖²_Q + ‖u_k − u_hover‖²_R + ‖Δu_k‖²_Rd + slack terms`` (``Δu_0 =
u_0 − u_prev``, terminal weight ``Q_N`` on ``x_N``). Corridor rows and the floor are softened
by one slack ``s_k ≥ 0`` per stage with an exact-penalty linear weight (``slack_linear``,
1e3) plus a small quadratic one: with hard rows the linearised QP goes infeasible
mid-manoeuvre, while the exact penalty keeps ``s_k = 0`` whenever the rows can be met.
Roll/pitch bounds are hard but loosened near ``x_0`` when the current tilt already exceeds
them (so the QP stays feasible); inputs are hard boxes. On any failure (solver status other
than Solved/AlmostSolved, non-finite data, exception) the result has ``ok=False`` and
``u0`` is a level-and-hold command; ``solve`` never raises.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field
from typing import Any

import clarabel
import numpy as np
import scipy.sparse as sp
from llmland_schemas.arrays import FloatArray

from llmland_planner.dynamics import NU, NX, ModelParams, linearize_discrete
from llmland_planner.mpc_layout import QpIndex, build_constraints, build_cost, dynamics_masks

log = logging.getLogger(__name__)

Halfspaces = list[tuple[FloatArray, FloatArray]]
_OK_STATUS = ("Solved", "AlmostSolved")


@dataclass
class MpcWeights:
    """Diagonal cost weights (``½‖·‖²`` convention)."""

    pos: tuple[float, float, float] = (20.0, 20.0, 30.0)
    vel: tuple[float, float, float] = (3.0, 3.0, 3.0)
    roll_pitch: float = 0.5
    yaw: float = 5.0
    terminal_scale: float = 5.0
    rates: tuple[float, float, float] = (0.5, 0.5, 0.5)
    thrust: float = 0.05
    d_rates: tuple[float, float, float] = (1.0, 1.0, 1.0)
    d_thrust: float = 0.1
    slack_linear: float = 1.0e3
    slack_quad: float = 10.0


@dataclass
class MpcResult:
    """One tick's output: ``u0 (4,)`` (rates rad/s, thrust N), predictions ``x_pred (N+1, 9)``,
    ``u_pred (N, 4)``; ``solve_ms`` = clarabel update + solve, ``tick_ms`` = the whole call;
    ``max_slack`` (m) = largest corridor/floor violation the QP accepted."""

    u0: FloatArray
    x_pred: FloatArray
    u_pred: FloatArray
    status: str
    solve_ms: float
    tick_ms: float
    iterations: int
    ok: bool
    max_slack: float = 0.0
    z: FloatArray | None = None  # raw QP solution (None on fallback)


@dataclass
class QpData:
    """The QP ``min ½zᵀPz + qᵀz  s.t.  A z + s = b, s ∈ {0}^n_eq × ℝ₊^n_ineq``."""

    P: sp.csc_matrix  # upper triangle
    q: FloatArray
    A: sp.csc_matrix
    b: FloatArray
    n_eq: int
    n_ineq: int
    extras: dict[str, Any] = field(default_factory=dict)


class MpcController:
    """RTI MPC; see the module docstring. ``max_halfspaces`` = corridor rows per stage."""

    def __init__(self, params: ModelParams | None = None, horizon: int = 20, dt: float = 0.05,
                 max_halfspaces: int = 8, weights: MpcWeights | None = None,
                 z_floor_m: float = 0.0, qp_max_iter: int = 50, qp_tol: float = 1e-6) -> None:
        self.params = params or ModelParams()
        self.n, self.dt, self.k = horizon, dt, max_halfspaces
        self.weights = w = weights or MpcWeights()
        self.z_floor_m = z_floor_m
        self.ix = QpIndex(horizon, max_halfspaces)
        rng = np.random.default_rng(7)
        xs = rng.uniform(-0.4, 0.4, (3, NX))
        us = self.params.u_hover + rng.uniform(-0.5, 0.5, (3, NU))
        a_s, b_s, _ = linearize_discrete(xs, us, dt, self.params)
        self._mask_a, self._mask_b = dynamics_masks(a_s, b_s)
        lay, self._slots = build_constraints(self.ix, self._mask_a, self._mask_b)
        self._a_mat, self._perm, self._a_vals = lay.finish()
        self._q_diag = np.array([*w.pos, *w.vel, w.roll_pitch, w.roll_pitch, w.yaw])
        self._r_diag = np.array([*w.rates, w.thrust])
        self._rd_diag = np.array([*w.d_rates, w.d_thrust])
        self._p_mat = build_cost(self.ix, self._q_diag, w.terminal_scale * self._q_diag,
                                 self._r_diag, self._rd_diag, w.slack_quad)
        self._cones = [clarabel.ZeroConeT(self.ix.n_eq),
                       clarabel.NonnegativeConeT(self.ix.n_con - self.ix.n_eq)]
        self._settings = clarabel.DefaultSettings()
        self._settings.verbose = False
        self._settings.presolve_enable = False
        self._settings.iterative_refinement_enable = False
        self._settings.max_iter = qp_max_iter
        self._settings.max_threads = 1  # the machine is shared; threads only add jitter here
        self._settings.direct_solve_method = "qdldl"
        for name in ("tol_gap_abs", "tol_gap_rel", "tol_feas", "tol_infeas_abs", "tol_infeas_rel"):
            setattr(self._settings, name, qp_tol)
        self._solver: Any = None
        self._q = np.zeros(self.ix.n_var)
        self._b = np.zeros(self.ix.n_con)
        self._x_guess: FloatArray | None = None
        self._u_guess: FloatArray | None = None
        self.u_prev = self.params.u_hover.copy()

    def reset(self) -> None:
        """Forget the warm-start trajectory, the previous input and the solver: a solver updated
        from the last episode's QPs answers the same QP up to ~1e-12 differently from a new one,
        and a closed loop can grow that into another episode (the same seed must fly the same
        episode whatever the planner flew before)."""
        self._x_guess = self._u_guess = None
        self.u_prev = self.params.u_hover.copy()
        self._solver = None

    def problem_matrices(self) -> QpData:
        """The QP of the last tick (copies), for checking with an independent solver."""
        a = self._a_mat.copy()
        a.data = self._a_vals[self._perm].copy()
        return QpData(self._p_mat.copy(), self._q.copy(), a, self._b.copy(), self.ix.n_eq,
                      self.ix.n_con - self.ix.n_eq)

    def solve(self, x0: FloatArray, ref_pos: FloatArray, ref_vel: FloatArray,
              ref_yaw: float | FloatArray = 0.0, halfspaces: Halfspaces | None = None,
              z_floor_m: float | None = None) -> MpcResult:
        """One RTI tick from ``x0 (9,)`` tracking ``ref_pos, ref_vel (N+1, 3)`` and ``ref_yaw``
        (rad, scalar or ``(N+1,)``; index ``k`` is time ``k·dt`` from now).

        ``halfspaces[k-1] = (A (≤K, 3), b (≤K,))`` constrains ``p_k`` (stage ``k = 1…N``); fewer
        rows or a shorter list leave the rest unconstrained, ``None`` means no corridor.
        ``z_floor_m`` overrides the (soft) floor ``z_k ≥ z_floor`` for this tick.
        """
        t_tick = time.perf_counter()
        try:
            self._fill(np.asarray(x0, dtype=float), np.asarray(ref_pos, dtype=float),
                       np.asarray(ref_vel, dtype=float), ref_yaw, halfspaces,
                       self.z_floor_m if z_floor_m is None else z_floor_m)
            t_solve = time.perf_counter()
            res = self._run_solver()
            solve_ms = 1e3 * (time.perf_counter() - t_solve)
            status, iters = str(res.status), int(res.iterations)
            z = np.asarray(res.x, dtype=float)
            if status not in _OK_STATUS or not np.all(np.isfinite(z)):
                return self._fallback(x0, status, t_tick, solve_ms, iters)
        except Exception as exc:  # never raise from a control tick
            log.warning("MPC tick failed: %s", exc)
            self._solver = None
            return self._fallback(x0, f"error: {exc}", t_tick, 0.0, 0)
        ix = self.ix
        x_pred = z[: ix.u(0)].reshape(self.n + 1, NX)
        u_pred = z[ix.u(0): ix.s(1)].reshape(self.n, NU)
        u0 = np.clip(u_pred[0], self.params.u_min, self.params.u_max)
        self._x_guess = np.vstack([x_pred[1:], x_pred[-1:]])
        self._u_guess = np.vstack([u_pred[1:], u_pred[-1:]])
        self.u_prev = u0.copy()
        return MpcResult(u0, x_pred, u_pred, status, solve_ms,
                         1e3 * (time.perf_counter() - t_tick), iters, True,
                         float(np.max(z[ix.s(1):], initial=0.0)), z)

    def _fill(self, x0: FloatArray, ref_pos: FloatArray, ref_vel: FloatArray,
              ref_yaw: float | FloatArray, halfspaces: Halfspaces | None, z_floor: float) -> None:
        """Refresh ``A`` values, ``b`` and ``q`` for this tick."""
        n, ix, prm = self.n, self.ix, self.params
        if not np.all(np.isfinite(x0)):
            raise ValueError("non-finite state")
        if self._x_guess is None or self._u_guess is None:
            xg, ug = np.tile(x0, (n, 1)), np.tile(prm.u_hover, (n, 1))
        else:
            xg, ug = self._x_guess[:n].copy(), self._u_guess.copy()
            xg[:, 8] += 2.0 * np.pi * np.round((x0[8] - xg[0, 8]) / (2.0 * np.pi))
            xg[0] = x0
        a_d, b_d, c_d = linearize_discrete(xg, ug, self.dt, prm)
        vals = self._a_vals
        vals[self._slots["A"]] = -a_d[:, self._mask_a].ravel()
        vals[self._slots["B"]] = -b_d[:, self._mask_b].ravel()
        k = self.k
        corr_a, corr_b = np.zeros((n, k, 3)), np.ones((n, k))
        if halfspaces is not None:
            for s, (ha, hb) in enumerate(halfspaces[:n]):
                rows, rhs = np.asarray(ha, dtype=float).reshape(-1, 3), np.asarray(hb, dtype=float).ravel()
                if rows.shape[0] > k or rhs.shape[0] != rows.shape[0]:
                    raise ValueError(f"stage {s + 1}: {rows.shape[0]} corridor rows, at most {k}")
                corr_a[s, : rows.shape[0]], corr_b[s, : rows.shape[0]] = rows, rhs
        vals[self._slots["corr"]] = corr_a.ravel()
        b = self._b
        b[:NX] = x0
        b[NX: ix.n_eq] = c_d.ravel()
        b[ix.row_input: ix.row_tilt] = np.tile(np.concatenate([prm.u_max, -prm.u_min]), n)
        loosen = 0.8 * self.dt * np.arange(1, n + 1) * prm.max_roll_rate_rps
        tilt_r = np.maximum(prm.max_tilt_rad, abs(x0[6]) - loosen)
        tilt_p = np.maximum(prm.max_tilt_rad, abs(x0[7]) - loosen)
        b[ix.row_tilt: ix.row_corr] = np.stack([tilt_r, tilt_r, tilt_p, tilt_p], 1).ravel()
        b[ix.row_corr: ix.row_slack] = np.concatenate(
            [corr_b, np.full((n, 1), -z_floor)], axis=1).ravel()
        b[ix.row_slack:] = 0.0
        yaw = np.broadcast_to(np.asarray(ref_yaw, dtype=float), (n + 1,))
        yaw = x0[8] + np.angle(np.exp(1j * (yaw - x0[8])))
        x_ref = np.concatenate([ref_pos, ref_vel, np.zeros((n + 1, 2)), yaw[:, None]], axis=1)
        w_x = np.tile(self._q_diag, (n + 1, 1))
        w_x[0] = 0.0
        w_x[n] *= self.weights.terminal_scale
        q = self._q
        q[: ix.u(0)] = -(w_x * x_ref).ravel()
        q[ix.u(0): ix.s(1)] = np.tile(-self._r_diag * prm.u_hover, n)
        q[ix.u(0): ix.u(0) + NU] -= self._rd_diag * self.u_prev
        q[ix.s(1):] = self.weights.slack_linear
        if not (np.all(np.isfinite(vals)) and np.all(np.isfinite(b)) and np.all(np.isfinite(q))):
            raise ValueError("non-finite QP data")

    def _run_solver(self) -> Any:
        data = self._a_vals[self._perm]
        if self._solver is None:
            a = self._a_mat.copy()
            a.data = data
            self._solver = clarabel.DefaultSolver(self._p_mat, self._q, a, self._b,
                                                  self._cones, self._settings)
        else:
            self._solver.update(q=self._q, A=data, b=self._b)
        return self._solver.solve()

    def _fallback(self, x0: FloatArray, status: str, t_tick: float, solve_ms: float,
                  iters: int) -> MpcResult:
        """Level-and-hold command: drive roll/pitch to zero, thrust to hold altitude."""
        prm = self.params
        x = np.where(np.isfinite(x0), x0, 0.0)
        phi, th = float(np.clip(x[6], -1.2, 1.2)), float(np.clip(x[7], -1.2, 1.2))
        rate_des = np.array([-4.0 * phi, -4.0 * th, 0.0])  # Euler rates (rad/s)
        w_inv = np.array([[1.0, 0.0, -np.sin(th)],
                          [0.0, np.cos(phi), np.sin(phi) * np.cos(th)],
                          [0.0, -np.sin(phi), np.cos(phi) * np.cos(th)]])
        thrust = prm.hover_thrust_n / max(np.cos(phi) * np.cos(th), 0.5)
        u0 = np.clip(np.append(w_inv @ rate_des, thrust), prm.u_min, prm.u_max)
        log.warning("MPC fallback (%s)", status)
        self._x_guess = self._u_guess = None
        self.u_prev = u0.copy()
        return MpcResult(u0, np.tile(x, (self.n + 1, 1)), np.tile(u0, (self.n, 1)), status,
                         solve_ms, 1e3 * (time.perf_counter() - t_tick), iters, False)
