"""Tests of the RTI MPC: QP optimality against OSQP, closed loop on the RK4 model, fallback."""

from __future__ import annotations

import numpy as np
import osqp
import scipy.sparse as sp
from llmland_planner.corridors import corridor_for_segment, halfspaces_at_times
from llmland_planner.dynamics import ModelParams, step
from llmland_planner.mpc import MpcController
from llmland_planner.path import Path, resample
from llmland_planner.regions import UnsafeRegion

PRM = ModelParams()
N, DT, K = 20, 0.05, 8


def _box_rows(lo: list[float], hi: list[float]) -> tuple[np.ndarray, np.ndarray]:
    a = np.vstack([np.eye(3), -np.eye(3), np.zeros((K - 6, 3))])
    b = np.concatenate([hi, -np.asarray(lo), np.ones(K - 6)])
    return a, b


def _hover_at(p: list[float]) -> np.ndarray:
    x = np.zeros(9)
    x[:3] = p
    return x


def _closed_loop(mpc: MpcController, x: np.ndarray, target: np.ndarray, hs: list, ticks: int
                 ) -> tuple[np.ndarray, list]:
    traj, results = [x[:3].copy()], []
    for _ in range(ticks):
        res = mpc.solve(x, np.tile(target, (N + 1, 1)), np.zeros((N + 1, 3)), 0.0, hs)
        results.append(res)
        x = step(x, res.u0, DT, PRM)
        traj.append(x[:3].copy())
    return np.array(traj), results


def _osqp_check(qp_tol: float, sol_atol: float) -> None:
    mpc = MpcController(PRM, N, DT, K, qp_tol=qp_tol, qp_max_iter=100)
    x0 = _hover_at([0.0, 0.0, 2.0])
    x0[3:6] = [0.5, -0.3, 0.2]
    x0[6:9] = [0.05, -0.1, 0.3]
    hs = [_box_rows([-0.5, -0.5, 1.0], [2.5, 0.3, 2.5])] * N  # the reference leaves it: slack active
    ref = np.tile([2.0, 1.0, 1.0], (N + 1, 1))
    mpc.solve(x0, ref, np.zeros((N + 1, 3)), 0.5, hs)
    res = mpc.solve(x0, ref, np.zeros((N + 1, 3)), 0.5, hs)  # linearised about a trajectory
    assert res.ok and res.z is not None
    qp = mpc.problem_matrices()
    l_b = np.concatenate([qp.b[: qp.n_eq], np.full(qp.n_ineq, -np.inf)])
    solver = osqp.OSQP()
    solver.setup(qp.P, qp.q, qp.A, l_b, qp.b, verbose=False, eps_abs=1e-10, eps_rel=1e-10,
                 polishing=True, max_iter=200000)
    ref_sol = solver.solve(raise_error=False)
    assert ref_sol.info.status == "solved"
    p_full = qp.P + sp.triu(qp.P, 1).T

    def obj(z: np.ndarray) -> float:
        return float(0.5 * z @ (p_full @ z) + qp.q @ z)

    assert abs(obj(res.z) - obj(ref_sol.x)) <= 1e-4 * max(1.0, abs(obj(ref_sol.x)))
    np.testing.assert_allclose(res.z, ref_sol.x, atol=sol_atol)
    assert np.max(qp.A[: qp.n_eq] @ res.z - qp.b[: qp.n_eq]) < 1e-5
    assert np.max(qp.A[qp.n_eq:] @ res.z - qp.b[qp.n_eq:]) < 1e-5
    assert res.max_slack > 0.0


def test_qp_matches_osqp() -> None:
    """Same QP, independent solver (OSQP, polished, 1e-10 tolerances)."""
    _osqp_check(1e-9, 1e-4)  # tight clarabel tolerances: solutions agree to 1e-4
    _osqp_check(1e-6, 1e-2)  # production tolerance: objective within 1e-4 relative


def test_closed_loop_converges_inside_corridor() -> None:
    mpc = MpcController(PRM, N, DT, K)
    target = np.array([2.0, 1.0, 1.0])
    lo, hi = [-0.5, -0.5, 0.5], [2.5, 1.5, 2.5]
    traj, results = _closed_loop(mpc, _hover_at([0.0, 0.0, 2.0]), target, [_box_rows(lo, hi)] * N,
                                 100)
    assert all(r.ok for r in results)
    assert np.linalg.norm(traj[-1] - target) < 0.1
    assert np.all(traj >= np.array(lo) - 0.01) and np.all(traj <= np.array(hi) + 0.01)
    tilt = np.array([np.max(np.abs(r.x_pred[1:, 6:8])) for r in results])
    assert np.all(tilt <= PRM.max_tilt_rad + 1e-6)
    assert all(np.all(r.u0 >= PRM.u_min - 1e-9) and np.all(r.u0 <= PRM.u_max + 1e-9) for r in results)


def test_corridor_excluding_straight_line_is_respected() -> None:
    mpc = MpcController(PRM, N, DT, K)
    target = np.array([2.0, 1.0, 1.0])
    corridor = _box_rows([-0.5, -0.5, 0.5], [2.5, 0.4, 2.5])  # y ≤ 0.4 cuts the straight line
    traj, results = _closed_loop(mpc, _hover_at([0.0, 0.0, 2.0]), target, [corridor] * N, 100)
    assert all(r.ok for r in results)
    assert np.max(traj[:, 1]) <= 0.4 + 0.02
    np.testing.assert_allclose(traj[-1], [2.0, 0.4, 1.0], atol=0.1)


def test_detour_around_obstacle_with_timed_corridors() -> None:
    """Two corridors around a box on the straight line; the drone never enters the box."""
    obstacle = UnsafeRegion([0.8, -0.6, 0.0], [1.4, 0.6, 4.0])
    knots = np.array([[0.0, 0.0, 2.0], [1.1, 1.2, 2.0], [2.2, 0.0, 2.0]])
    t = np.array([0.0, 1.5, 3.0])
    vel = np.vstack([np.zeros(3), (knots[2] - knots[0]) / 3.0, np.zeros(3)])
    path = Path(t, knots, vel)
    cors = []
    for i in range(2):
        c = corridor_for_segment(knots[i], knots[i + 1], [obstacle], margin_m=0.6, max_halfspaces=K)
        assert c is not None and c.segment_clear
        c.t0, c.t1 = float(t[i]), float(t[i + 1])
        cors.append(c)
    mpc = MpcController(PRM, N, DT, K)
    x = _hover_at(list(knots[0]))
    for tick in range(100):
        t_now = tick * DT
        win = resample(path, DT, t_start=t_now, count=N + 1)
        hs = halfspaces_at_times(cors, win.t[1:], K)  # rows for stages 1..N
        res = mpc.solve(x, win.p, win.v, 0.0, hs)
        assert res.ok
        x = step(x, res.u0, DT, PRM)
        assert obstacle.signed_distance(x[:3]) > 0.0
    assert np.linalg.norm(x[:3] - knots[2]) < 0.15


def test_failed_solve_returns_level_hover_command() -> None:
    mpc = MpcController(PRM, N, DT, K)
    x0 = _hover_at([0.0, 0.0, 2.0])
    ref = np.tile([1.0, 0.0, 2.0], (N + 1, 1))
    bad = mpc.solve(np.full(9, np.nan), ref, np.zeros((N + 1, 3)))
    assert not bad.ok
    np.testing.assert_allclose(bad.u0, PRM.u_hover)
    nan_rows = [(np.zeros((K, 3)), np.full(K, np.nan))] * N
    assert not mpc.solve(x0, ref, np.zeros((N + 1, 3)), 0.0, nan_rows).ok
    tilted = x0.copy()
    tilted[6] = 0.3
    starved = MpcController(PRM, N, DT, K, qp_max_iter=1)
    res = starved.solve(tilted, ref, np.zeros((N + 1, 3)))
    assert not res.ok and res.status == "MaxIterations"
    assert res.u0[0] < 0.0 and res.u0[3] >= PRM.hover_thrust_n  # levels the roll, holds altitude
    assert mpc.solve(x0, ref, np.zeros((N + 1, 3))).ok  # recovers after failures


def test_partial_rows_and_too_many_rows() -> None:
    mpc = MpcController(PRM, N, DT, K)
    x0 = _hover_at([0.0, 0.0, 2.0])
    ref = np.tile([1.0, 0.0, 2.0], (N + 1, 1))
    few = [(np.array([[1.0, 0.0, 0.0]]), np.array([0.5]))] * (N // 2)  # x ≤ 0.5, first half only
    res = mpc.solve(x0, ref, np.zeros((N + 1, 3)), 0.0, few)
    assert res.ok and np.all(res.x_pred[1 : N // 2 + 1, 0] <= 0.5 + 1e-4)
    many = [(np.tile([1.0, 0.0, 0.0], (K + 1, 1)), np.ones(K + 1))] * N
    assert not mpc.solve(x0, ref, np.zeros((N + 1, 3)), 0.0, many).ok


def test_yaw_takes_the_short_way_round() -> None:
    mpc = MpcController(PRM, N, DT, K)
    x = _hover_at([0.0, 0.0, 2.0])
    x[8] = 3.0
    for _ in range(40):
        res = mpc.solve(x, np.tile(x[:3], (N + 1, 1)), np.zeros((N + 1, 3)), -3.0)
        assert res.ok
        x = step(x, res.u0, DT, PRM)
        assert x[8] >= 3.0 - 1e-3  # increases through π instead of unwinding 6 rad
    assert abs(np.angle(np.exp(1j * (x[8] + 3.0)))) < 0.05


def test_after_reset_the_same_qp_gets_bit_identical_answers_whatever_was_solved_before() -> None:
    """A solver kept across episodes answered ~1e-12 differently from a new one."""
    def problem(seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        rng = np.random.default_rng(seed)
        x0 = np.zeros(9)
        x0[:3], x0[3:6] = rng.uniform(-1, 1, 3), rng.uniform(-0.5, 0.5, 3)
        return x0, np.tile(rng.uniform(-2, 2, 3), (21, 1)), np.zeros((21, 3))

    fresh, used = MpcController(), MpcController()
    used.solve(*problem(1))
    used.solve(*problem(2))
    used.reset()
    a, b = fresh.solve(*problem(3)), used.solve(*problem(3))
    assert np.array_equal(a.u0, b.u0) and np.array_equal(a.x_pred, b.x_pred)
