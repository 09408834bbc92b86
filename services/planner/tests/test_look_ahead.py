"""The forward camera's azimuth range and the look-before-flying rule."""

import math

import numpy as np
import pytest
from llmland_planner.look_ahead import must_turn_first, view_half_azimuth_rad
from llmland_schemas.camera import CameraIntrinsics


def _pitched_down(pitch_deg: float, yaw_rad: float = 0.0) -> np.ndarray:
    """Optical-frame pose (x right, y down, z forward) of a camera pitched down, heading ``yaw_rad``."""
    a = math.radians(pitch_deg)
    fwd = np.array([math.cos(a) * math.cos(yaw_rad), math.cos(a) * math.sin(yaw_rad), -math.sin(a)])
    right = np.array([math.sin(yaw_rad), -math.cos(yaw_rad), 0.0])
    t = np.eye(4)
    t[:3, :3] = np.column_stack([right, np.cross(fwd, right), fwd])
    return t


@pytest.mark.parametrize("yaw", [0.0, 1.0, -2.5])
def test_the_sim_forward_camera_sees_36_degrees_either_side_along_its_top_row(yaw):
    """90° wide, pitched 60° down: the top row (15° below the horizon) spans ±36.2° of azimuth,
    narrower than the image's ±45°, whatever the heading."""
    k = CameraIntrinsics.from_hfov(384, 384, 90.0)
    half = view_half_azimuth_rad(k, _pitched_down(60.0, yaw))
    assert math.degrees(half) == pytest.approx(36.2, abs=0.2)


def test_a_level_camera_sees_about_its_half_field_of_view():
    k = CameraIntrinsics.from_hfov(200, 100, 60.0)
    half = math.degrees(view_half_azimuth_rad(k, _pitched_down(0.0)))
    assert 25.0 < half < 30.0 + 1e-6  # the top row of a level camera bends inward a little


def test_must_turn_first():
    pos = np.array([0.0, 0.0, 3.0])
    behind, ahead, near = np.array([-3.0, 0.0, 3.0]), np.array([3.0, 0.5, 3.0]), np.array([-0.5, 0.0, 3.0])
    assert must_turn_first(pos, 0.0, behind, 0.6, 1.0)
    assert not must_turn_first(pos, math.pi, behind, 0.6, 1.0)  # facing it (through ±π)
    assert not must_turn_first(pos, 0.0, ahead, 0.6, 1.0)
    assert not must_turn_first(pos, 0.0, near, 0.6, 1.0)  # too near for a bearing
    assert not must_turn_first(pos, 0.0, behind, None, 1.0)  # no camera: nothing to wait for
    assert not must_turn_first(pos, 0.0, None, 0.6, 1.0)
    assert not must_turn_first(pos, 0.0, behind, 0.01, 1.0)  # no usable view: never wait for ever
