"""The downward camera's detection coverage: the point-count bound holds against brute-force
counting, and the radius is 0 where a person right below would be missed (the 160 px camera
the hard limit once relied on covered 6.9 m at 3.5 m by geometry, and its detector missed a
person right below; the closed-loop check against real renders is tests/test_down_coverage.py)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from llmland_planner.coverage import PersonTorso, _camera_points, detected_points_lower_bound, detection_radius_m
from llmland_planner.settings import PlannerSettings
from llmland_schemas import CameraIntrinsics
from scipy.spatial import ConvexHull

TORSO = PersonTorso()
WIDE = CameraIntrinsics.from_hfov(400, 400, 140.0)


def _lattice_points_in_torso_image(k: CameraIntrinsics, height_m: float, offset_m: float, tilt_rad: float,
                                   stride: int) -> int:
    """Brute force: sampled pixel centres inside the (sampled) torso image, by half-planes."""
    uv = k.project(_camera_points(offset_m, height_m, tilt_rad, TORSO))
    hull = uv[ConvexHull(uv).vertices]  # counter-clockwise
    us, vs = np.meshgrid(np.arange(0, k.width, stride, dtype=float), np.arange(0, k.height, stride, dtype=float))
    p = np.column_stack([us.ravel(), vs.ravel()])
    inside = np.ones(len(p), dtype=bool)
    for a, b in zip(hull, np.roll(hull, -1, axis=0), strict=True):
        inside &= (b[0] - a[0]) * (p[:, 1] - a[1]) - (b[1] - a[1]) * (p[:, 0] - a[0]) >= 0.0
    return int(inside.sum())


@settings(max_examples=60, deadline=None)
@given(height=st.floats(1.5, 8.0), offset=st.floats(0.0, 12.0), tilt=st.floats(-0.3, 0.3),
       stride=st.sampled_from([1, 2]), size=st.sampled_from([160, 320, 400]))
def test_the_bound_never_exceeds_the_pixels_on_the_torso(height: float, offset: float, tilt: float, stride: int,
                                                         size: int) -> None:
    k = CameraIntrinsics.from_hfov(size, size, 140.0)
    bound = detected_points_lower_bound(k, height, offset, tilt, stride, TORSO)
    assert bound <= _lattice_points_in_torso_image(k, height, offset, tilt, stride)


def test_the_count_falls_with_height_right_below() -> None:
    counts = [detected_points_lower_bound(WIDE, h, 0.0, 0.0, 1) for h in (2.0, 3.0, 4.0, 6.0)]
    assert counts == sorted(counts, reverse=True)
    assert counts[0] > 20.0


def test_the_radius_is_zero_where_someone_right_below_is_missed() -> None:
    # The old camera (160 px, stride 2, 20 points): a person right below at 3.5 m is 7-13 points.
    old = CameraIntrinsics.from_hfov(160, 160, 140.0)
    assert detection_radius_m(old, 3.5, 0.0, stride=2, min_points=20) == 0.0
    assert detection_radius_m(WIDE, 12.0, 0.0, stride=1, min_points=6) == 0.0
    assert detection_radius_m(WIDE, TORSO.top_m, 0.0, stride=1, min_points=6) == 0.0


def test_the_radius_at_the_hover_covers_the_descent() -> None:
    """With the default camera and detector, the hover at cruise altitude gives a radius that
    the untracked bound can use (more than 6 m), not more than the geometric horizon."""
    s = PlannerSettings()
    r = detection_radius_m(WIDE, s.cruise_altitude_m, 0.0, stride=s.down_blob_stride,
                           min_points=s.down_blob_min_points, torso=s.coverage_torso)
    horizon = (s.cruise_altitude_m - TORSO.bottom_m) * np.tan(np.radians(70.0))
    assert 6.0 < r <= horizon


def test_every_checked_offset_within_the_radius_passes() -> None:
    for h, tilt in ((3.2, 0.0), (3.5, 0.05), (4.0, 0.1)):
        r = detection_radius_m(WIDE, h, tilt, stride=1, min_points=6)
        for d in np.arange(0.0, r + 1e-9, 0.05):
            for sign in (1.0, -1.0):
                # h and tilt are table nodes: the radius is at most that node's; the scan checked the
                # fine steps only in the last coarse step, so this also checks the smoothness assumption
                assert detected_points_lower_bound(WIDE, h, float(d), sign * tilt, 1) >= 6.0


def test_more_demanding_detectors_cover_less() -> None:
    radii = [detection_radius_m(WIDE, 3.5, 0.0, stride=1, min_points=m) for m in (4, 6, 10, 40)]
    assert radii == sorted(radii, reverse=True)
    assert detection_radius_m(WIDE, 3.5, 0.2, stride=1, min_points=6) < radii[1]


def test_the_torso_must_stand_clear_of_the_ground_tolerance() -> None:
    with pytest.raises(ValueError, match="torso"):
        PlannerSettings(coverage_torso_bottom_m=0.2)
