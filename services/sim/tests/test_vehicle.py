"""Tests of the simulated quadrotor (real pybullet, DIRECT mode)."""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator

import numpy as np
import pybullet as p
import pytest
from llmland_sim.vehicle import (
    DEFAULT_PARAMS,
    Mixer,
    Quadrotor,
    QuadState,
    RateController,
    ReferencePositionController,
    RotorModel,
    euler_zyx_to_rotmat,
    quat_to_rotmat,
    rotmat_to_euler_zyx,
)

PHYSICS_HZ = 240
CTRL_HZ = 48

ControllerFn = Callable[[float, QuadState], tuple[np.ndarray, float]]


@pytest.fixture
def client() -> Iterator[int]:
    cid = p.connect(p.DIRECT)
    p.setGravity(0.0, 0.0, -DEFAULT_PARAMS.gravity_mps2, physicsClientId=cid)
    p.setTimeStep(1.0 / PHYSICS_HZ, physicsClientId=cid)
    plane = p.createCollisionShape(p.GEOM_PLANE, physicsClientId=cid)
    p.createMultiBody(0.0, plane, physicsClientId=cid)
    yield cid
    p.disconnect(cid)


def _sim_loop(
    quad: Quadrotor,
    client: int,
    seconds: float,
    physics_hz: int,
    ctrl_hz: int,
    controller_fn: ControllerFn,
) -> tuple[np.ndarray, list[QuadState]]:
    """Closed loop: command at ``ctrl_hz`` (zero-order hold), physics at ``physics_hz``.

    Returns the times (N,) s and the states logged after every physics step.
    """
    assert physics_hz % ctrl_hz == 0
    p.setTimeStep(1.0 / physics_hz, physicsClientId=client)
    n_sub = physics_hz // ctrl_hz
    dt = 1.0 / physics_hz
    times: list[float] = []
    states: list[QuadState] = []
    n_ctrl = int(round(seconds * ctrl_hz))
    for k in range(n_ctrl):
        rates, thrust = controller_fn(k / ctrl_hz, quad.state())
        quad.set_command(rates, thrust)
        for j in range(n_sub):
            quad.apply_forces(dt)
            p.stepSimulation(physicsClientId=client)
            times.append((k * n_sub + j + 1) * dt)
            states.append(quad.state())
    return np.asarray(times), states


def _const(rates: tuple[float, float, float], thrust_n: float) -> ControllerFn:
    def fn(_t: float, _s: QuadState) -> tuple[np.ndarray, float]:
        return np.asarray(rates, dtype=float), thrust_n

    return fn


HOVER_N = DEFAULT_PARAMS.hover_thrust_n


# ----------------------------------------------------------------------- pure numpy
def test_params_consistency() -> None:
    prm = DEFAULT_PARAMS
    assert prm.max_thrust_n == pytest.approx(2.5 * prm.mass_kg * prm.gravity_mps2, rel=0.01)
    assert prm.torque_thrust_ratio_m == pytest.approx(0.016)
    assert prm.hover_thrust_n == pytest.approx(9.81)


def test_motor_lag_exact_discretisation() -> None:
    prm = DEFAULT_PARAMS
    rm = RotorModel(prm)
    rm.reset(0.0)
    cmd = np.full(4, 800.0)
    rm.step(cmd, 0.01)
    expected = 800.0 * (1.0 - math.exp(-0.01 / prm.motor_time_constant_s))
    np.testing.assert_allclose(rm.speeds_radps, expected, rtol=1e-12)
    # exactness: ten steps of dt/10 == one step of dt
    rm2 = RotorModel(prm)
    rm2.reset(0.0)
    for _ in range(10):
        rm2.step(cmd, 0.001)
    np.testing.assert_allclose(rm2.speeds_radps, expected, rtol=1e-12)
    # saturation of the speed command
    rm.step(np.full(4, 1e5), 10.0)
    np.testing.assert_allclose(rm.speeds_radps, prm.max_rotor_speed_radps)


def test_mixer_round_trip_and_clipping() -> None:
    prm = DEFAULT_PARAMS
    mixer = Mixer(prm)
    thrust, torque = 11.0, np.array([0.05, -0.08, 0.02])
    f = mixer.thrusts_from_wrench(thrust, torque)
    t2, tau2 = mixer.wrench_from_thrusts(f)
    assert t2 == pytest.approx(thrust)
    np.testing.assert_allclose(tau2, torque, atol=1e-12)
    # rotor model at the steady-state speeds reproduces the same wrench (incl. yaw km·w²)
    rm = RotorModel(prm)
    rm.reset(rm.speeds_for_thrusts(f))
    t3, tau3 = rm.body_wrench()
    assert t3 == pytest.approx(thrust)
    np.testing.assert_allclose(tau3, torque, atol=1e-9)
    # positive roll torque: left rotors (0, 1 at +y) push harder
    f_roll = mixer.thrusts_from_wrench(HOVER_N, np.array([0.1, 0.0, 0.0]))
    assert f_roll[0] > f_roll[3] and f_roll[1] > f_roll[2]
    # clipping to [0, max]
    f_clip = mixer.thrusts_from_wrench(1.0, np.array([1.0, 0.0, 0.0]))
    assert np.all(f_clip >= 0.0) and np.all(f_clip <= prm.max_rotor_thrust_n)


def test_rate_controller_priority_and_feedforward() -> None:
    rc = RateController(DEFAULT_PARAMS)
    omega = np.array([1.0, 2.0, 0.5])
    tau = rc.compute_torque(omega, omega, 1.0 / PHYSICS_HZ)  # zero error: only ω × Jω
    np.testing.assert_allclose(tau, np.cross(omega, DEFAULT_PARAMS.inertia_kgm2 @ omega))
    # at max collective the roll torque is kept by lowering the collective
    f = rc.allocate(DEFAULT_PARAMS.max_thrust_n, np.array([0.2, 0.0, 0.0]))
    _, tau_out = rc.mixer.wrench_from_thrusts(f)
    assert tau_out[0] == pytest.approx(0.2)


def test_rotation_helpers() -> None:
    rot = euler_zyx_to_rotmat(0.3, -0.2, 1.1)
    q = p.getQuaternionFromEuler([0.3, -0.2, 1.1])
    np.testing.assert_allclose(quat_to_rotmat(np.asarray(q)), rot, atol=1e-12)
    np.testing.assert_allclose(rotmat_to_euler_zyx(rot), [0.3, -0.2, 1.1], atol=1e-12)


# ----------------------------------------------------------------------- pybullet
def test_urdf_mass_and_inertia(client: int) -> None:
    quad = Quadrotor(client)
    info = p.getDynamicsInfo(quad.body_id, -1, physicsClientId=client)
    assert info[0] == pytest.approx(DEFAULT_PARAMS.mass_kg)
    np.testing.assert_allclose(info[2], DEFAULT_PARAMS.inertia_diag_kgm2)


def test_set_command_rejects_non_finite(client: int) -> None:
    quad = Quadrotor(client)
    with pytest.raises(ValueError):
        quad.set_command([0.0, float("nan"), 0.0], HOVER_N)
    with pytest.raises(ValueError):
        quad.set_command([0.0, 0.0, 0.0], float("inf"))
    with pytest.raises(ValueError):
        quad.set_command([0.0, 0.0], HOVER_N)


@pytest.mark.parametrize(("physics_hz", "ctrl_hz"), [(240, 48), (240, 60), (480, 80)])
def test_hover_holds_position(client: int, physics_hz: int, ctrl_hz: int) -> None:
    start = np.array([0.0, 0.0, 2.0])
    quad = Quadrotor(client, start_pos=start)
    _, states = _sim_loop(quad, client, 2.0, physics_hz, ctrl_hz, _const((0, 0, 0), HOVER_N))
    drift = max(float(np.linalg.norm(s.pos_m - start)) for s in states)
    assert drift < 0.05, f"hover drift {drift:.4f} m"


def test_roll_rate_step_tracked(client: int) -> None:
    quad = Quadrotor(client, start_pos=(0.0, 0.0, 2.0))
    t, states = _sim_loop(quad, client, 0.2, PHYSICS_HZ, CTRL_HZ, _const((1.0, 0, 0), HOVER_N))
    p_rate = np.array([s.body_rates_rps[0] for s in states])
    idx = np.flatnonzero(p_rate >= 0.9)
    assert idx.size > 0, f"max roll rate {p_rate.max():.3f}"
    rise_s = float(t[idx[0]])
    assert rise_s <= 0.1, f"90% rise time {rise_s:.3f} s"
    assert abs(p_rate[-1] - 1.0) < 0.1
    # no cross-coupling into q, r
    assert max(abs(s.body_rates_rps[1]) + abs(s.body_rates_rps[2]) for s in states) < 0.05


def test_yaw_rate_sign(client: int) -> None:
    quad = Quadrotor(client, start_pos=(0.0, 0.0, 2.0))
    _, states = _sim_loop(quad, client, 0.5, PHYSICS_HZ, CTRL_HZ, _const((0, 0, 1.0), HOVER_N))
    yaw = states[-1].euler_rpy_rad[2]
    assert yaw > 0.25, f"yaw {yaw:.3f} rad"  # counter-clockwise seen from above
    assert states[-1].body_rates_rps[2] > 0.8
    quad.reset((0.0, 0.0, 2.0), 0.0)
    _, states = _sim_loop(quad, client, 0.5, PHYSICS_HZ, CTRL_HZ, _const((0, 0, -1.0), HOVER_N))
    assert states[-1].euler_rpy_rad[2] < -0.25


def test_conventions_pitch_and_roll(client: int) -> None:
    """R = Rz Ry Rx: θ > 0 turns body x toward -z (nose down), body z toward +x.

    With ψ = 0 the thrust direction is R e3 = (sin θ cos φ, -sin φ, cos θ cos φ), so
    q > 0 -> θ > 0 -> a_x > 0 and p > 0 -> φ > 0 -> a_y < 0.
    """
    quad = Quadrotor(client, start_pos=(0.0, 0.0, 2.0))
    _sim_loop(quad, client, 0.25, PHYSICS_HZ, CTRL_HZ, _const((0, 1.0, 0), HOVER_N))
    s = quad.state()
    theta = s.euler_rpy_rad[1]
    assert 0.15 < theta < 0.3
    assert s.rotation[2, 0] < -0.1  # body x points down: nose down
    assert s.rotation[0, 2] > 0.1  # body z (thrust) leans toward +x
    thrust = 1.2 * HOVER_N / math.cos(theta)
    vx0 = s.vel_mps[0]
    assert vx0 > 0.0  # already accelerating forward while tilting with hover thrust
    _, states = _sim_loop(quad, client, 0.5, PHYSICS_HZ, CTRL_HZ, _const((0, 0, 0), thrust))
    s = states[-1]
    assert s.vel_mps[0] > 0.5 and s.vel_mps[2] > 0.0 and abs(s.vel_mps[1]) < 0.05
    # a_x = T/m · sin θ cos φ (= T/m · R[0, 2]) minus linear drag, integrated over the log
    prm = DEFAULT_PARAMS
    dv_expected = sum(
        (
            prm.kf_n_per_radps2 * float(np.sum(st.rotor_speeds_radps**2)) * st.rotation[0, 2]
            - prm.linear_drag_ns_per_m * st.vel_mps[0]
        )
        / prm.mass_kg
        / PHYSICS_HZ
        for st in states
    )
    assert s.vel_mps[0] - vx0 == pytest.approx(dv_expected, rel=0.03)

    quad.reset((0.0, 0.0, 2.0), 0.0)
    _sim_loop(quad, client, 0.25, PHYSICS_HZ, CTRL_HZ, _const((1.0, 0, 0), HOVER_N))
    phi = quad.state().euler_rpy_rad[0]
    assert phi > 0.15
    _, states = _sim_loop(quad, client, 0.5, PHYSICS_HZ, CTRL_HZ, _const((0, 0, 0), 1.2 * HOVER_N / math.cos(phi)))
    assert states[-1].vel_mps[1] < -0.5 and abs(states[-1].vel_mps[0]) < 0.05


def test_reference_controller_goto_and_land(client: int) -> None:
    quad = Quadrotor(client, start_pos=(0.0, 0.0, 2.0))
    ctrl = ReferencePositionController(DEFAULT_PARAMS)
    target = np.array([2.0, 1.0, 1.0])

    def goto(_t: float, s: QuadState) -> tuple[np.ndarray, float]:
        return ctrl.update(s.pos_m, s.vel_mps, s.quat_xyzw, target, target_yaw_rad=0.3)

    t, states = _sim_loop(quad, client, 6.0, PHYSICS_HZ, CTRL_HZ, goto)
    err = np.array([np.linalg.norm(s.pos_m - target) for s in states])
    outside = np.flatnonzero(err > 0.1)
    settle_s = float(t[outside[-1]]) if outside.size else 0.0
    assert err[-1] < 0.1 and settle_s <= 6.0 - 0.5, f"settle {settle_s:.2f} s"
    speeds = np.array([np.linalg.norm(s.vel_mps) for s in states])
    tilts = np.array([math.acos(np.clip(s.rotation[2, 2], -1, 1)) for s in states])
    assert speeds.max() < 2.0 * 1.15
    assert tilts.max() < math.radians(40.0)
    assert abs(states[-1].euler_rpy_rad[2] - 0.3) < 0.05

    land = np.array([2.0, 1.0, 0.05])

    def land_fn(_t: float, s: QuadState) -> tuple[np.ndarray, float]:
        return ctrl.update(s.pos_m, s.vel_mps, s.quat_xyzw, land, target_yaw_rad=0.3)

    _, states = _sim_loop(quad, client, 3.0, PHYSICS_HZ, CTRL_HZ, land_fn)
    tilts = np.array([math.acos(np.clip(s.rotation[2, 2], -1, 1)) for s in states])
    final = states[-1]
    assert final.pos_m[2] < 0.1
    assert np.linalg.norm(final.pos_m[:2] - land[:2]) < 0.1
    assert tilts.max() < math.radians(30.0)
    assert np.linalg.norm(final.vel_mps) < 0.05
