"""One pybullet episode: world, vehicle, camera, scoring — no bus in here.

:class:`Simulation` is driven one control tick at a time by the service loop
(:mod:`llmland_sim.main`) or directly by tests and benchmarks.
"""

from __future__ import annotations

import logging
import time
from typing import TYPE_CHECKING

import numpy as np
import pybullet as p
from llmland_schemas import (
    CameraFrame,
    CameraFrameHeader,
    ControlCommand,
    EpisodeResult,
    GroundTruth,
    MissionGoal,
    TruthObject,
    VehicleState,
    encode_frame,
    vec3,
)

from .camera import RgbdCamera
from .renderer import release_renderer
from .scoring import TOUCHDOWN_HEIGHT_M, EpisodeScore
from .settings import SimSettings
from .vehicle import DEFAULT_PARAMS, QuadParams, Quadrotor, ReferencePositionController
from .world import World, WorldObject, build_world
from .world.scenarios import Scenario

if TYPE_CHECKING:
    from .perception_clock import PerceptionClock

log = logging.getLogger(__name__)

#: The downward camera looks straight down (optical axis = body -z) from just under the
#: body, so neither the body nor the arms are in view.
DOWN_CAMERA_PITCH_DEG = 90.0
DOWN_CAMERA_MOUNT_M = (0.0, 0.0, -0.04)


class Simulation:
    """A headless (or GUI) pybullet world with one quadrotor."""

    def __init__(self, settings: SimSettings, params: QuadParams = DEFAULT_PARAMS) -> None:
        self.settings = settings
        self.params = params
        self.client = p.connect(p.GUI if settings.gui else p.DIRECT)
        self.world: World | None = None
        self.quad: Quadrotor | None = None
        self.camera: RgbdCamera | None = None
        self.down_camera: RgbdCamera | None = None
        self.mission: MissionGoal | None = None
        self.scenario: Scenario | None = None
        self.score: EpisodeScore | None = None
        self._failsafe = ReferencePositionController(params)
        self._hold_target: np.ndarray | None = None
        self._last_cmd: ControlCommand | None = None
        self._last_cmd_t = 0.0
        self.t_s = 0.0
        self.seq = 0
        self._wall_start = 0.0
        self.done = False
        self._ended_by_stop = False

    # ------------------------------------------------------------------ episode
    def reset(self, mission: MissionGoal) -> None:
        """Build the mission's world from its seed and place the vehicle at the start."""
        s = self.settings
        p.resetSimulation(physicsClientId=self.client)
        p.setGravity(0, 0, -9.81, physicsClientId=self.client)
        p.setTimeStep(1.0 / s.physics_hz, physicsClientId=self.client)
        self.world = build_world(self.client, mission.world, mission.seed, n_pedestrians=mission.n_pedestrians)
        self.scenario = Scenario(mission.scenario, self.world, mission.seed) if mission.scenario else None
        start = np.asarray(mission.start_m if mission.start_m is not None else self.world.start_m, dtype=float)
        if mission.target_m is not None:
            self.world.target_m = np.asarray(mission.target_m, dtype=float)
        self.quad_start_m = start
        self.quad = Quadrotor(self.client, self.params, start_pos=tuple(start), start_yaw=0.0)
        self.quad.set_command(np.zeros(3), self.params.hover_thrust_n)
        if s.down_camera_hz > 0:
            self.down_camera = RgbdCamera(self.client, width=s.down_camera_size, height=s.down_camera_size,
                                          hfov_deg=s.down_camera_fov_deg, pitch_down_deg=DOWN_CAMERA_PITCH_DEG,
                                          mount_offset_m=DOWN_CAMERA_MOUNT_M, renderer=s.renderer)
        if s.camera_hz > 0:
            self.camera = RgbdCamera(self.client, width=s.camera_width, height=s.camera_height,
                                     pitch_down_deg=s.camera_pitch_down_deg, renderer=s.renderer)
        self.mission = mission
        self.score = EpisodeScore(target_m=np.asarray(self.world.target_m, dtype=float))
        self._classes = {o.obj_id: o.cls for o in self.world.objects}
        self._hold_target = self._failsafe_target(start)
        self._last_cmd = None
        self._last_cmd_t = 0.0
        self.t_s = 0.0
        self.seq = 0
        self._wall_start = time.perf_counter()
        self.done = False
        self._ended_by_stop = False
        log.info("episode %s: world=%s seed=%d start=%s target=%s", mission.episode_id, mission.world,
                 mission.seed, np.round(start, 2).tolist(), np.round(self.world.target_m, 2).tolist())

    def stop(self) -> None:
        """End the episode early (a stop command)."""
        self.done = True
        self._ended_by_stop = True

    # ------------------------------------------------------------------ stepping
    def apply_command(self, cmd: ControlCommand | None) -> bool:
        """Set the vehicle input for the next tick; returns True if the failsafe flew it.

        A missing command holds the previous one for ``command_hold_s``; after that the
        vehicle-side failsafe holds position where commands were lost, first climbing to
        ``failsafe_min_height_m`` over the ground if it is lower (:meth:`_failsafe_target`).
        """
        assert self.quad is not None and self.score is not None
        self.score.observe_command(cmd, 1e3 / self.settings.ctrl_hz)
        if cmd is not None:
            self._last_cmd, self._last_cmd_t = cmd, self.t_s
            self._hold_target = None
            self.quad.set_command(np.asarray(cmd.body_rates_rps), cmd.thrust_n)
            return False
        if self._last_cmd is not None and self.t_s - self._last_cmd_t <= self.settings.command_hold_s:
            return False
        st = self.quad.state()
        if self._hold_target is None:
            self._hold_target = self._failsafe_target(st.pos_m)
        rates, thrust = self._failsafe.update(st.pos_m, st.vel_mps, st.quat_xyzw, self._hold_target)
        self.quad.set_command(rates, thrust)
        return True

    def _failsafe_target(self, hold_m: np.ndarray) -> np.ndarray:
        """Where the failsafe flies ``(3,)`` to hold at ``hold_m (3,)``: that point, raised to
        ``failsafe_min_height_m`` over the ground under it (set once, when the hold begins).

        Without a planner the vehicle knows nothing about people, so it waits above their reach
        (a person's height plus the 1 m limit, with margin), as a flight controller's return
        mode climbs before it moves. Holding where commands were lost left a vehicle spawned at
        2.5 m hovering at head height for 25 s while a pedestrian passed within 0.996 m (Exp 1
        conservative seed 8 at 25135e6, the planner held up by the previous episode's search).
        Assumption: nothing overhead within the climb (open sky above the hold point).
        """
        assert self.world is not None
        target = np.array(hold_m, dtype=float)
        ground = self.world.ground_height(float(target[0]), float(target[1]))
        target[2] = max(float(target[2]), ground + self.settings.failsafe_min_height_m)
        return target

    def step(self) -> None:
        """Advance one control tick (``substeps`` physics steps), then score it."""
        assert self.quad is not None and self.world is not None and self.score is not None
        dt = 1.0 / self.settings.physics_hz
        for _ in range(self.settings.substeps):
            self.world.step_actors(dt)
            self.quad.apply_forces(dt)
            p.stepSimulation(physicsClientId=self.client)
            self.t_s += dt
        self.seq += 1
        if self.scenario is not None:
            st = self.quad.state()
            self.scenario.on_tick(st.pos_m, st.vel_mps)
        self._score_tick()
        if self.mission is not None and self.t_s >= self.mission.timeout_s:
            self.done = True

    def _score_tick(self) -> None:
        assert self.quad is not None and self.world is not None and self.score is not None
        st = self.quad.state()
        people = {o.obj_id: (self._base_of(o), float(o.size_m[2])) for o in self.world.people()}
        self.score.observe_people(st.pos_m, people)
        ground_contact = False
        for c in p.getContactPoints(bodyA=self.quad.body_id, physicsClientId=self.client):
            other = c[2]
            obj_id = self.world.body_to_object.get(other)
            cls = self._classes.get(obj_id, "ground") if obj_id else "ground"
            if cls in ("ground", "pad"):
                ground_contact = True
            else:
                self.score.observe_collision(obj_id or f"body_{other}")
        speed = float(np.linalg.norm(st.vel_mps))
        height = float(st.pos_m[2] - self.world.ground_height(st.pos_m[0], st.pos_m[1]))
        self.score.observe_ground(self.t_s, st.pos_m, speed, height, ground_contact)
        if self.score.finished:
            self.done = True

    @staticmethod
    def _base_of(obj: WorldObject) -> np.ndarray:
        centre = np.asarray(obj.position(), dtype=np.float64)
        return centre - np.array([0.0, 0.0, obj.size_m[2] / 2.0])

    # ------------------------------------------------------------------ messages
    def vehicle_state(self, *, camera_seq: int | None = None, down_camera_seq: int | None = None,
                      specs_released_upto_s: float | None = None) -> VehicleState:
        assert self.quad is not None and self.mission is not None and self.world is not None
        st = self.quad.state()
        height = st.pos_m[2] - self.world.ground_height(st.pos_m[0], st.pos_m[1])
        return VehicleState(
            drone_id=self.settings.drone_id,
            stamp=self.t_s,
            seq=self.seq,
            position_m=vec3(st.pos_m),
            velocity_mps=vec3(st.vel_mps),
            quat_xyzw=tuple(st.quat_xyzw),
            euler_rpy_rad=vec3(st.euler_rpy_rad),
            body_rates_rps=vec3(st.body_rates_rps),
            on_ground=bool(height < TOUCHDOWN_HEIGHT_M),
            collided=bool(self.score and self.score.collisions),
            episode_id=self.mission.episode_id,
            camera_seq=camera_seq,
            down_camera_seq=down_camera_seq,
            specs_released_upto_s=specs_released_upto_s,
        )

    def camera_frame(self) -> bytes:
        """Render the RGB-D camera and pack it with its typed header (wire bytes)."""
        frame = self.render_frame()
        return encode_frame(frame.header, frame.rgb, frame.depth_m)

    def render_frame(self, *, perceive: bool = True, camera: str = "forward") -> CameraFrame:
        """Render an RGB-D camera (``forward`` or ``down``): typed header + pixel arrays.

        ``perceive``: see :class:`CameraFrameHeader` (the downward camera is never perceived).
        """
        cam = self.camera if camera == "forward" else self.down_camera
        assert self.quad is not None and cam is not None and self.mission is not None
        st = self.quad.state()
        r = cam.render(st.pos_m, st.quat_xyzw, with_seg=False)
        k = r.intrinsics
        header = CameraFrameHeader(
            drone_id=self.settings.drone_id,
            stamp=self.t_s,
            seq=self.seq,
            width=k.width,
            height=k.height,
            intrinsics=k,
            T_world_camera=[float(x) for x in np.asarray(r.T_world_camera).reshape(-1)],
            vehicle_position_m=vec3(st.pos_m),
            episode_id=self.mission.episode_id,
            camera="forward" if camera == "forward" else "down",
            perceive=perceive and camera == "forward",
        )
        return CameraFrame(header=header, rgb=r.rgb, depth_m=r.depth_m.astype(np.float32))

    def truth(self) -> GroundTruth:
        assert self.world is not None and self.mission is not None
        objs = []
        for o in self.world.objects:
            objs.append(
                TruthObject(
                    obj_id=o.obj_id,
                    cls=o.cls,
                    position_m=vec3(o.position()),
                    velocity_mps=vec3(o.velocity()),
                    size_m=vec3(o.size_m),
                    dynamic=o.dynamic,
                    is_person=o.cls == "person",
                )
            )
        return GroundTruth(
            drone_id=self.settings.drone_id,
            stamp=self.t_s,
            seq=self.seq,
            world=self.world.name,
            target_m=vec3(self.world.target_m),
            objects=objs,
            episode_id=self.mission.episode_id,
        )

    def result(self, *, perception: PerceptionClock | None = None, rrd_path: str | None = None) -> EpisodeResult:
        """The episode's scored result (see :meth:`.scoring.EpisodeScore.result`)."""
        assert self.score is not None and self.mission is not None
        m = self.mission
        return self.score.result(
            aborted=self._ended_by_stop, perception=perception,
            drone_id=self.settings.drone_id, stamp=self.t_s, seq=self.seq, episode_id=m.episode_id, world=m.world,
            seed=m.seed, method=m.method, clock=m.clock, sim_time_s=self.t_s,
            wall_time_s=time.perf_counter() - self._wall_start, control_ticks=self.seq,
            latency_model=m.latency_model if m.perception != "none" else "", rrd_path=rrd_path,
        )

    def close(self) -> None:
        release_renderer(self.client)  # unload the EGL plugin, if one was loaded, before disconnecting
        try:
            p.disconnect(physicsClientId=self.client)
        except p.error:
            pass
