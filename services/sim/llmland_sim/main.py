"""``llmland-sim``: the pybullet quadrotor world as a Zenoh service.

Subscribes ``llmland/<d>/mission`` (MissionGoal) and ``llmland/<d>/planner/command``
(ControlCommand); publishes ``sim/state`` each control tick, ``sim/camera`` at
``camera_hz``, ``sim/truth`` at ``truth_hz`` and ``episode/result`` at the end.

Clock modes (DESIGN §4): ``lockstep`` publishes each tick's state and waits, bounded by
``lockstep_timeout_s``, for the command echoing its ``seq`` (a miss, or a command whose
controller compute time `tick_ms` exceeded the control period, is counted and the
vehicle holds its last input, then holds position); ``realtime`` paces ticks to the wall
clock and applies the newest command.
"""

from __future__ import annotations

import logging
import queue
import threading
import time
from pathlib import Path

from llmland_schemas import (
    ControlCommand,
    MissionGoal,
    PlanSnapshot,
    SafetySpecMessage,
    SceneDescription,
    Topic,
    alive,
    key,
)
from llmland_schemas.bus import Bus
from llmland_schemas.frames import encode_frame
from llmland_schemas.service import configure_logging, shutdown_event

from .mailbox import CommandMailbox
from .settings import SimSettings
from .simulation import Simulation
from .viz import SimRecorder

log = logging.getLogger("llmland.sim")


class SimService:
    """Runs episodes as missions arrive."""

    def __init__(self, settings: SimSettings, bus: Bus, stop: threading.Event) -> None:
        self.settings = settings
        self.bus = bus
        self.stop = stop
        self.sim = Simulation(settings)
        self.missions: queue.Queue[MissionGoal] = queue.Queue()
        self.commands = CommandMailbox()
        self.recorder: SimRecorder | None = None
        self.current: MissionGoal | None = None
        self.spec_latencies_ms: list[float] = []
        d = settings.drone_id
        self.k = {t: key(d, t) for t in Topic}
        bus.subscribe(self.k[Topic.MISSION], MissionGoal, self._on_mission)
        bus.subscribe(self.k[Topic.COMMAND], ControlCommand, lambda _k, m: self.commands.put(m))
        bus.subscribe(self.k[Topic.PLAN], PlanSnapshot, lambda _k, m: self._record("plan", m))
        bus.subscribe(self.k[Topic.SCENE], SceneDescription, lambda _k, m: self._record("scene", m))
        bus.subscribe(self.k[Topic.SPEC], SafetySpecMessage, self._on_spec)
        bus.announce(alive(d, "sim"))

    def _on_mission(self, _key: str, msg: MissionGoal) -> None:
        if msg.command == "stop":
            if self.current is not None and msg.episode_id in (self.current.episode_id, "*"):
                self.sim.stop()
            return
        if self.current is not None and self.current.episode_id == msg.episode_id:
            return  # a repeated start for the running episode
        self.missions.put(msg)

    def _on_spec(self, _key: str, msg: SafetySpecMessage) -> None:
        if self.current is not None and msg.episode_id == self.current.episode_id:
            self.spec_latencies_ms.append(msg.latency_ms)
        self._record("spec", msg)

    def _record(self, kind: str, msg: object) -> None:
        rec = self.recorder
        if rec is None or self.current is None or getattr(msg, "episode_id", "") not in ("", self.current.episode_id):
            return
        getattr(rec, kind)(msg)

    def serve(self) -> None:
        log.info("sim ready (drone %s, physics %d Hz, control %d Hz)", self.settings.drone_id,
                 self.settings.physics_hz, self.settings.ctrl_hz)
        seen: set[str] = set()
        while not self.stop.is_set():
            try:
                mission = self.missions.get(timeout=0.2)
            except queue.Empty:
                continue
            if mission.episode_id in seen:
                continue
            seen.add(mission.episode_id)
            self.run_episode(mission)

    def run_episode(self, mission: MissionGoal) -> None:
        s, sim, bus = self.settings, self.sim, self.bus
        self.commands.clear()
        self.spec_latencies_ms = []
        sim.reset(mission)
        assert sim.world is not None
        # Tell everyone the resolved mission (start and target filled from the world).
        mission = mission.model_copy(update={
            "start_m": tuple(float(x) for x in sim.quad_start_m),
            "target_m": tuple(float(x) for x in sim.world.target_m),
        })
        sim.mission = mission
        self.current = mission
        bus.publish(self.k[Topic.MISSION], mission)
        rrd = mission.rrd_path or s.rrd
        if rrd is not None or s.rerun_connect:
            self.recorder = SimRecorder(mission.episode_id, rrd=Path(rrd) if rrd else None,
                                        connect_url=s.rerun_connect)
        cam_period = 1.0 / s.camera_hz if s.camera_hz > 0 else float("inf")
        truth_period = 1.0 / s.truth_hz if s.truth_hz > 0 else float("inf")
        next_cam, next_truth = 0.0, 0.0
        solve_ms: list[float] = []
        lockstep = mission.clock == "lockstep"
        wall0 = time.perf_counter()
        while not sim.done and not self.stop.is_set():
            if sim.t_s + 1e-9 >= next_truth:
                truth = sim.truth()
                bus.publish(self.k[Topic.TRUTH], truth)
                if self.recorder:
                    self.recorder.truth(truth)
                next_truth += truth_period
            if sim.t_s + 1e-9 >= next_cam:
                frame = sim.render_frame()
                bus.publish_bytes(self.k[Topic.CAMERA], encode_frame(frame.header, frame.rgb, frame.depth_m))
                if self.recorder:
                    self.recorder.camera(frame)  # the arrays, not a decode of what was just encoded
                next_cam += cam_period
            state = sim.vehicle_state()
            bus.publish(self.k[Topic.STATE], state)
            if self.recorder:
                self.recorder.state(state)
            if lockstep:
                if mission.max_rtf is not None:
                    time.sleep(max(0.0, wall0 + sim.t_s / mission.max_rtf - time.perf_counter()))
                cmd = self.commands.wait_for(state.seq, s.lockstep_timeout_s)
                if cmd is None:
                    sim.deadline_misses += 1
            else:
                time.sleep(max(0.0, wall0 + sim.t_s - time.perf_counter()))
                cmd = self.commands.take_latest()
            if cmd is not None and cmd.tick_ms is not None and cmd.tick_ms > 1e3 / s.ctrl_hz:
                sim.deadline_misses += 1  # the controller overran its control period
            if cmd is not None and cmd.solve_ms is not None:
                solve_ms.append(cmd.solve_ms)
                if self.recorder:
                    self.recorder.mpc_solve(sim.t_s, cmd.solve_ms)
            sim.apply_command(cmd)
            sim.step()
        result = sim.result(mpc_solve_ms=solve_ms)
        if self.spec_latencies_ms:
            result.spec_latency_ms_mean = float(sum(self.spec_latencies_ms) / len(self.spec_latencies_ms))
        if self.recorder:
            self.recorder.close()
            result.rrd_path = str(self.recorder.path) if self.recorder.path else None
            self.recorder = None
        bus.publish(self.k[Topic.RESULT], result)
        log.info("episode %s: %s (success=%s, %.1f s sim in %.1f s wall, %d deadline misses)",
                 mission.episode_id, result.outcome, result.success, result.sim_time_s,
                 result.wall_time_s, result.deadline_misses)
        self.current = None


def main() -> None:
    configure_logging()
    settings = SimSettings()
    stop = shutdown_event()
    with Bus() as bus:
        service = SimService(settings, bus, stop)
        try:
            service.serve()
        finally:
            service.sim.close()


if __name__ == "__main__":
    main()
