"""The planner pipeline for one episode, without the bus.

``tick(state)`` runs once per control tick: unsafe regions → landing phase → reference
(a searched path, or a straight descent) → corridors → one MPC QP → body rates + thrust.

Path search, plan adoption and path following are :mod:`.replanning`'s; the descent and
climb-out fly a vertical reference of :mod:`.descent`.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from dataclasses import dataclass

import numpy as np
from llmland_schemas import (
    MissionGoal,
    PlanSnapshot,
    SafetySpecMessage,
    VehicleState,
)
from llmland_schemas.arrays import FloatArray
from llmland_schemas.frames import CameraFrame

from .coverage import HEIGHT_STEP_M, TILT_STEP_RAD, detection_radius_m
from .dynamics import ModelParams
from .hard_limit import REACH_CEILING_M
from .landing import HOLD_LOST_M, LandingLogic, Phase, Surroundings
from .look_ahead import must_turn_first
from .mpc import MpcController, MpcResult
from .regions import UnsafeRegion
from .replanning import CORRIDOR_EXIT_M, Replanner
from .settings import PlannerSettings
from .snapshots import plan_snapshot
from .world_model import WorldModel

log = logging.getLogger(__name__)

#: the downward camera sits at most this far (m) below the body's centre (the sim's: 4 cm): a hold
#: height is chosen for a camera this much lower
DOWN_CAMERA_BELOW_BODY_MAX_M = HEIGHT_STEP_M

#: The MPC's soft floor sits this far (m) below the target: the ground, not the goal.
GROUND_FLOOR_MARGIN_M = 0.2
#: A plan snapshot (for displays) goes out at least this often (s) and on every phase change.
SNAPSHOT_PERIOD_S = 0.5
#: While holding, why the gate is closed is logged this often (s).
GATE_LOG_PERIOD_S = 5.0
#: Paths and holds keep this much (m) above the reach ceiling.
REACH_FLOOR_MARGIN_M = 0.1
#: A downward frame older than this (s) gives no coverage (the camera is off or stalled).
DOWN_FRAME_FRESH_S = 0.5
#: Holding: the forward camera turns toward possible people nearer than this (m).
YAW_ATTENTION_M = 12.0
#: Approaching: turn only toward a point farther than this (m); nearer, bearings are noise.
YAW_ALONG_PATH_MIN_M = 1.0
#: Approaching: the forward camera looks at the active path this far (m) ahead of the vehicle.
YAW_LOOK_AHEAD_M = 3.0


@dataclass
class TickOutput:
    body_rates_rps: FloatArray
    thrust_n: float
    mode: str
    mpc: MpcResult | None
    tick_ms: float
    snapshot: PlanSnapshot | None = None


class Planner:
    """One drone's planner. Not thread-safe except ``on_frame``/``on_spec`` vs ``tick``."""

    def __init__(self, settings: PlannerSettings | None = None, params: ModelParams | None = None) -> None:
        self.settings = s = settings or PlannerSettings()
        self._torso = s.coverage_torso  # built once: the coverage lookup runs every tick near the target
        self.params = params or ModelParams()
        self.mpc = MpcController(self.params, horizon=s.horizon, dt=s.mpc_dt_s, max_halfspaces=s.max_halfspaces)
        self.paths = Replanner(s)
        self._lock = threading.Lock()
        self.mission: MissionGoal | None = None
        self.world: WorldModel | None = None
        self.landing: LandingLogic | None = None
        self._yaw_ref = 0.0
        self._last_t = 0.0
        self._logged_phase: Phase | None = None
        self._logged_t = -1e9
        self._snap_phase: Phase | None = None
        self._snap_t = -1e9

    @property
    def _lockstep(self) -> bool:
        return self.mission is not None and self.mission.clock == "lockstep"

    # ------------------------------------------------------------------ episode inputs
    def start(self, mission: MissionGoal) -> None:
        assert mission.target_m is not None and mission.start_m is not None
        with self._lock:
            self.mission = mission
            self.paths.start(self._lockstep)
            self.world = WorldModel(self.settings, mission.method, np.asarray(mission.target_m, dtype=float))
            self.landing = LandingLogic(np.asarray(mission.target_m, dtype=float), self.settings)
            self._last_t = 0.0
            self._logged_phase, self._logged_t = None, -1e9
            self._snap_phase, self._snap_t = None, -1e9
            d = np.subtract(mission.target_m, mission.start_m)[:2]
            self._yaw_ref = float(math.atan2(d[1], d[0])) if np.linalg.norm(d) > YAW_ALONG_PATH_MIN_M else 0.0
            self.mpc.reset()
        log.info("planner: episode %s method=%s target=%s", mission.episode_id, mission.method, mission.target_m)

    def on_frame(self, frame: CameraFrame) -> None:
        """A camera frame of the running episode (one of another episode is dropped)."""
        with self._lock:
            episode = "" if self.mission is None else self.mission.episode_id
            if self.world is not None and frame.header.episode_id in ("", episode):
                self.world.on_frame(frame)

    def on_spec(self, msg: SafetySpecMessage) -> None:
        with self._lock:
            if self.world is not None:
                self.world.on_spec(msg)

    # ------------------------------------------------------------------ control tick
    def _surroundings(self, t: float, pos: FloatArray, tilt_rad: float) -> Surroundings:
        """The world model's views for the landing logic (called under the lock; the two functions
        it hands over run after it). The coverage radius is evaluated only if the landing logic or
        a display asks for it."""
        assert self.world is not None and self.landing is not None
        w, s = self.world, self.settings
        fresh = w.last_down_stamp_s is not None and t - w.last_down_stamp_s <= DOWN_FRAME_FRESH_S
        # the coverage is what the newest downward frame showed, from where that frame was taken
        # (its camera's height, its optical axis's tilt, its offset from the target), not from the
        # vehicle's pose at this tick: a frame taken lower or tilted more covers less
        cam = pos if w.down_camera_pose is None else w.down_camera_pose[:3, 3]
        if w.down_camera_pose is not None:  # the optical axis (camera z) from straight down
            tilt_rad = math.acos(min(1.0, max(-1.0, -float(w.down_camera_pose[2, 2]))))
        off_target = float(np.linalg.norm(cam[:2] - self.landing.target_m[:2]))
        intrinsics, height = w.down_intrinsics, float(cam[2] - self.landing.target_m[2])

        def radius(height_m: float, tilt: float) -> float:
            return 0.0 if intrinsics is None else detection_radius_m(
                intrinsics, height_m, tilt, stride=s.down_blob_stride, min_points=s.down_blob_min_points,
                torso=self._torso)

        def coverage() -> float:
            if not fresh or off_target >= HOLD_LOST_M:
                return 0.0
            # about the landing point: the radius around the vehicle less the vehicle's offset from it
            return max(0.0, radius(height, tilt_rad) - off_target)

        def coverage_at(height_m: float) -> float:
            """From a hover straight above the target (a hover's tilt: under one table step), the
            camera up to :data:`DOWN_CAMERA_BELOW_BODY_MAX_M` below the body: what the gate will get
            from that hover's frames (their camera's pose), or the hold it picks could never open."""
            return radius(height_m - DOWN_CAMERA_BELOW_BODY_MAX_M, TILT_STEP_RAD)

        age = 0.0 if w.last_down_stamp_s is None else max(0.0, t - w.last_down_stamp_s)
        return Surroundings(w.regions(t), w.people(t), coverage, lambda duration: w.landing_regions(t, duration),
                            coverage_age_s=age, reach_floor=w.reach_floor(REACH_CEILING_M + REACH_FLOOR_MARGIN_M),
                            coverage_at=coverage_at)

    def tick(self, state: VehicleState) -> TickOutput:
        t_tick = time.perf_counter()
        assert self.world is not None and self.landing is not None
        t = state.stamp
        pos, vel = np.asarray(state.position_m), np.asarray(state.velocity_mps)
        euler = np.asarray(state.euler_rpy_rad)
        with self._lock:
            self.world.ingest(t, lockstep=self._lockstep)
            self.world.release_specs(t, state.specs_released_upto_s, lockstep=self._lockstep)
            around = self._surroundings(t, pos, float(np.hypot(euler[0], euler[1])))
        phase, goal = self.landing.update(pos, vel, t, around)
        self._log_phase(phase, t, float(pos[2] - self.landing.target_m[2]), around)
        regions = around.regions
        ahead = self.paths.look_ahead_m(pos, YAW_LOOK_AHEAD_M) if phase == Phase.APPROACH else None
        self._steer_yaw(phase, t, pos, goal, around, ahead)
        hold = self.settings.look_before_flying and must_turn_first(
            pos, float(euler[2]), ahead, self.world.forward_half_azimuth_rad, YAW_ALONG_PATH_MIN_M)
        snapshot = None
        halfspaces = None
        if phase in (Phase.DESCEND, Phase.CLIMB_OUT, Phase.TOUCHDOWN) or (
                phase == Phase.HOLD and self.landing.lowered_hold):  # a lowered hold: straight down into it
            ref_pos, ref_vel = self._vertical_reference(phase, pos, vel, goal)
            self.paths.active = None
        else:
            floor_fn = around.reach_floor if self.landing.climbed else None
            if self.paths.maybe_replan(t, pos, vel, goal, regions, self._reach_floor(pos, around), floor_fn):
                snapshot = self._snapshot(t, regions, None)
            ref_pos, ref_vel, halfspaces = self.paths.reference(pos, hold=hold)
        if snapshot is None and (phase != self._snap_phase or t - self._snap_t >= SNAPSHOT_PERIOD_S):
            snapshot = self._snapshot(t, regions, around)
        if snapshot is not None:
            self._snap_phase, self._snap_t = phase, t
        if phase == Phase.TOUCHDOWN:
            return TickOutput(np.zeros(3), 0.0, phase.value, None, 1e3 * (time.perf_counter() - t_tick), snapshot)
        x0 = np.concatenate([pos, vel, euler])
        if phase in (Phase.DESCEND, Phase.CLIMB_OUT):
            z_floor = float(self.landing.target_m[2]) - GROUND_FLOOR_MARGIN_M  # the ground, not the goal
        else:  # approaching and holding: above everyone's reach, along the reference too
            z_floor = self._reach_floor(pos, around, ref_pos)
        yaw = float(state.euler_rpy_rad[2])
        yaw_ref = yaw + math.remainder(self._yaw_ref - yaw, 2.0 * math.pi)  # no unwinding through ±π
        res = self.mpc.solve(x0, ref_pos, ref_vel, yaw_ref, halfspaces, z_floor_m=z_floor)
        if halfspaces is not None and (not res.ok or res.max_slack > CORRIDOR_EXIT_M):
            # The corridors no longer fit the vehicle's state: an RTI step leaning on large
            # slacks is unreliable. Track the path without them and replan at once.
            self.paths.force_replan = True
            res = self.mpc.solve(x0, ref_pos, ref_vel, yaw_ref, None, z_floor_m=z_floor)
        mode = phase.value if res.ok else "fallback"
        return TickOutput(res.u0[:3].copy(), float(res.u0[3]), mode, res,
                          1e3 * (time.perf_counter() - t_tick), snapshot)

    def _log_phase(self, phase: Phase, t: float, height_m: float, around: Surroundings) -> None:
        """Phase changes, and every ``GATE_LOG_PERIOD_S`` while holding why the gate is closed
        (``height_m``: the vehicle's height above the target)."""
        if self.landing is None:
            return
        gate = self.landing.last_gate
        changed = phase != self._logged_phase
        if not changed and not (phase == Phase.HOLD and t - self._logged_t >= GATE_LOG_PERIOD_S):
            return
        self._logged_phase, self._logged_t = phase, t
        if gate is None:
            log.info("t=%.1f %s", t, phase.value)
            return
        who = next((p for p in around.people if p.track_id == gate.clearance.track_id), None)
        if gate.clearance.track_id == "":
            binding = f"untracked people (coverage {around.coverage_m:.1f} m)"
        elif who is not None:
            dist = float(np.linalg.norm(who.centre_xy[:2] - self.landing.target_m[:2]))
            binding = f"{who.label or 'unknown'} {who.track_id} at {dist:.1f} m"
        else:
            binding = "nobody"
        log.info("t=%.1f %s at %.1f m: hard-limit margin %.2f m (%s), landing disc %s, %d possible people", t,
                 phase.value, height_m, gate.clearance.margin_m, binding, "clear" if gate.disc_clear else "blocked",
                 len(around.people))

    def _reach_floor(self, pos: FloatArray, around: Surroundings, ref_pos: FloatArray | None = None) -> float:
        """Lowest altitude (m) for paths and holds outside the final descent: above everyone's reach
        (the reach floor over the terrain, :meth:`.world_model.WorldModel.reach_floor`) at the
        vehicle and along ``ref_pos (N+1, 3)`` if given; for paths (no ``ref_pos``), the floor's
        minimum, the search reading the floor itself point by point. During the take-off climb
        (and only then) where the vehicle is, below it.

        Once the vehicle has climbed, the floor never follows it down: a vehicle that sagged under
        the floor (tracking error against the soft MPC floor) got a floor under itself for its next
        paths and holds, whose tracking errors lowered it again. In Exp 2 at 36cb619 four llm-land
        approaches sank this way to 2.68–2.85 m, within a person's reach, 7–8 m from the target
        (open_field seed 4: 3.19 → 2.68 m in 2.4 s)."""
        assert self.landing is not None
        flat = float(self.landing.target_m[2]) + REACH_CEILING_M + REACH_FLOOR_MARGIN_M
        floor_fn = around.reach_floor
        here = flat if floor_fn is None else float(floor_fn(pos[:2]))
        if not self.landing.climbed:
            return min(here, float(pos[2]) - REACH_FLOOR_MARGIN_M)
        if floor_fn is None:
            return flat
        if ref_pos is None:
            return floor_fn.lowest_m
        return max(here, float(np.max(floor_fn(np.asarray(ref_pos)[:, :2]))))

    def _vertical_reference(self, phase: Phase, pos: FloatArray, vel: FloatArray,
                            goal: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Straight down the descent profile, or straight up or down to the hold point at the climb
        speed (``(N+1, 3)`` each)."""
        assert self.landing is not None
        n, dt = self.settings.horizon, self.settings.mpc_dt_s
        ground = float(self.landing.target_m[2])
        if phase == Phase.DESCEND:
            h, sink = self.landing.profile.reference(float(pos[2]) - ground, max(0.0, -float(vel[2])), dt, n + 2)
            z, vz = ground + h[1:], -sink[1:]
        else:
            climb, z0, z_goal = self.settings.climb_speed_mps, float(pos[2]), float(goal[2])
            direction = 1.0 if z_goal >= z0 else -1.0
            z = z0 + direction * np.minimum(climb * dt * np.arange(1, n + 2), abs(z_goal - z0))
            vz = np.where(np.abs(z - z_goal) > 1e-9, direction * climb, 0.0)
        ref_pos = np.column_stack([np.full(n + 1, goal[0]), np.full(n + 1, goal[1]), z])
        ref_vel = np.column_stack([np.zeros(n + 1), np.zeros(n + 1), vz])
        return ref_pos, ref_vel

    def _steer_yaw(self, phase: Phase, t: float, pos: FloatArray, goal: FloatArray, around: Surroundings,
                   ahead: FloatArray | None) -> None:
        """Where the forward camera looks: along the active path while approaching (with no path, at
        the nearest thing of unknown class, else at the goal); while holding, at the nearest
        possible person (their class stays fresh), else turning slowly to see all around.
        ``ahead (3,)``: the active path's point ahead (:meth:`.Replanner.look_ahead_m`), None
        without a plan."""
        s = self.settings
        dt = max(0.0, t - self._last_t)
        self._last_t = t
        if phase in (Phase.DESCEND, Phase.TOUCHDOWN, Phase.CLIMB_OUT):
            return
        if phase == Phase.APPROACH:
            # Along the path, not at the goal: a detour can lead away from the goal (even
            # backwards), and the vehicle must see what it flies into (look_ahead.py). With no
            # path, at the nearest thing of unknown class: its careful keep-out may be what
            # blocks the way, and only the forward camera's frames are captioned.
            if ahead is None:
                ahead = self._nearest_unresolved(t, pos)
            d = (goal if ahead is None else ahead)[:2] - pos[:2]
            if float(np.linalg.norm(d)) > YAW_ALONG_PATH_MIN_M:
                self._turn_toward(math.atan2(float(d[1]), float(d[0])), s.hold_yaw_rate_rps * dt)
            return
        near = [p for p in around.people if float(np.linalg.norm(p.centre_xy[:2] - pos[:2])) <= YAW_ATTENTION_M]
        if near:
            c = min(near, key=lambda p: float(np.linalg.norm(p.centre_xy[:2] - pos[:2]))).centre_xy
            self._turn_toward(math.atan2(float(c[1] - pos[1]), float(c[0] - pos[0])), s.hold_yaw_rate_rps * dt)
        else:
            self._yaw_ref += s.scan_yaw_rate_rps * dt

    def _nearest_unresolved(self, t: float, pos: FloatArray) -> FloatArray | None:
        """The nearest footprint centre (2,) of unknown class within ``YAW_ATTENTION_M``, farther than
        ``YAW_ALONG_PATH_MIN_M`` (a bearing to something right below is noise); None if there is none."""
        assert self.world is not None
        dists = [(float(np.linalg.norm(c - pos[:2])), c) for c in self.world.unresolved(t)]
        near = [(d, c) for d, c in dists if YAW_ALONG_PATH_MIN_M < d <= YAW_ATTENTION_M]
        return min(near, key=lambda dc: dc[0])[1] if near else None

    def _turn_toward(self, heading: float, max_step: float) -> None:
        err = math.remainder(heading - self._yaw_ref, 2.0 * math.pi)
        self._yaw_ref += float(np.clip(err, -max_step, max_step))

    def _snapshot(self, t: float, regions: list[UnsafeRegion], around: Surroundings | None) -> PlanSnapshot:
        assert self.mission is not None
        act = self.paths.active
        return plan_snapshot(self.settings.drone_id, self.mission.episode_id, t, self.landing, regions, around,
                             act.path if act else None, act.corridors if act else [], act.search_ms if act else None)
