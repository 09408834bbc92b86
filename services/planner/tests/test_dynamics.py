"""Tests of the MPC model: Jacobians, RK4 linearisation, hover equilibrium."""

from __future__ import annotations

import numpy as np
from llmland_planner.dynamics import ModelParams, f, jacobians, linearize_discrete, step

PRM = ModelParams(drag_per_s=0.1)
RNG = np.random.default_rng(0)


def _random_point() -> tuple[np.ndarray, np.ndarray]:
    x = np.concatenate([RNG.uniform(-2, 2, 6), RNG.uniform(-0.5, 0.5, 2), RNG.uniform(-3, 3, 1)])
    u = np.concatenate([RNG.uniform(-2, 2, 3), RNG.uniform(5, 15, 1)])
    return x, u


def _fd(fun, z: np.ndarray, h: float = 1e-6) -> np.ndarray:
    cols = []
    for i in range(z.size):
        e = np.zeros_like(z)
        e[i] = h
        cols.append((fun(z + e) - fun(z - e)) / (2 * h))
    return np.stack(cols, axis=1)


def test_jacobians_match_central_differences() -> None:
    for _ in range(5):
        x, u = _random_point()
        a_c, b_c = jacobians(x, u, PRM)
        np.testing.assert_allclose(a_c, _fd(lambda z, u=u: f(z, u, PRM), x), atol=1e-7, rtol=1e-5)
        np.testing.assert_allclose(b_c, _fd(lambda z, x=x: f(x, z, PRM), u), atol=1e-7, rtol=1e-5)


def test_discrete_jacobians_match_rk4_step() -> None:
    dt = 0.05
    for _ in range(5):
        x, u = _random_point()
        a_d, b_d, c_d = linearize_discrete(x, u, dt, PRM)
        np.testing.assert_allclose(a_d, _fd(lambda z, u=u: step(z, u, dt, PRM), x), atol=1e-7, rtol=1e-5)
        np.testing.assert_allclose(b_d, _fd(lambda z, x=x: step(x, z, dt, PRM), u), atol=1e-7, rtol=1e-5)
        np.testing.assert_allclose(a_d @ x + b_d @ u + c_d, step(x, u, dt, PRM), atol=1e-12)


def test_linear_model_predicts_small_perturbations() -> None:
    dt = 0.05
    x, u = _random_point()
    a_d, b_d, c_d = linearize_discrete(x, u, dt, PRM)
    for scale in (1e-2, 1e-3):
        dx, du = scale * RNG.standard_normal(9), scale * RNG.standard_normal(4)
        err = np.linalg.norm(a_d @ (x + dx) + b_d @ (u + du) + c_d - step(x + dx, u + du, dt, PRM))
        assert err < 10 * scale**2


def test_batch_matches_single() -> None:
    xs, us = zip(*[_random_point() for _ in range(4)], strict=True)
    a_b, b_b, c_b = linearize_discrete(np.array(xs), np.array(us), 0.05, PRM)
    for i in range(4):
        a_s, b_s, c_s = linearize_discrete(xs[i], us[i], 0.05, PRM)
        np.testing.assert_allclose(a_b[i], a_s)
        np.testing.assert_allclose(c_b[i], c_s)


def test_hover_is_equilibrium() -> None:
    prm = ModelParams()
    x = np.array([1.0, -2.0, 3.0, 0, 0, 0, 0, 0, 0.7])
    np.testing.assert_allclose(f(x, prm.u_hover, prm), 0.0, atol=1e-12)
    np.testing.assert_allclose(step(x, prm.u_hover, 0.05, prm), x, atol=1e-12)
    assert prm.u_min[3] == 0.2 * prm.hover_thrust_n and prm.u_max[3] == 2.0 * prm.hover_thrust_n


def test_tilt_direction_follows_conventions() -> None:
    """Positive pitch tilts thrust towards +x, positive roll towards −y (R = Rz Ry Rx)."""
    prm = ModelParams()
    x = np.zeros(9)
    x[7] = 0.2
    assert f(x, prm.u_hover, prm)[3] > 0
    x[7], x[6] = 0.0, 0.2
    assert f(x, prm.u_hover, prm)[4] < 0


def test_a_jacobian_written_by_a_caller_leaves_the_next_call_alone() -> None:
    """The Jacobians start from a cached template of their constant entries: a caller writing into
    one batch's result must not change another's (the MPC keeps and scales them)."""
    xs = np.stack([_random_point()[0] for _ in range(3)])
    us = np.stack([_random_point()[1] for _ in range(3)])
    a1, b1 = jacobians(xs, us, PRM)
    a1[:] = np.nan
    b1[:] = np.nan
    a2, b2 = jacobians(xs, us, PRM)
    assert np.all(np.isfinite(a2)) and np.all(np.isfinite(b2))
    assert np.all(a2[:, [0, 1, 2], [3, 4, 5]] == 1.0) and np.all(b2[:, 6, 0] == 1.0)
