"""What the planner believes is around it: tracked depth obstacles plus their semantics.

Geometry comes from the depth image only (the planner is never told what an obstacle is by
the simulator). Semantics come from ``reasoner/spec`` messages, attached to tracks by
position. Each spec is applied at sim time ``frame stamp + measured latency`` (DESIGN §4),
so a slower reasoner delivers its spec later and the drone pays for it.

Unsafe regions (DESIGN §6):

- ``baseline``: every track gets one fixed margin; tracks that the tracker sees moving are
  swept along their measured velocity (same geometry as the semantic methods). Only the
  semantic methods, which know an obstacle is a person or a vehicle, let its buffer grow
  while it is out of view.
- semantic methods (``llm``, ``llm-land``): the spec's ``buffer_m`` and ``z_min``; dynamic
  classes (or measured motion) are swept over the horizon. A track with no spec yet, or
  whose spec is older than ``spec_stale_s``, gets the most conservative class.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from llmland_schemas import PERSON_BUFFER_M, PERSON_Z_MIN_M, SafetySpec, SafetySpecMessage
from llmland_schemas.depth import blobs_from_frame
from llmland_schemas.frames import CameraFrame

from .dynamics import FloatArray
from .regions import UnsafeRegion, from_obstacle
from .settings import PlannerSettings
from .tracking import ObstacleTracker, TrackedObstacle

log = logging.getLogger(__name__)


@dataclass
class PendingSpec:
    """A spec waiting for its sim-time release."""

    apply_at_s: float
    #: the source frame's stamp (s): in lockstep the sim says up to which stamp specs apply
    stamp_s: float
    position_m: FloatArray
    spec: SafetySpec
    #: horizontal radius (m) of the object: every track within it takes the spec
    radius_m: float = 0.0


def frustum_fn(frame: CameraFrame, max_range_m: float):  # type: ignore[no-untyped-def]
    """``visible(point_m) -> bool`` for the frame's camera (in image and within range)."""
    t_cw = np.linalg.inv(frame.T_world_camera)
    k = frame.header.intrinsics

    def visible(p: FloatArray) -> bool:
        q = t_cw[:3, :3] @ np.asarray(p, dtype=float) + t_cw[:3, 3]
        if q[2] <= 0.1 or q[2] > max_range_m:
            return False
        u, v = k.fx * q[0] / q[2] + k.cx, k.fy * q[1] / q[2] + k.cy
        return bool(0 <= u < k.width and 0 <= v < k.height)

    return visible


def more_careful(a: SafetySpec, b: SafetySpec) -> SafetySpec:
    """The spec asking more of the drone: dynamic first, then the larger buffer, then ``z_min``."""
    return b if (b.is_dynamic, b.buffer_m, b.z_min) > (a.is_dynamic, a.buffer_m, a.z_min) else a


class WorldModel:
    """Tracks + semantic specs → unsafe regions for one episode."""

    def __init__(self, settings: PlannerSettings, method: str) -> None:
        self.settings = settings
        self.method = method
        self.tracker = ObstacleTracker(gate_m=1.5, forget_after_s=2.0, predict_cap_s=settings.predict_cap_s,
                                       gate_growth_mps=settings.reach_speed_mps)
        self.pending: list[PendingSpec] = []
        self.specs_applied = 0
        self.spec_latencies_ms: list[float] = []
        self.version = 0  # bumps when tracks or specs change

    @property
    def semantic(self) -> bool:
        return self.method in ("llm", "llm-land")

    @property
    def blind_caution(self) -> bool:
        """``conservative``: geometry only, every obstacle treated as a person."""
        return self.method == "conservative"

    # ------------------------------------------------------------------ inputs
    def on_frame(self, frame: CameraFrame) -> None:
        if frame.depth_m is None:
            return
        blobs = blobs_from_frame(frame, stride=self.settings.blob_stride, max_range_m=self.settings.max_range_m)
        self.tracker.update(blobs, frame.header.stamp, visible_fn=frustum_fn(frame, self.settings.max_range_m))
        self.version += 1

    def on_spec(self, msg: SafetySpecMessage) -> None:
        """Queue the per-object specs for release at ``stamp + latency``."""
        if not self.semantic:
            return
        release = msg.stamp + msg.latency_ms / 1e3
        for obj in msg.objects:
            radius = 0.5 * max(obj.size_m[0], obj.size_m[1])
            self.pending.append(PendingSpec(release, msg.stamp, np.asarray(obj.centroid_m, dtype=float), obj.spec,
                                            radius))
        self.spec_latencies_ms.append(msg.latency_ms)

    def release_specs(self, t_s: float, released_upto_s: float | None = None, *, lockstep: bool = False) -> None:
        """Attach every spec whose time has come to the tracks at its position.

        Lockstep: the sim owns the latency model and says (``released_upto_s``) up to which
        frame stamp specs are in effect; realtime: at ``frame stamp + reported latency``.
        """
        if lockstep:
            def is_due(s: PendingSpec) -> bool:
                return released_upto_s is not None and s.stamp_s <= released_upto_s + 1e-9
        else:
            def is_due(s: PendingSpec) -> bool:
                return s.apply_at_s <= t_s
        due = [s for s in self.pending if is_due(s)]
        if not due:
            return
        self.pending = [s for s in self.pending if not is_due(s)]
        # One object may be several blobs (a tree's trunk and crown): every track within its
        # footprint takes its spec. One blob may be several objects (a person walking past a
        # rock): the track takes the most careful spec, never the last one in.
        batch: dict[str, tuple[TrackedObstacle, SafetySpec]] = {}
        for s in due:
            for track in self.tracker.match_all(s.position_m, max(self.settings.spec_match_m, s.radius_m)):
                prev = batch.get(track.track_id)
                batch[track.track_id] = (track, s.spec if prev is None else more_careful(prev[1], s.spec))
        for track, spec in batch.values():
            track.meta["spec"] = spec
            track.meta["spec_t"] = t_s
            self.specs_applied += 1
            self.version += 1

    # ------------------------------------------------------------------ output
    def spec_for(self, track: TrackedObstacle, t_s: float) -> SafetySpec:
        spec = track.meta.get("spec")
        if spec is None or t_s - float(track.meta.get("spec_t", -1e9)) > self.settings.spec_stale_s:
            return SafetySpec.conservative()
        return spec  # type: ignore[no-any-return]

    def regions(self, t_s: float) -> list[UnsafeRegion]:
        """Unsafe regions at sim time ``t_s`` (dynamic ones swept over the horizon).

        Reads only: release due specs first with :meth:`release_specs`.
        """
        s = self.settings
        out: list[UnsafeRegion] = []
        for tr in self.tracker.tracks():
            vel = tr.velocity_mps[:2]
            # Moving = fast enough now AND displaced from where it was first seen: a static
            # object seen from new angles shifts its visible centroid, but not by metres.
            origin = tr.centroid_m if tr.origin_m is None else tr.origin_m
            displaced = float(np.linalg.norm(tr.centroid_m[:2] - origin[:2])) > s.moving_displacement_m
            moving = displaced and float(np.linalg.norm(vel)) > s.moving_speed_mps
            if self.semantic:
                spec = self.spec_for(tr, t_s)
                buffer_m, z_min, label = spec.buffer_m, spec.z_min, spec.label
                dynamic = spec.is_dynamic or moving
            elif self.blind_caution:
                buffer_m, z_min, label, dynamic = PERSON_BUFFER_M, PERSON_Z_MIN_M, "person?", True
            else:
                buffer_m, z_min, label, dynamic = s.baseline_margin_m, 0.0, "obstacle", moving
            # Unseen for a while: extrapolate at most `predict_cap_s`, then let the
            # uncertainty grow at walking speed (a person out of view may be anywhere near).
            age = max(0.0, t_s - tr.last_seen_s)
            dt_pred = min(age, s.predict_cap_s)
            if dynamic and (self.semantic or self.blind_caution):  # a person/vehicle may walk in unseen
                buffer_m += min(s.unseen_growth_mps * (age - dt_pred), s.unseen_growth_max_m)
            shift = np.array([vel[0], vel[1], 0.0]) * dt_pred
            lo, hi = tr.lo_m + shift, tr.hi_m + shift
            centre = 0.5 * (lo + hi)
            radius = float(0.5 * np.hypot(hi[0] - lo[0], hi[1] - lo[1]))
            height = float(hi[2] - lo[2])
            boxes = from_obstacle(
                centre[:2], radius, height, buffer_m, z_min,
                velocity_xy=vel if moving else None,
                horizon_s=s.sweep_horizon_s if moving else 0.0,
                obj_id=tr.track_id, label=label, z_ground_m=float(lo[2]),
            )
            for box in boxes:
                box.is_dynamic = dynamic  # a standing person is still dynamic
            out += boxes
        return out
