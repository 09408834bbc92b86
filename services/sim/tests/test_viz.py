"""Rerun recording of a landing: geometry helpers, and a short synthetic episode recorded
with ``SimRecorder`` and read back with the Rerun dataframe API (no bus, no pybullet)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import rerun as rr
from llmland_schemas import (
    CameraFrameHeader,
    CameraIntrinsics,
    Caption,
    CorridorPolytope,
    GroundTruth,
    LandingGate,
    ObjectSpec,
    PlanSnapshot,
    ReachDisc,
    SafetySpec,
    SafetySpecMessage,
    SceneDescription,
    SceneObject,
    TruthObject,
    UnsafeBox,
    VehicleState,
)
from llmland_schemas.frames import CameraFrame
from llmland_sim.viz import SimRecorder, paths
from llmland_sim.viz.corridors import polytope_edges
from llmland_sim.viz.perception import PerceivedObjects
from llmland_sim.viz.readback import column, has_blueprint, landing_problems, open_recording, seconds
from llmland_sim.viz.scene import GROUND_Z_M, drone_body, merged_regions

CTRL_DT_S = 0.02
TICKS = 150  # 3 s of flight
PERSON = TruthObject(obj_id="person_0", cls="person", position_m=(2.0, 1.0, 0.85), size_m=(0.3, 0.62, 1.7),
                     dynamic=True, is_person=True)
ROCK = TruthObject(obj_id="rock_0", cls="rock", position_m=(-2.0, 3.0, 0.25), size_m=(0.5, 0.5, 0.5))


def test_swept_slices_merge_into_one_box_per_id_clipped_at_the_ground() -> None:
    regions = [UnsafeBox(obj_id="t1", lo_m=(0, 0, -0.7), hi_m=(1, 1, 2), label="person", is_dynamic=True),
               UnsafeBox(obj_id="t1", lo_m=(0.5, 0.5, -0.7), hi_m=(2, 1.5, 2), label="person", is_dynamic=True),
               UnsafeBox(obj_id="t2", lo_m=(5, 5, -1), hi_m=(6, 6, -0.5), label="rock")]
    boxes = merged_regions(regions)
    assert set(boxes) == {"t1", "t2"}
    lo, hi, _ = boxes["t1"]
    np.testing.assert_allclose(lo, [0, 0, GROUND_Z_M])
    np.testing.assert_allclose(hi, [2, 1.5, 2])
    lo2, hi2, _ = boxes["t2"]
    assert lo2[2] == GROUND_Z_M and hi2[2] == GROUND_Z_M  # wholly underground: flat, never below


def test_unit_cube_corridor_has_twelve_edges() -> None:
    A = np.vstack([np.eye(3), -np.eye(3)])  # noqa: N806
    b = np.array([1, 1, 1, 0, 0, 0], dtype=float)
    edges = polytope_edges(A, b)
    assert len(edges) == 12
    lengths = [float(np.linalg.norm(e[1] - e[0])) for e in edges]
    np.testing.assert_allclose(lengths, 1.0, atol=1e-9)
    assert polytope_edges(A, np.array([1, 1, 1, -2, 0, 0], dtype=float)) == []  # empty polytope


def test_drone_body_is_a_hub_two_arms_and_four_rotors() -> None:
    body = drone_body()
    assert body.centers is not None and len(body.centers) == 7


def test_blob_takes_the_label_of_the_perceived_object_at_its_place() -> None:
    perceived = PerceivedObjects()
    perceived.on_spec(_spec(stamp=1.0))
    near = perceived.near(np.array([2.3, 1.2, 0.8]), t_s=1.5)
    assert near is not None and near.label == "person" and near.maybe_person
    assert "buffer 2.0 m" in near.describe() and "walking" in near.describe()
    assert perceived.near(np.array([9.0, 9.0, 0.0]), t_s=1.5) is None
    assert perceived.near(np.array([2.0, 1.0, 0.0]), t_s=60.0) is None  # forgotten
    assert perceived.human_buffer_m() == 2.0


def _spec(stamp: float) -> SafetySpecMessage:
    spec = SafetySpec(is_dynamic=True, is_human=True, z_min=2.0, buffer_m=2.0, label="person",
                      caption="a person walking on the grass")
    return SafetySpecMessage(stamp=stamp, frame_seq=1, scene=spec, latency_ms=420.0,
                             objects=[ObjectSpec(obj_id="blob_0", centroid_m=(2.0, 1.0, 0.85), size_m=(0.4, 0.6, 1.7),
                                                 spec=spec)])


def _state(k: int) -> VehicleState:
    t = k * CTRL_DT_S
    yaw = 0.3 * t
    pos = (-4.0 + 1.5 * t, 0.5 * t, 4.0 - 0.5 * t)
    return VehicleState(stamp=t, seq=k, position_m=pos, velocity_mps=(1.5, 0.5, -0.5),
                        quat_xyzw=(0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)), euler_rpy_rad=(0.0, 0.0, yaw),
                        body_rates_rps=(0.0, 0.0, 0.3))


def _frame(t: float, camera: str) -> CameraFrame:
    """A 64×64 camera looking straight down from 4 m at a 1.7 m tall block (a person)."""
    n, f = 64, 32.0
    k = CameraIntrinsics(fx=f, fy=f, cx=31.5, cy=31.5, width=n, height=n)
    # optical x right, y down, z forward → world: z forward = world -z, x right = world +x, y down = world -y
    T = np.array([[1, 0, 0, 2.0], [0, -1, 0, 1.0], [0, 0, -1, 4.0], [0, 0, 0, 1]], dtype=float)  # noqa: N806
    depth = np.full((n, n), 4.0, dtype=np.float32)
    depth[26:38, 26:38] = 4.0 - 1.7
    depth[:3, :] = np.inf  # no return: must not be drawn as 0
    header = CameraFrameHeader(stamp=t, seq=int(t * 10), width=n, height=n, intrinsics=k,
                               T_world_camera=T.reshape(-1).tolist(), camera=camera)  # type: ignore[arg-type]
    rgb = np.full((n, n, 3), 90, dtype=np.uint8)
    return CameraFrame(header=header, rgb=rgb, depth_m=depth)


def _plan(t: float, regions: list[UnsafeBox], mode: str, gate: LandingGate | None = None) -> PlanSnapshot:
    cube = CorridorPolytope(A=[(1, 0, 0), (0, 1, 0), (0, 0, 1), (-1, 0, 0), (0, -1, 0), (0, 0, -1)],
                            b=[1, 1, 5, 4, 1, 0])
    return PlanSnapshot(stamp=t, mode=mode, regions=regions, reference_m=[(-4, 0, 4), (0, 0, 3), (0, 0, 0)],
                        corridors=[cube], target_m=(0.0, 0.0, 0.0), gate=gate)


@pytest.fixture(scope="module")
def recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    rrd = tmp_path_factory.mktemp("rrd") / "episode.rrd"
    rec = SimRecorder("viz-test", rrd=rrd)
    person_box = [UnsafeBox(obj_id="t1", lo_m=(1.0, 0.0, -0.7), hi_m=(3.0, 2.0, 2.5), label="person", is_dynamic=True),
                  UnsafeBox(obj_id="t1", lo_m=(1.5, 0.5, -0.7), hi_m=(3.5, 2.5, 2.5), label="person", is_dynamic=True)]
    gate = LandingGate(open=True, duration_s=4.0, margin_m=0.4, binding="t1", coverage_m=6.0,
                       people=[ReachDisc(track_id="t1", label="person", centre_m=(2.0, 1.0, 0.0), radius_m=2.5)])
    for k in range(TICKS):
        t = k * CTRL_DT_S
        if k % 5 == 0:
            rec.truth(GroundTruth(stamp=t, world="test", target_m=(0.0, 0.0, 0.0), objects=[PERSON, ROCK]))
        if k % 10 == 0:
            rec.camera(_frame(t, "forward"))
            rec.camera_down(_frame(t, "down"))
        rec.state(_state(k))
        rec.mpc_solve(t, 3.0)
        if k == 10:
            rec.scene(SceneDescription(stamp=t, frame_seq=1, caption=Caption(text="a person in a field", backend="t"),
                                       objects=[SceneObject(obj_id="blob_0", centroid_m=(2.0, 1.0, 0.85),
                                                            size_m=(0.4, 0.6, 1.7), bbox_px=(26, 26, 38, 38),
                                                            caption=Caption(text="a person walking", backend="t"))]))
            rec.spec(_spec(stamp=t))
        if k == 20:
            rec.plan(_plan(t, person_box, "approach"))
        if k == 100:
            rec.plan(_plan(t, person_box, "descend", gate))
        if k == 120:
            rec.plan(_plan(t, [], "descend"))  # t1 gone: its box is cleared
    rec.close()
    return rrd


def test_path_points_are_the_drones_world_positions(recording: Path) -> None:
    with open_recording(recording) as r:
        t = r.table([paths.DRONE, paths.TRAJECTORY])
    poses = column(t, paths.DRONE, "InstancePoses3D:translations")
    strips = column(t, paths.TRAJECTORY, "LineStrips3D:strips")
    checked = 0
    for s, pose, strip in zip(seconds(t), poses, strips, strict=True):
        if strip is None:
            continue
        truth = np.asarray(_state(round(s / CTRL_DT_S)).position_m)
        np.testing.assert_allclose(pose[0], truth, atol=1e-3)
        np.testing.assert_allclose(strip[0][-1], truth, atol=0.01)  # the path ends where the drone is
        checked += 1
    assert checked >= 10


def test_recording_has_a_blueprint_every_design_path_and_nothing_below_ground(recording: Path) -> None:
    assert landing_problems(recording, semantic=True) == []


def test_blueprint_and_scene_entities_are_recorded(recording: Path) -> None:
    assert has_blueprint(recording)
    with open_recording(recording) as r:
        entities = r.entity_paths()
    for p in (paths.DRONE, paths.TRAJECTORY, paths.CORRIDORS, paths.REFERENCE, paths.CAMERA_RGB, paths.CAMERA_BLOBS,
              paths.CAMERA_DEPTH, paths.CAMERA_DOWN_RGB, paths.CAMERA_DOWN_BLOBS, paths.GATE_PEOPLE, paths.LOG_PHASE,
              paths.LOG_GATE, paths.LOG_SPECS, paths.LOG_CAPTIONS, paths.SCENE_CAPTION, paths.PLOT_SPEC_LATENCY,
              paths.PLOT_PERSON_CLOSEST, paths.PLOT_PERSON_BUFFER, "world/actors/person_0", "world/obstacles/rock_0",
              "world/unsafe/t1"):
        assert p in entities, p


def test_unsafe_box_is_one_labelled_box_above_ground_then_cleared(recording: Path) -> None:
    with open_recording(recording) as r:
        shown = r.table("/world/unsafe/**", at_s=[1.0])
        rows = r.table("/world/unsafe/**", clears=True)
    centres = column(shown, "world/unsafe/t1", "Boxes3D:centers")
    halves = column(shown, "world/unsafe/t1", "Boxes3D:half_sizes")
    labels = column(shown, "world/unsafe/t1", "Boxes3D:labels")
    assert len(centres[0]) == 1 and centres[0][0][2] - halves[0][0][2] >= GROUND_Z_M - 1e-6
    assert "person · buffer 2.0 m" in labels[0][0]
    boxes_at = [s for s, c in zip(seconds(rows), column(rows, "world/unsafe/t1", "Boxes3D:centers"), strict=True) if c]
    clears_at = [s for s, c in zip(seconds(rows), column(rows, "world/unsafe/t1", "Clear:is_recursive"), strict=True)
                 if c]
    assert clears_at and max(clears_at) > max(boxes_at)  # cleared once the planner dropped it


def test_blobs_are_labelled_and_depth_has_no_zeros(recording: Path) -> None:
    with open_recording(recording) as r:
        blobs = r.table(paths.CAMERA_BLOBS, at_s=[1.0])
        depth = r.table(paths.CAMERA_DEPTH, at_s=[1.0])
        rgb = r.table(paths.CAMERA_RGB, at_s=[1.0])
    labels = column(blobs, paths.CAMERA_BLOBS, "Boxes2D:labels")[0]
    assert labels and any("person" in x for x in labels)
    assert "/camera/rgb:EncodedImage:blob" in rgb.column_names  # JPEG, not raw pixels
    fmt = column(depth, paths.CAMERA_DEPTH, "DepthImage:format")[0][0]
    buf = np.frombuffer(bytes(column(depth, paths.CAMERA_DEPTH, "DepthImage:buffer")[0][0]), dtype=np.float16)
    assert fmt["width"] < 64 and np.isnan(buf).any() and not (buf == 0).any()


def test_problems_are_found_in_a_bad_recording(tmp_path: Path) -> None:
    """No blueprint, a path that is not where the drone is, a box under the ground."""
    rrd = tmp_path / "bad.rrd"
    rec = rr.RecordingStream("llmland-bad")
    rec.save(str(rrd))
    for k in range(3):
        rec.set_time(paths.TIMELINE, duration=0.1 * k)
        rec.log(paths.DRONE, rr.InstancePoses3D(translations=[(float(k), 0.0, 2.0)]))
        rec.log(paths.TRAJECTORY, rr.LineStrips3D([[(0.0, 0.0, 2.0), (float(k), 0.0, 4.0)]]))
    rec.log(paths.child(paths.UNSAFE, "t0"), rr.Boxes3D(centers=[(0.0, 0.0, 0.0)], half_sizes=[(1.0, 1.0, 0.7)]))
    rec.flush()
    rec.disconnect()
    problems = landing_problems(rrd, semantic=False)
    assert "no blueprint" in problems and "missing entity path world/plan/corridors" in problems
    assert any("is not the drone" in p for p in problems) and any("below the ground" in p for p in problems)
    assert not any("scene/caption" in p for p in problems)  # not asked of a baseline run
