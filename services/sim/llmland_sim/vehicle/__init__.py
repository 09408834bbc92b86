"""Simulated quadrotor: parameters, rotor model, rate controller, reference pilot, pybullet body."""

from llmland_sim.vehicle.params import DEFAULT_PARAMS, GRAVITY_MPS2, QuadParams
from llmland_sim.vehicle.quadrotor import URDF_PATH, Quadrotor, QuadState, load_quadrotor_urdf
from llmland_sim.vehicle.rate_controller import RateController
from llmland_sim.vehicle.reference_controller import (
    ReferencePositionController,
    euler_zyx_to_rotmat,
    quat_to_rotmat,
    rotmat_to_euler_zyx,
)
from llmland_sim.vehicle.rotors import Mixer, RotorModel

__all__ = [
    "DEFAULT_PARAMS",
    "GRAVITY_MPS2",
    "URDF_PATH",
    "Mixer",
    "QuadParams",
    "QuadState",
    "Quadrotor",
    "RateController",
    "ReferencePositionController",
    "RotorModel",
    "euler_zyx_to_rotmat",
    "load_quadrotor_urdf",
    "quat_to_rotmat",
    "rotmat_to_euler_zyx",
]
