"""What the planner believes is around it: tracked depth obstacles, their semantics, and who may
be a person.

Geometry comes from the depth images only (the forward-down camera and the downward landing
camera; the simulator never tells the planner what an obstacle is): both cameras' blobs go to
one tracker (:mod:`.tracking`), which estimates velocity from consecutive views of the same
camera so the two views' different visible surfaces are not mistaken for motion. Semantics come from
``reasoner/spec`` messages attached to tracks by position; in lockstep a spec applies from the
tick the sim says it has arrived (DESIGN §4), in realtime at ``frame stamp + latency``.

Three views of the tracks, one per use (DESIGN §6):

- :meth:`WorldModel.regions` — the *semantic keep-out* for the path and the hover point:
  footprint inflated by the spec's buffer up to its ``z_min``; moving tracks swept along their
  predicted motion (constant velocity, no worst case). ``baseline``: one fixed margin for
  everything; ``conservative``: every obstacle a person. A track with no spec yet, or a stale
  one, gets the most conservative class.
- :meth:`WorldModel.landing_regions` — what the landing disc must stay clear of during a
  descent: moving vehicles and animals swept over the descent with their buffer, everything
  else its footprint plus ``landing_clearance_m`` (geometry; a parked car does not keep the pad
  closed, and people are the hard limit's).
- :meth:`WorldModel.people` — tracks that may be a person, for the hard limit
  (:mod:`.hard_limit`): a person or an unknown/stale class, anything dynamic the KB cannot vouch
  for, and anything that moves unless it is known to be a vehicle or animal. ``baseline`` only
  knows motion; ``conservative`` counts every obstacle.
"""

from __future__ import annotations

import logging
import math

import numpy as np
from llmland_schemas import PERSON_HARD_LIMIT_M, SEMANTIC_METHODS, CameraIntrinsics, SafetySpec, SafetySpecMessage
from llmland_schemas.arrays import FloatArray
from llmland_schemas.depth import Blob, backproject_planes, find_blobs
from llmland_schemas.frames import CameraFrame

from .ground import GroundMap, ReachFloor
from .hard_limit import PERSON_BODY_RADIUS_M, PERSON_MAX_HEIGHT_M, PersonHypothesis
from .look_ahead import view_half_azimuth_rad
from .regions import OVERFLY_CLEARANCE_M, POSSIBLE_PERSON, UNSEEN_TOP, UnsafeRegion, from_obstacle
from .settings import PlannerSettings
from .specs import AttachedSpec, PendingSpec, more_careful
from .track_views import (
    BLIND_CAUTION_METHOD,
    TrackView,
    is_moving,
    person_sized,
    says_person,
    spec_in_force,
    view_track,
)
from .tracking import ObstacleTracker, TrackedObstacle, VisibleFn

log = logging.getLogger(__name__)

#: every Nth of the blob points (each way) votes in the ground map
GROUND_POINT_STRIDE = 2
#: points nearer than this (m) in front of a camera are outside its view
FRUSTUM_NEAR_M = 0.1
#: frame stamps closer than this (s) are the same instant (sums of physics steps drift)
FRAME_SAME_INSTANT_S = 1e-9


def frustum_fn(frame: CameraFrame, max_range_m: float) -> VisibleFn:
    """``visible(point_m) -> bool`` for the frame's camera (in image and within range)."""
    t_cw = np.linalg.inv(frame.T_world_camera)
    k = frame.header.intrinsics

    def visible(p: FloatArray) -> bool:
        q = t_cw[:3, :3] @ np.asarray(p, dtype=float) + t_cw[:3, 3]
        if q[2] <= FRUSTUM_NEAR_M or q[2] > max_range_m:
            return False
        u, v = k.project(q)[0]
        return k.in_image(float(u), float(v))

    return visible


class WorldModel:
    """Tracks + semantic specs → unsafe regions and possible people, for one episode."""

    def __init__(self, settings: PlannerSettings, method: str, target_m: FloatArray | None = None) -> None:
        self.settings = s = settings
        self.method = method
        #: the landing target (3,): still obstacles' keep-out yields around it (see ``regions``)
        self.target_m = None if target_m is None else np.asarray(target_m, dtype=float)
        #: the terrain, estimated from the depth points (hills are ground, not obstacles)
        self.ground = None if self.target_m is None else GroundMap(self.target_m)
        self.tracker = ObstacleTracker(gate_m=s.track_gate_m, forget_after_s=s.track_forget_s,
                                       predict_cap_s=s.predict_cap_s, gate_growth_mps=s.human_max_speed_mps)
        self.pending: list[PendingSpec] = []
        #: per frame stamp and camera: its blobs, its frustum test and what the frame says of the
        #: camera (taken in at :meth:`ingest`, so a tick never sees a frame it has not ingested)
        self._views: dict[float, dict[str, tuple[list[Blob], VisibleFn, CameraFrame]]] = {}
        self.down_intrinsics: CameraIntrinsics | None = None  # known once a downward frame arrived
        #: half the forward camera's azimuth range (rad, :func:`~.look_ahead.view_half_azimuth_rad`)
        self.forward_half_azimuth_rad: float | None = None
        self.last_down_stamp_s: float | None = None
        #: the newest ingested downward frame's camera pose (4, 4) (``T_world_camera``): where the
        #: coverage it shows was seen from
        self.down_camera_pose: FloatArray | None = None
        self.specs_applied = 0
        self.spec_latencies_ms: list[float] = []
        self.version = 0  # bumps when tracks or specs change
        #: :meth:`views` of the last queried time, valid while the tracks and their specs stay
        #: as they were (one tick asks three times: keep-out, possible people, the landing disc)
        self._views_cache: tuple[tuple[float, int, int], list[TrackView]] | None = None
        self._track_copies: tuple[tuple[int, int], list[TrackedObstacle]] | None = None
        self._specs_revision = 0
        #: keep-out boxes of still tracks, by track and view, while the tracks and specs stay as
        #: they were (a still track's boxes do not depend on the time)
        self._still_regions: dict[tuple[str, float, float, str, bool, bool, bool], list[UnsafeRegion]] = {}
        self._still_regions_rev: tuple[int, int] = (-1, -1)
        self._still_landing: dict[tuple[str, bool, str], list[UnsafeRegion]] = {}
        self._still_landing_rev: tuple[int, int] = (-1, -1)

    @property
    def semantic(self) -> bool:
        return self.method in SEMANTIC_METHODS

    @property
    def blind_caution(self) -> bool:
        """``conservative``: geometry only, every obstacle treated as a person."""
        return self.method == BLIND_CAUTION_METHOD

    # ------------------------------------------------------------------ inputs
    def on_frame(self, frame: CameraFrame) -> None:
        """Depth blobs of one camera frame, held until :meth:`ingest` merges the instant's views."""
        if frame.depth_m is None:
            return
        s = self.settings
        down = frame.header.camera == "down"
        stride, min_points = ((s.down_blob_stride, s.down_blob_min_points) if down
                              else (s.blob_stride, s.blob_min_points))
        planes = backproject_planes(frame.depth_m, frame.header.intrinsics, frame.T_world_camera, stride)
        if self.ground is not None:  # the same ground-point density whatever the camera's stride
            step = max(1, GROUND_POINT_STRIDE * s.blob_stride // stride)
            self.ground.stage(frame.header.stamp, frame.header.camera,
                              np.moveaxis(planes[:, ::step, ::step], 0, -1))
        surface = self.ground.surface() if self.ground is not None else None  # one commit's heights
        blobs = find_blobs(frame.depth_m, frame.header.intrinsics, frame.T_world_camera, stride=stride,
                           min_points=min_points, max_range_m=s.max_range_m, ground_tol_m=s.ground_tolerance_m,
                           points_planes=planes, ground_height_fn=surface,
                           ground_floor_m=surface.lowest_m if surface is not None else None)
        view = (blobs, frustum_fn(frame, s.max_range_m), frame)
        self._views.setdefault(frame.header.stamp, {})[frame.header.camera] = view

    def ingest(self, t_s: float, *, lockstep: bool = False) -> None:
        """Track every frame up to ``t_s``, oldest instant first (downward view, then forward).

        ``lockstep``: only frames stamped *before* ``t_s``. The sim renders a tick's frames after
        publishing its state and names them in the next state (``llmland_sim.main``), so a frame
        stamped ``t_s`` may or may not have arrived when this tick runs; taking it would make
        what the planner knows depend on bus timing. The next tick takes it, every time. (Blobs
        are found on arrival against the ground committed so far; with cameras rendering on
        consecutive ticks, faster than half the control rate, a frame's blobs could then depend
        on whether the previous tick's commit came first. The sim's cameras render together at
        5 Hz, a frame period after the last commit.)
        """
        upto = t_s - FRAME_SAME_INSTANT_S if lockstep else t_s + FRAME_SAME_INSTANT_S
        for stamp in sorted(st for st in self._views if st <= upto):
            views = self._views.pop(stamp)
            for camera in sorted(views):  # "down" before "forward": the top view fixes positions
                blobs, visible, frame = views[camera]
                self.tracker.update(blobs, stamp, visible_fn=visible, source=camera)
                self._take_camera(frame)
            self.version += 1
        self.tracker.mark_moved(lambda tr: is_moving(tr, self.settings))
        if self.ground is not None:
            self.ground.commit(upto)

    def _take_camera(self, frame: CameraFrame) -> None:
        """What an ingested frame tells of its camera: the downward one's intrinsics, pose and
        freshness (the coverage radius), the forward one's azimuth range (look before flying)."""
        if frame.header.camera == "down":
            self.down_intrinsics = frame.header.intrinsics
            self.last_down_stamp_s = frame.header.stamp
            self.down_camera_pose = np.asarray(frame.T_world_camera, dtype=np.float64).reshape(4, 4)
        else:
            self.forward_half_azimuth_rad = view_half_azimuth_rad(frame.header.intrinsics, frame.T_world_camera)

    def on_spec(self, msg: SafetySpecMessage) -> None:
        """Queue the per-object specs for release."""
        if not self.semantic:
            return
        release = msg.stamp + msg.latency_ms / 1e3
        self.pending += [PendingSpec(release, msg.stamp, obj) for obj in msg.objects]
        self.spec_latencies_ms.append(msg.latency_ms)

    def release_specs(self, t_s: float, released_upto_s: float | None = None, *, lockstep: bool = False) -> None:
        """Attach every spec whose time has come to the tracks at its position: where each track
        was seen in the spec's frame (a moving thing has moved on by the time its spec arrives).

        Lockstep: the sim owns the latency model and says (``released_upto_s``) up to which
        frame stamp specs are in effect; realtime: at ``frame stamp + reported latency``.
        """
        if lockstep:
            def is_due(s: PendingSpec) -> bool:
                return released_upto_s is not None and s.stamp_s <= released_upto_s + FRAME_SAME_INSTANT_S
        else:
            def is_due(s: PendingSpec) -> bool:
                return s.apply_at_s <= t_s
        due = [s for s in self.pending if is_due(s)]
        if not due:
            return
        self._specs_revision += 1
        self.pending = [s for s in self.pending if not is_due(s)]
        # One object may be several blobs (a tree's trunk and crown): every track within its
        # footprint takes its spec. One blob may be several objects (a person walking past a
        # rock): the track takes the most careful spec, never the last one in. A spec reaching a
        # track only through a big object's footprint (not its own blob) may not make a
        # person-sized track less careful than it is: a hill or a crown around someone standing
        # there says nothing about them. Across releases a fresh person reading holds against a
        # neighbour's spec (_holds_a_person_reading).
        batch: dict[str, tuple[TrackedObstacle, SafetySpec]] = {}
        for s in due:
            matches = self.tracker.match_all(s.position_m, max(self.settings.spec_match_m, s.radius_m), s.stamp_s)
            nearest = min((d for _, d in matches), default=math.inf)
            for track, dist in matches:
                direct = dist <= self.settings.spec_match_m
                spec = s.spec
                if dist > nearest and self._holds_a_person_reading(track, spec, t_s):
                    continue  # a spec about the thing beside them (another track is nearer its position)
                log.debug("t=%.2f spec of frame %.2f (%s %r, %s) reaches %s at %.2f m (%s; height %.2f m, moved %s)",
                          t_s, s.stamp_s, s.obj.obj_id, spec.caption, spec.label, track.track_id, dist,
                          "its blob" if direct else "the object's footprint", track.height_m, track.has_moved)
                if not direct and person_sized(track, self.settings):
                    spec = more_careful(self.spec_for(track, t_s), spec)
                prev = batch.get(track.track_id)
                batch[track.track_id] = (track, spec if prev is None else more_careful(prev[1], spec))
        for track, spec in batch.values():
            track.spec = AttachedSpec(spec, t_s, track.height_m)
            self.specs_applied += 1
            self.version += 1

    def _holds_a_person_reading(self, track: TrackedObstacle, spec: SafetySpec, t_s: float) -> bool:
        """Whether ``track`` keeps its person reading against ``spec``, a spec about the thing beside
        it (another track is nearer the spec's position): a fresh reading that it may be a person
        (not stale, not the reasoner's fallback; :func:`.track_views.says_person`) is not replaced
        by a neighbour's spec that says otherwise. A later frame that captioned only the rock
        beside someone, its centroid within ``spec_match_m`` of their track too, turned the person
        into a rock. A spec about the track itself (it is the nearest) still replaces it: a misread
        corrected must not stay a person (holding every person reading against every later one
        kept VLE misreads of still things as people, and open_field seeds 26 and 41 timed out).
        """
        held = track.spec
        return (held is not None and says_person(held.spec) and held.spec.source != "fallback"
                and not says_person(spec) and t_s - held.applied_s <= self.settings.spec_stale_s)

    # ------------------------------------------------------------------ views
    def spec_for(self, track: TrackedObstacle, t_s: float) -> SafetySpec:
        """The track's spec in force at ``t_s`` (see :func:`.track_views.spec_in_force`)."""
        return spec_in_force(track, t_s, self.settings)

    def view(self, tr: TrackedObstacle, t_s: float) -> TrackView:
        """How the method sees one track at ``t_s`` (see :func:`.track_views.view_track`)."""
        return view_track(tr, t_s, self.method, self.settings)

    def views(self, t_s: float) -> list[TrackView]:
        """Every live track as the method sees it at ``t_s`` (track copies; computed once per time
        and state of the tracks and specs, so the list is shared: read it, do not change it)."""
        key = (t_s, self.tracker.revision, self._specs_revision)
        cached = self._views_cache
        if cached is not None and cached[0] == key:
            return cached[1]
        rev = key[1:]
        if self._track_copies is None or self._track_copies[0] != rev:
            # the copies change only with the tracks or their specs, not with time (5-10 Hz, not 50)
            self._track_copies = (rev, self.tracker.tracks())
        out = [self.view(tr, t_s) for tr in self._track_copies[1]]
        self._views_cache = (key, out)
        return out

    def _footprint(self, v: TrackView, t_pred_s: float) -> tuple[FloatArray, FloatArray, float, float]:
        """Centre (2,), footprint half sizes (2,) along x and y, height and ground z of a track moved
        ``t_pred_s`` along its velocity (m).

        A still thing keeps its seen bounds (a long building stays a long box: the square around its
        half diagonal would reach metres past its sides and may enclose the drone). A thing that
        may turn (:meth:`_may_turn`) gets the radius of its half diagonal, both ways. A side view
        that cut the object at the top leaves its height unknown: tall, unless its class bounds it
        (a person is never taller than :data:`PERSON_MAX_HEIGHT_M`).
        """
        tr = v.track
        centre = 0.5 * (tr.lo_m[:2] + tr.hi_m[:2]) + tr.velocity_mps[:2] * t_pred_s
        half = np.full(2, tr.half_diagonal_m) if self._may_turn(v) else tr.half_extent_m
        height = tr.height_m
        if v.human:
            height, half = min(height, PERSON_MAX_HEIGHT_M), np.maximum(half, PERSON_BODY_RADIUS_M)
        elif tr.touches_top:
            height = max(height, self.settings.max_altitude_m)
        return centre, half, height, float(tr.lo_m[2])

    def _may_turn(self, v: TrackView) -> bool:
        """Whether the track's footprint may rotate while the keep-out holds: it moves or has moved
        (a vehicle or an animal turns only while moving, and then its box is rebuilt every frame),
        or it may be a person standing (person-sized, or known to be one): people turn on the spot."""
        tr = v.track
        return v.moving or tr.has_moved or v.human or person_sized(tr, self.settings)

    def _yielding_buffer(self, v: TrackView, centre: FloatArray, half: FloatArray, buffer_m: float,
                         top_m: float) -> float:
        """The keep-out buffer (m) of a still thing that cannot be overflown, shrunk so that the
        landing disc stays outside it: the target is given, and a tree or a wall next to the pad
        must not make the hover point unreachable. Physical clearance at the pad is
        :meth:`landing_regions`' job, people the hard limit's."""
        s = self.settings
        if self.target_m is None or v.moving or v.possible_person or top_m < self.target_m[2] + s.cruise_altitude_m:
            return buffer_m
        return self._clear_of_disc(centre, half, buffer_m)

    def _clear_of_disc(self, centre: FloatArray, half: FloatArray, buffer_m: float) -> float:
        """``buffer_m`` shrunk so that the footprint grown by it leaves the landing disc outside."""
        if self.target_m is None:
            return buffer_m
        # the footprint's Chebyshev distance to the target: the box grown by b stays that far minus b
        gap = float(np.max(np.abs(self.target_m[:2] - centre) - half))
        return max(0.0, min(buffer_m, gap - self.settings.landing_disc_radius_m))

    def regions(self, t_s: float) -> list[UnsafeRegion]:
        """The semantic keep-out at ``t_s`` (path and hover point); reads only.

        A thing that has moved and was last seen more than ``moved_unseen_keepout_s`` ago is left
        out: its constant-velocity prediction stopped being trusted at ``predict_cap_s``, so a
        box there is a guess (a car seen for half a second at the start stood frozen between
        the drone and the pad for 30 s, urban seed 1 through the pipeline). What the path meets
        is in front of the drone, where the forward camera looks (yaw along the path); people
        near the pad are the hard limit's, which has its own bound for the unseen.
        """
        s = self.settings
        rev = (self.tracker.revision, self._specs_revision)
        if rev != self._still_regions_rev:
            self._still_regions, self._still_regions_rev = {}, rev
        out: list[UnsafeRegion] = []
        for v in self.views(t_s):
            tr = v.track
            if tr.has_moved and t_s - tr.last_seen_s > s.moved_unseen_keepout_s:
                continue  # somewhere else by now; where the path goes, the forward camera looks
            if v.moving:
                out += self._keepout(v, t_s)
                continue
            key = (tr.track_id, v.buffer_m, v.z_min, v.label, v.dynamic, v.possible_person, v.human)
            boxes = self._still_regions.get(key)
            if boxes is None:
                boxes = self._still_regions[key] = self._keepout(v, t_s)
            out += boxes
        return out

    def _keepout(self, v: TrackView, t_s: float) -> list[UnsafeRegion]:
        """One track's keep-out boxes at ``t_s`` (a still track's do not depend on ``t_s``)."""
        s, tr = self.settings, v.track
        dt_pred = min(max(0.0, t_s - tr.last_seen_s), s.predict_cap_s)
        centre, half, height, z0 = self._footprint(v, dt_pred if v.moving else 0.0)
        top = z0 + max(height + min(v.buffer_m, OVERFLY_CLEARANCE_M), v.z_min)
        buffer_m = self._yielding_buffer(v, centre, half, v.buffer_m, top)
        boxes = from_obstacle(centre, half, height, buffer_m, v.z_min,
                              velocity_xy=tr.velocity_mps[:2] if v.moving else None,
                              horizon_s=s.sweep_horizon_s if v.moving else 0.0,
                              obj_id=tr.track_id, label=v.label, z_ground_m=z0, is_dynamic=v.dynamic)
        if v.possible_person:
            for b in boxes:
                b.meta[POSSIBLE_PERSON] = 1.0
        if tr.touches_top and not v.moving and not v.human:
            # above what the side view saw, the thing may reach wider (a crown over its trunk); a
            # guess about a still thing, it yields to the landing disc whatever the class
            reach = self._clear_of_disc(centre, half, max(buffer_m, s.unseen_top_reach_m))
            # nothing above the seen top to guard when the keep-out ends there (a 0 m buffer):
            # the box would be flat, or upside down by a rounding (a tick failed on one, Exp 2
            # urban 12 at 893c7dc)
            if reach > buffer_m and top > float(tr.hi_m[2]):
                lo, hi = centre - half - reach, centre + half + reach
                boxes.append(UnsafeRegion(np.array([lo[0], lo[1], float(tr.hi_m[2])]), np.array([hi[0], hi[1], top]),
                                          tr.track_id, v.label, v.dynamic, reach, v.z_min, {UNSEEN_TOP: 1.0}))
        return boxes

    def landing_regions(self, t_s: float, duration_s: float) -> list[UnsafeRegion]:
        """What the landing disc must stay clear of for a descent of ``duration_s`` from ``t_s``.

        Moving things that are not possible people (vehicles, animals) with their buffer swept
        along their predicted motion; everything else its footprint plus
        ``landing_clearance_m``. Possible people are the hard limit's (:meth:`people`): its
        reachable sets already bound where they can be, whatever they do.
        """
        s = self.settings
        rev = (self.tracker.revision, self._specs_revision)
        if rev != self._still_landing_rev:
            self._still_landing, self._still_landing_rev = {}, rev
        out: list[UnsafeRegion] = []
        for v in self.views(t_s):
            tr = v.track
            if not v.moving:  # a still track's box does not depend on the time (built once per revision)
                key = (tr.track_id, v.human, v.label)  # with the revision, all _footprint reads
                boxes = self._still_landing.get(key)
                if boxes is None:
                    boxes = self._still_landing[key] = self._clearance_boxes(v, 0.0)
                out += boxes
                continue
            dt_pred = min(max(0.0, t_s - tr.last_seen_s), s.predict_cap_s)
            if v.possible_person:
                out += self._clearance_boxes(v, dt_pred)
                continue
            centre, half, height, z0 = self._footprint(v, dt_pred)
            out += from_obstacle(centre, half, height, v.buffer_m, v.z_min, velocity_xy=tr.velocity_mps[:2],
                                 horizon_s=duration_s, obj_id=tr.track_id, label=v.label, z_ground_m=z0)
        return out

    def _clearance_boxes(self, v: TrackView, t_pred_s: float) -> list[UnsafeRegion]:
        """The track's footprint ``t_pred_s`` ahead, grown by ``landing_clearance_m`` (one box)."""
        centre, half, height, z0 = self._footprint(v, t_pred_s)
        return from_obstacle(centre, half, height, self.settings.landing_clearance_m, 0.0, obj_id=v.track.track_id,
                             label=v.label, z_ground_m=z0)

    def unresolved(self, t_s: float) -> list[FloatArray]:
        """Footprint centres (2,) of the tracks whose class is unknown at ``t_s``: no spec yet, a
        stale one, or the reasoner's fallback (semantic methods; the geometric ones read no specs).

        They stand in the most careful class, whose keep-out is wide and high enough to block the
        way; the forward camera turns to them when no path is found (:meth:`.Planner._steer_yaw`),
        since a thing only the downward camera has seen is never captioned otherwise.
        """
        if not self.semantic:
            return []
        return [0.5 * (v.track.lo_m[:2] + v.track.hi_m[:2]) for v in self.views(t_s)
                if self.spec_for(v.track, t_s).source == "fallback"]

    def reach_floor(self, clearance_m: float) -> ReachFloor | None:
        """``clearance_m`` above the highest ground on which anyone within the hard limit (1 m)
        horizontally can stand (:meth:`.ground.GroundMap.reach_floor`); None without a target."""
        return None if self.ground is None else self.ground.reach_floor(PERSON_HARD_LIMIT_M, clearance_m)

    def people(self, t_s: float) -> list[PersonHypothesis]:
        """Every live possible person, with the age of their last observation (the hard limit's
        input; :func:`~llmland_planner.hard_limit.commit_clearance` decides which ones count: the
        recent ones, and older ones that cannot have left the coverage since)."""
        out: list[PersonHypothesis] = []
        for v in self.views(t_s):
            if not v.possible_person:
                continue
            tr = v.track
            centre = 0.5 * (tr.lo_m[:2] + tr.hi_m[:2])
            radius = max(tr.half_diagonal_m, PERSON_BODY_RADIUS_M)
            # one sighting gives no velocity (it reads 0): unknown, i.e. at the bound, not standing
            speed = float(np.linalg.norm(tr.velocity_mps[:2])) if tr.velocity_known else None
            out.append(PersonHypothesis(tr.track_id, centre, radius, speed, max(0.0, t_s - tr.last_seen_s), v.label))
        return out
