"""``SimRecorder``: one episode to Rerun (DESIGN §9), live (``--connect``) or to an ``.rrd``.

The sim owns the richest view of an episode (world, actors, cameras), so it also records
what the other services publish for display: plan snapshots, scene captions and specs.
Every method is safe to call from the sim loop and from bus callbacks at once; the time
line is ``sim_time`` (each message's own stamp).
"""

from __future__ import annotations

import logging
import threading
from pathlib import Path

import numpy as np
import rerun as rr
from llmland_schemas import (
    PERSON_HARD_LIMIT_M,
    GroundTruth,
    PlanSnapshot,
    SafetySpecMessage,
    SceneDescription,
    UnsafeBox,
    VehicleState,
)
from llmland_schemas.frames import CameraFrame

from ..scoring import distance_to_person
from . import paths
from .blueprint import landing_blueprint, landing_eye
from .corridors import corridor_edges
from .files import compact_rrd, size_report
from .perception import DEPTH_PERIOD_S, PerceivedObjects, caption_line, log_frame, spec_line
from .scene import (
    CORRIDOR_COLOUR,
    DRONE_DRAW_SCALE,
    REFERENCE_COLOUR,
    PathLayer,
    UnsafeLayer,
    drone_body,
    log_gate,
    log_truth,
)

log = logging.getLogger(__name__)

#: file recordings: batch rows into chunks for this long (s) or this many bytes before writing
FILE_FLUSH_TICK_S = 1.0
FILE_FLUSH_BYTES = 2 * 1024 * 1024
FRUSTUM_DEPTH_M = 0.3
FRUSTUM_COLOUR = (90, 90, 90)
PHASE_COLOUR = (40, 170, 80)
GATE_CLOSED_TEXT_COLOUR = (220, 60, 60)
SERIES_STYLE = {
    paths.PLOT_PERSON_CLOSEST: ((230, 60, 60), "closest person"),
    paths.PLOT_PERSON_LIMIT: ((120, 120, 120), "1 m limit"),
    paths.PLOT_PERSON_BUFFER: ((255, 160, 0), "spec buffer"),
    paths.PLOT_ALTITUDE: ((0, 170, 255), "altitude"),
    paths.PLOT_SPEC_LATENCY: ((180, 90, 255), "spec latency"),
    paths.PLOT_MPC_SOLVE: ((60, 200, 120), "MPC solve"),
    paths.PLOT_SEARCH: ((200, 200, 60), "path search"),
}


class SimRecorder:
    """Logs one episode to Rerun. ``rrd`` may contain ``{episode_id}``."""

    def __init__(self, episode_id: str, *, rrd: Path | None = None, connect_url: str | None = None) -> None:
        self.path: Path | None = None
        batcher = None
        if rrd is not None:
            self.path = Path(str(rrd).format(episode_id=episode_id))
            self.path.parent.mkdir(parents=True, exist_ok=True)
            batcher = rr.ChunkBatcherConfig(flush_tick=FILE_FLUSH_TICK_S, flush_num_bytes=FILE_FLUSH_BYTES)
        self.rec = rr.RecordingStream("llmland", recording_id=episode_id, batcher_config=batcher)
        if self.path is not None:
            self.rec.save(str(self.path))
        elif connect_url:
            self.rec.connect_grpc(connect_url)
        self._lock = threading.Lock()
        self._closed = False
        self._path = PathLayer()
        self._unsafe = UnsafeLayer()
        self._perceived = PerceivedObjects()
        self._people: dict[str, tuple[np.ndarray, float]] = {}
        self._drone_m: np.ndarray | None = None
        self._start_m: np.ndarray | None = None
        self._target_m: tuple[float, float, float] | None = None
        self._truth_seen = False
        self._eye_sent = False
        self._next_depth_s = 0.0
        self._phase = ""
        self._gate_open: bool | None = None
        self._corridor_key: tuple[object, ...] | None = None
        self._t_s = 0.0
        self._static()

    def _static(self) -> None:
        rec = self.rec
        rec.send_blueprint(landing_blueprint())
        rec.log(paths.WORLD, rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        rec.log(paths.DRONE, drone_body(), static=True)
        for path, (colour, name) in SERIES_STYLE.items():
            rec.log(path, rr.SeriesLines(colors=[colour], names=[name], widths=[2.0]), static=True)

    def _time(self, t_s: float) -> None:
        self.rec.set_time(paths.TIMELINE, duration=t_s)

    # ------------------------------------------------------------------ world
    def truth(self, msg: GroundTruth) -> None:
        with self._lock:
            if self._closed:
                return
            self._time(msg.stamp)
            log_truth(self.rec, msg, first=not self._truth_seen)
            self._truth_seen = True
            self._target_m = msg.target_m
            self._people = {o.obj_id: (np.asarray(o.position_m) - [0.0, 0.0, o.size_m[2] / 2.0], o.size_m[2])
                            for o in msg.objects if o.is_person}
            if self._drone_m is not None and self._people:
                closest = min(distance_to_person(self._drone_m, base, h) for base, h in self._people.values())
                self.rec.log(paths.PLOT_PERSON_CLOSEST, rr.Scalars(closest))
                self.rec.log(paths.PLOT_PERSON_LIMIT, rr.Scalars(PERSON_HARD_LIMIT_M))
                buffer = self._perceived.human_buffer_m()
                if buffer is not None:
                    self.rec.log(paths.PLOT_PERSON_BUFFER, rr.Scalars(buffer))

    def state(self, msg: VehicleState) -> None:
        with self._lock:
            if self._closed:
                return
            self._time(msg.stamp)
            self._t_s = max(self._t_s, msg.stamp)
            self._drone_m = np.asarray(msg.position_m, dtype=float)
            if not self._eye_sent and self._target_m is not None:
                self.rec.send_blueprint(landing_blueprint(landing_eye(self._drone_m, np.asarray(self._target_m))))
                self._eye_sent = True
            self.rec.log(paths.DRONE, rr.InstancePoses3D(translations=[msg.position_m],
                                                         quaternions=[rr.Quaternion(xyzw=msg.quat_xyzw)],
                                                         scales=[[DRONE_DRAW_SCALE] * 3]))
            self._path.add(self.rec, msg.stamp, msg.position_m)
            self.rec.log(paths.PLOT_ALTITUDE, rr.Scalars(msg.position_m[2]))

    def camera(self, frame: CameraFrame) -> None:
        """The forward camera: image, blobs, a coarse depth image now and then, frustum."""
        with self._lock:
            if self._closed:
                return
            t = frame.header.stamp
            self._time(t)
            depth_due = t + 1e-9 >= self._next_depth_s
            if depth_due:
                self._next_depth_s = t + DEPTH_PERIOD_S
            log_frame(self.rec, frame, paths.CAMERA_RGB, paths.CAMERA_BLOBS, self._perceived,
                      depth_path=paths.CAMERA_DEPTH if depth_due else None)
            self._frustum(paths.CAMERA_FRUSTUM, frame)

    def camera_down(self, frame: CameraFrame) -> None:
        """The downward landing camera: image, blobs, frustum."""
        with self._lock:
            if self._closed:
                return
            self._time(frame.header.stamp)
            log_frame(self.rec, frame, paths.CAMERA_DOWN_RGB, paths.CAMERA_DOWN_BLOBS, self._perceived)
            self._frustum(paths.CAMERA_DOWN_FRUSTUM, frame)

    def _frustum(self, path: str, frame: CameraFrame) -> None:
        k = frame.header.intrinsics
        self.rec.log(path, rr.Pinhole(focal_length=[k.fx, k.fy], principal_point=[k.cx, k.cy],
                                      resolution=[k.width, k.height], image_plane_distance=FRUSTUM_DEPTH_M,
                                      color=FRUSTUM_COLOUR))
        t = frame.T_world_camera
        self.rec.log(path, rr.Transform3D(translation=t[:3, 3], mat3x3=t[:3, :3]))

    # ------------------------------------------------------------------ other services
    def plan(self, msg: PlanSnapshot) -> None:
        with self._lock:
            if self._closed:
                return
            self._time(msg.stamp)
            rec = self.rec
            if msg.reference_m:
                rec.log(paths.REFERENCE, rr.LineStrips3D([msg.reference_m], colors=[REFERENCE_COLOUR], radii=0.02))
            key = tuple((tuple(map(tuple, c.A)), tuple(c.b)) for c in msg.corridors)
            if key != self._corridor_key:
                self._corridor_key = key
                rec.log(paths.CORRIDORS, rr.LineStrips3D(corridor_edges(msg.corridors), colors=[CORRIDOR_COLOUR],
                                                         radii=0.01))
            self._unsafe.update(rec, msg.regions, self._describe_region)
            log_gate(rec, msg.gate, msg.target_m or self._target_m)
            if msg.mode != self._phase:
                rec.log(paths.LOG_PHASE, rr.TextLog(f"phase: {self._phase or 'start'} → {msg.mode}", level="INFO",
                                                    color=PHASE_COLOUR))
                self._phase = msg.mode
            gate = msg.gate
            if gate is not None and gate.open != self._gate_open:
                self._gate_open = gate.open
                rec.log(paths.LOG_GATE, rr.TextLog(
                    f"landing gate {'OPEN' if gate.open else 'closed'}: margin {gate.margin_m:.2f} m, "
                    f"{len(gate.people)} possible people, binding {gate.binding or 'coverage'}, "
                    f"descent {gate.duration_s:.1f} s", level="INFO" if gate.open else "WARN",
                    color=PHASE_COLOUR if gate.open else GATE_CLOSED_TEXT_COLOUR))
            if msg.search_ms is not None:
                rec.log(paths.PLOT_SEARCH, rr.Scalars(msg.search_ms))

    def _describe_region(self, region: UnsafeBox, centre_m: np.ndarray) -> tuple[str, bool]:
        p = self._perceived.near(centre_m, self._t_s)
        if p is None:
            return f"{region.obj_id}: {region.label}", False
        return f"{region.obj_id}: {p.describe()}", p.maybe_person

    def scene(self, msg: SceneDescription) -> None:
        with self._lock:
            if self._closed:
                return
            self._time(msg.stamp)
            self._perceived.on_scene(msg)
            lines = [msg.caption.text] + [f"{o.obj_id}: {o.caption.text}" for o in msg.objects]
            self.rec.log(paths.SCENE_CAPTION, rr.TextDocument("\n".join(lines)))
            self.rec.log(paths.LOG_CAPTIONS, rr.TextLog(caption_line(msg), level="DEBUG"))

    def spec(self, msg: SafetySpecMessage) -> None:
        with self._lock:
            if self._closed:
                return
            self._time(msg.stamp)
            self._perceived.on_spec(msg)
            self.rec.log(paths.PLOT_SPEC_LATENCY, rr.Scalars(msg.latency_ms))
            self.rec.log(paths.LOG_SPECS, rr.TextLog(spec_line(msg), level="INFO"))

    def mpc_solve(self, t_s: float, solve_ms: float) -> None:
        with self._lock:
            if self._closed:
                return
            self._time(t_s)
            self.rec.log(paths.PLOT_MPC_SOLVE, rr.Scalars(solve_ms))

    def close(self) -> None:
        """Finish the recording; a file is compacted into few large chunks."""
        with self._lock:
            self._closed = True
            self.rec.flush()
            self.rec.disconnect()
        if self.path is not None:
            compact_rrd(self.path)
            log.info("rerun recording %s: %s", self.path, size_report(self.path, self._t_s))
        else:
            log.info("rerun recording streamed")
