"""Rerun logging for the simulator (entity paths of DESIGN §9), live or to an ``.rrd``.

The sim owns the richest view of an episode (world, actors, camera), so it also records
what the other services publish for display: plan snapshots (``world/plan/...``,
``world/unsafe/<id>``), scene captions and spec latencies. Time line: ``sim_time``.
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
import rerun as rr
from llmland_schemas import GroundTruth, PlanSnapshot, SafetySpecMessage, SceneDescription, VehicleState
from llmland_schemas.frames import CameraFrame

log = logging.getLogger(__name__)

CLASS_COLOURS: dict[str, tuple[int, int, int]] = {
    "person": (230, 60, 60),
    "vehicle": (60, 110, 230),
    "building": (150, 150, 150),
    "tree": (40, 140, 60),
    "bush": (80, 170, 80),
    "shed": (160, 110, 60),
    "rock": (120, 110, 100),
    "pad": (240, 200, 40),
}
TRAJECTORY_EVERY = 5  # log the accumulated trajectory every N states


class SimRecorder:
    """Logs one episode to Rerun. ``rrd`` may contain ``{episode_id}``."""

    def __init__(self, episode_id: str, *, rrd: Path | None = None, connect_url: str | None = None) -> None:
        self.rec = rr.RecordingStream("llmland", recording_id=episode_id)
        self.path: Path | None = None
        if rrd is not None:
            self.path = Path(str(rrd).format(episode_id=episode_id))
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self.rec.save(str(self.path))
        elif connect_url:
            self.rec.connect_grpc(connect_url)
        self._trajectory: list[tuple[float, float, float]] = []
        self._static_logged = False
        self.rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)

    # ------------------------------------------------------------------ world
    def truth(self, msg: GroundTruth) -> None:
        self.rec.set_time("sim_time", duration=msg.stamp)
        if not self._static_logged:
            self.rec.log(
                "world/target",
                rr.Points3D([msg.target_m], radii=0.15, colors=[(255, 200, 0)], labels=["target"]),
                static=True,
            )
        for o in msg.objects:
            colour = CLASS_COLOURS.get(o.cls, (200, 200, 200))
            half = np.asarray(o.size_m) / 2.0
            path = f"world/actors/{o.obj_id}" if o.dynamic else f"world/obstacles/{o.obj_id}"
            if o.dynamic or not self._static_logged:
                self.rec.log(
                    path,
                    rr.Boxes3D(centers=[o.position_m], half_sizes=[half], colors=[colour], labels=[o.cls]),
                    static=not o.dynamic,
                )
        self._static_logged = True

    def state(self, msg: VehicleState) -> None:
        self.rec.set_time("sim_time", duration=msg.stamp)
        self.rec.log(
            "world/drone",
            rr.Transform3D(translation=msg.position_m, quaternion=rr.Quaternion(xyzw=msg.quat_xyzw)),
        )
        self._trajectory.append(msg.position_m)
        if len(self._trajectory) % TRAJECTORY_EVERY == 1:
            self.rec.log(
                "world/drone/trajectory",
                rr.LineStrips3D([self._trajectory], colors=[(255, 140, 0)], radii=0.03),
            )
        self.rec.log("plot/altitude_m", rr.Scalars(msg.position_m[2]))

    def camera(self, frame: CameraFrame) -> None:
        h = frame.header
        self.rec.set_time("sim_time", duration=h.stamp)
        k = h.intrinsics
        self.rec.log("camera/rgb", rr.Image(frame.rgb))
        if frame.depth_m is not None:
            depth = np.where(np.isfinite(frame.depth_m), frame.depth_m, 0.0).astype(np.float32)
            self.rec.log("camera/depth", rr.DepthImage(depth, meter=1.0))
        self.rec.log(
            "world/camera",
            rr.Pinhole(focal_length=[k.fx, k.fy], principal_point=[k.cx, k.cy], resolution=[k.width, k.height]),
        )
        t = frame.T_world_camera
        self.rec.log("world/camera", rr.Transform3D(translation=t[:3, 3], mat3x3=t[:3, :3]))

    # ------------------------------------------------------------------ other services
    def plan(self, msg: PlanSnapshot) -> None:
        self.rec.set_time("sim_time", duration=msg.stamp)
        if msg.reference_m:
            self.rec.log("world/plan/reference", rr.LineStrips3D([msg.reference_m], colors=[(0, 200, 255)]))
        self.rec.log(
            "world/unsafe",
            rr.Boxes3D(
                centers=[(np.add(r.lo_m, r.hi_m) / 2).tolist() for r in msg.regions],
                half_sizes=[(np.subtract(r.hi_m, r.lo_m) / 2).tolist() for r in msg.regions],
                labels=[f"{r.obj_id}:{r.label}" for r in msg.regions],
                colors=[(255, 0, 0, 60)] * len(msg.regions),
            ),
        )
        if msg.search_ms is not None:
            self.rec.log("plot/search_ms", rr.Scalars(msg.search_ms))

    def scene(self, msg: SceneDescription) -> None:
        self.rec.set_time("sim_time", duration=msg.stamp)
        lines = [msg.caption.text] + [f"{o.obj_id}: {o.caption.text}" for o in msg.objects]
        self.rec.log("scene/caption", rr.TextDocument("\n".join(lines)))

    def spec(self, msg: SafetySpecMessage) -> None:
        self.rec.set_time("sim_time", duration=msg.stamp)
        self.rec.log("plot/spec_latency_ms", rr.Scalars(msg.latency_ms))

    def mpc_solve(self, t_s: float, solve_ms: float) -> None:
        self.rec.set_time("sim_time", duration=t_s)
        self.rec.log("plot/mpc_solve_ms", rr.Scalars(solve_ms))

    def close(self) -> None:
        if self._trajectory:
            self.rec.log("world/drone/trajectory", rr.LineStrips3D([self._trajectory], colors=[(255, 140, 0)]))
        self.rec.flush()
        self.rec.disconnect()
        log.info("rerun recording %s", self.path or "streamed")
