"""Simulated quadrotor: a pybullet rigid body driven by the rate controller + rotors.

Usage per control period (``ctrl_hz``) with ``n = physics_hz // ctrl_hz`` substeps::

    quad.set_command(body_rates_rps, thrust_n)   # zero-order hold until the next call
    for _ in range(n):
        quad.apply_forces(1.0 / physics_hz)      # pybullet clears external forces
        p.stepSimulation(physicsClientId=client) # after every step, so re-apply each time

Forces are applied in ``WORLD_FRAME`` at the base centre of mass (total thrust ``R @
[0, 0, T]`` plus linear drag), and the body torque (thrust moments + rotor reaction
torques) is rotated to world and applied with ``applyExternalTorque(WORLD_FRAME)``.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pybullet as p

from llmland_sim.vehicle.params import DEFAULT_PARAMS, QuadParams
from llmland_sim.vehicle.rate_controller import RateController
from llmland_sim.vehicle.reference_controller import quat_to_rotmat, rotmat_to_euler_zyx
from llmland_sim.vehicle.rotors import RotorModel

logger = logging.getLogger(__name__)

URDF_PATH = Path(__file__).resolve().parent.parent / "assets" / "quadrotor.urdf"


@dataclass(frozen=True)
class QuadState:
    """Snapshot of the vehicle state (all arrays are fresh copies)."""

    pos_m: np.ndarray  # (3,) world position of the centre of mass, m
    vel_mps: np.ndarray  # (3,) world-frame linear velocity, m/s
    quat_xyzw: np.ndarray  # (4,) attitude quaternion (x, y, z, w), body -> world
    euler_rpy_rad: np.ndarray  # (3,) ZYX Euler (roll, pitch, yaw), rad
    body_rates_rps: np.ndarray  # (3,) body-frame angular velocity (p, q, r), rad/s
    rotor_speeds_radps: np.ndarray  # (4,) rotor speeds, rad/s

    @property
    def rotation(self) -> np.ndarray:
        """Rotation matrix (3, 3), body -> world."""
        return quat_to_rotmat(self.quat_xyzw)


def load_quadrotor_urdf(
    client: int,
    params: QuadParams = DEFAULT_PARAMS,
    pos_m: tuple[float, float, float] | np.ndarray = (0.0, 0.0, 0.2),
    quat_xyzw: tuple[float, float, float, float] | np.ndarray = (0.0, 0.0, 0.0, 1.0),
) -> int:
    """Load ``assets/quadrotor.urdf`` into pybullet client ``client``; return the body id.

    The inertia is taken from the file (``URDF_USE_INERTIA_FROM_FILE``). Mass and
    inertia are checked against ``params``; on a mismatch (e.g. custom params) they are
    overridden with ``changeDynamics`` so the physics always matches ``params``.
    pybullet's default linear/angular damping is disabled (drag is modelled explicitly).
    """
    if not URDF_PATH.is_file():
        raise FileNotFoundError(f"quadrotor URDF not found at {URDF_PATH}")
    body_id = int(
        p.loadURDF(
            str(URDF_PATH),
            basePosition=list(map(float, pos_m)),
            baseOrientation=list(map(float, quat_xyzw)),
            flags=p.URDF_USE_INERTIA_FROM_FILE,
            physicsClientId=client,
        )
    )
    info = p.getDynamicsInfo(body_id, -1, physicsClientId=client)
    mass_urdf = float(info[0])
    inertia_urdf = np.asarray(info[2], dtype=float)
    inertia_want = np.asarray(params.inertia_diag_kgm2, dtype=float)
    if not math.isclose(mass_urdf, params.mass_kg, rel_tol=1e-6) or not np.allclose(
        inertia_urdf, inertia_want, rtol=1e-6
    ):
        logger.info(
            "URDF mass/inertia (%.4f kg, %s) differ from params (%.4f kg, %s); overriding",
            mass_urdf,
            inertia_urdf,
            params.mass_kg,
            inertia_want,
        )
        p.changeDynamics(
            body_id,
            -1,
            mass=params.mass_kg,
            localInertiaDiagonal=inertia_want.tolist(),
            physicsClientId=client,
        )
    p.changeDynamics(body_id, -1, linearDamping=0.0, angularDamping=0.0, physicsClientId=client)
    return body_id


class Quadrotor:
    """A quadrotor body in a pybullet client, commanded with body rates + thrust.

    Args:
        client: pybullet physics client id.
        params: vehicle constants.
        start_pos: initial centre-of-mass position (3,) world, m.
        start_yaw: initial heading ψ, rad.

    After construction / :meth:`reset` the rotors spin at hover speed and the held
    command is (zero rates, hover thrust), i.e. the vehicle is "spawned hovering".
    """

    def __init__(
        self,
        client: int,
        params: QuadParams = DEFAULT_PARAMS,
        start_pos: tuple[float, float, float] | np.ndarray = (0.0, 0.0, 0.2),
        start_yaw: float = 0.0,
    ) -> None:
        self.client = client
        self.params = params
        self.rate_controller = RateController(params)
        self.rotors = RotorModel(params)
        self._cmd_rates_rps = np.zeros(3)
        self._cmd_thrust_n = params.hover_thrust_n
        quat = p.getQuaternionFromEuler([0.0, 0.0, float(start_yaw)])
        self.body_id: int = load_quadrotor_urdf(client, params, start_pos, quat)
        self.reset(start_pos, start_yaw)

    # ------------------------------------------------------------------ commands
    def set_command(self, body_rates_rps: npt.ArrayLike, thrust_n: float) -> None:
        """Hold body rates (3,) rad/s (body frame) and collective thrust (N) until the next call.

        Rates are saturated to ±(6, 6, 3) rad/s and the thrust to ``[0, max_thrust_n]`` by
        the rate controller. Raises ``ValueError`` for a wrong shape or non-finite input.
        """
        rates = np.asarray(body_rates_rps, dtype=float).reshape(-1)
        if rates.shape != (3,):
            raise ValueError(f"body_rates_rps must have 3 elements, got shape {rates.shape}")
        thrust = float(thrust_n)
        if not (np.all(np.isfinite(rates)) and math.isfinite(thrust)):
            raise ValueError(f"non-finite command: rates={rates}, thrust={thrust}")
        self._cmd_rates_rps = rates.copy()
        self._cmd_thrust_n = thrust

    @property
    def command(self) -> tuple[np.ndarray, float]:
        """Currently held ``(body_rates_rps (3,), thrust_n)``."""
        return self._cmd_rates_rps.copy(), self._cmd_thrust_n

    # ------------------------------------------------------------------ physics
    def apply_forces(self, dt_s: float) -> None:
        """Run rate controller + rotor model for one physics substep and apply the wrench.

        Call once per substep immediately before ``p.stepSimulation()``; ``dt_s`` is the
        physics time step in s.
        """
        pos, quat = p.getBasePositionAndOrientation(self.body_id, physicsClientId=self.client)
        vel_w, omega_w = p.getBaseVelocity(self.body_id, physicsClientId=self.client)
        rot = quat_to_rotmat(np.asarray(quat))
        omega_b = rot.T @ np.asarray(omega_w, dtype=float)

        speed_cmd = self.rate_controller.update(self._cmd_rates_rps, self._cmd_thrust_n, omega_b, dt_s)
        self.rotors.step(speed_cmd, dt_s)
        thrust_n, torque_b = self.rotors.body_wrench()

        force_w = rot[:, 2] * thrust_n - self.params.linear_drag_ns_per_m * np.asarray(vel_w)
        torque_w = rot @ torque_b
        p.applyExternalForce(
            self.body_id,
            -1,
            force_w.tolist(),
            list(pos),
            p.WORLD_FRAME,
            physicsClientId=self.client,
        )
        p.applyExternalTorque(self.body_id, -1, torque_w.tolist(), p.WORLD_FRAME, physicsClientId=self.client)

    # ------------------------------------------------------------------ state
    def state(self) -> QuadState:
        """Current :class:`QuadState` read from pybullet."""
        pos, quat = p.getBasePositionAndOrientation(self.body_id, physicsClientId=self.client)
        vel_w, omega_w = p.getBaseVelocity(self.body_id, physicsClientId=self.client)
        q = np.asarray(quat, dtype=float)
        rot = quat_to_rotmat(q)
        return QuadState(
            pos_m=np.asarray(pos, dtype=float),
            vel_mps=np.asarray(vel_w, dtype=float),
            quat_xyzw=q,
            euler_rpy_rad=rotmat_to_euler_zyx(rot),
            body_rates_rps=rot.T @ np.asarray(omega_w, dtype=float),
            rotor_speeds_radps=self.rotors.speeds_radps.copy(),
        )

    def reset(
        self,
        pos: tuple[float, float, float] | np.ndarray = (0.0, 0.0, 0.2),
        yaw: float = 0.0,
    ) -> None:
        """Teleport to ``pos`` (3,) m with heading ``yaw`` rad, at rest, spawned hovering."""
        quat = p.getQuaternionFromEuler([0.0, 0.0, float(yaw)])
        p.resetBasePositionAndOrientation(self.body_id, list(map(float, pos)), quat, physicsClientId=self.client)
        p.resetBaseVelocity(self.body_id, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], physicsClientId=self.client)
        self.rate_controller.reset()
        self.rotors.reset()
        self._cmd_rates_rps = np.zeros(3)
        self._cmd_thrust_n = self.params.hover_thrust_n
