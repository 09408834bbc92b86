"""``llmland-sim``: the pybullet quadrotor world as a Zenoh service.

Subscribes ``llmland/<d>/mission`` (MissionGoal) and ``llmland/<d>/planner/command``
(ControlCommand); publishes ``sim/state`` each control tick, ``sim/camera`` at
``camera_hz``, ``sim/truth`` at ``truth_hz`` and ``episode/result`` at the end.

Clock modes (DESIGN §4): ``lockstep`` publishes each tick's state and waits, bounded by
``lockstep_timeout_s``, and on while the planner's liveliness token is up (at most
``lockstep_max_wait_s``), for the command echoing its ``seq``: a miss is counted and the
vehicle holds its last input, then holds position; a command whose controller compute time
``tick_ms`` exceeded the control period is applied and counted as an overrun. ``realtime`` paces
ticks to the wall clock and applies the newest command.

Camera frames due at a tick are rendered from that tick's state *after* the state is
published, while the planner computes its command, and reach the planner with the next
tick's state: a camera-to-planner latency of one control period (20 ms at 50 Hz; real
cameras take 20–50 ms from exposure to host). Frames keep the stamp of the instant they
show, so every age the planner computes (the hard limit's reach growth) includes it.
Rendering in the shadow of the planner's tick is what lets a lockstep episode use both
cores instead of taking turns.
"""

from __future__ import annotations

import logging
import math
import queue
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING

from llmland_schemas import (
    ABSTAIN_MODE,
    ControlCommand,
    MissionGoal,
    PlanSnapshot,
    SafetySpecMessage,
    SceneDescription,
    Topic,
    VehicleState,
    alive,
    key,
)
from llmland_schemas.bus import Bus
from llmland_schemas.frames import CameraFrame, encode_frame
from llmland_schemas.service import configure_logging, settings_or_exit, shutdown_event, watch_launcher

from .mailbox import CommandMailbox
from .perception_clock import LatencyModel, PerceptionClock
from .settings import SimSettings
from .simulation import Simulation

if TYPE_CHECKING:  # rerun is imported (≈1.5 s) only by an episode that records
    from .viz import SimRecorder

log = logging.getLogger("llmland.sim")

#: lockstep: after a tick without a command, wait this long (s, wall) until the planner is back
DEAD_PLANNER_WAIT_S = 0.05
#: How long (s) a liveliness query for the planner's token may take.
PLANNER_ALIVE_QUERY_S = 1.0
#: lockstep, after a miss: how often (s, wall) to ask again whether the planner's token is up
PLANNER_RECHECK_S = 1.0


def _flown(cmd: ControlCommand | None) -> ControlCommand | None:
    """The command to fly: none for an abstention (:data:`ABSTAIN_MODE`, a live planner with no
    command for this tick), which is then flown as a missing one, at once."""
    return None if cmd is not None and cmd.mode == ABSTAIN_MODE else cmd


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
        self.clock: PerceptionClock | None = None
        self.walls = WallTimes()
        #: episodes stopped before they started (``llmland mission`` interrupted or timed out while
        #: queued behind another episode): skipped, not flown for no one
        self._cancelled: set[str] = set()
        self._planner_ok = True
        self._planner_gone = False  # after a miss: the planner's liveliness token is gone
        self._gone_checked_at = -math.inf  # when that was last asked (perf_counter, s)
        #: the newest frames' seqs (lockstep: the state names the frames of its tick)
        self._camera_seq: int | None = None
        self._down_seq: int | None = None
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
            elif msg.episode_id != "*":  # a mission still queued behind the running one: not flown
                self._cancelled.add(msg.episode_id)
            return
        if self.current is not None and self.current.episode_id == msg.episode_id:
            return  # a repeated start for the running episode
        self.missions.put(msg)

    def _on_spec(self, _key: str, msg: SafetySpecMessage) -> None:
        score = self.sim.score
        if self.current is not None and msg.episode_id == self.current.episode_id and score is not None:
            score.observe_spec(msg)
            clock = self.clock
            if clock is not None:
                clock.on_spec(msg.frame_seq, msg.latency_ms, self.sim.t_s)
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
            if mission.episode_id in self._cancelled:
                self._cancelled.discard(mission.episode_id)
                log.info("mission %s was stopped before it started: not flown", mission.episode_id)
                continue
            self.run_episode(mission)

    def run_episode(self, mission: MissionGoal) -> None:
        """Fly one mission to its end; publishes its EpisodeResult."""
        mission = self._begin(mission)
        due = Schedule(self.settings.camera_hz, self.settings.truth_hz, self.settings.down_camera_hz)
        wall0 = time.perf_counter()
        while not self.sim.done and not self.stop.is_set():
            self._before_state(due)
            state = self._publish_state(mission)
            self._publish_frames(due, mission)  # rendered while the planner computes this tick
            cmd = self._await_command(mission, wall0)
            self._record_tick(state, cmd)
            with self.walls.time("physics"):
                self.sim.apply_command(cmd)
                self.sim.step()
        if self.stop.is_set() and not self.sim.done:
            self.sim.stop()  # the service is shutting down: the episode is aborted, not timed out
        self._finish(mission)

    def _begin(self, mission: MissionGoal) -> MissionGoal:
        """Build the world, announce the resolved mission, set up the clock and the recorder."""
        s, sim = self.settings, self.sim
        rrd = mission.rrd_path or s.rrd
        recording = rrd is not None or bool(s.rerun_connect)
        if recording:  # imported before the episode's wall clock starts (sim.reset)
            from .viz import SimRecorder
        self.commands.clear()
        sim.reset(mission)
        self.walls = WallTimes()
        self._planner_ok, self._planner_gone, self._gone_checked_at = True, False, -math.inf
        self._camera_seq = self._down_seq = None
        assert sim.world is not None
        # Tell everyone the resolved mission (start and target filled from the world).
        mission = mission.model_copy(update={
            "start_m": tuple(float(x) for x in sim.quad_start_m),
            "target_m": tuple(float(x) for x in sim.world.target_m),
        })
        sim.mission = mission
        lockstep = mission.clock == "lockstep"
        self.clock = (PerceptionClock(LatencyModel.parse(mission.latency_model), mission.seed, s.perception_timeout_s)
                      if lockstep and mission.perception != "none" else None)
        self.current = mission
        if mission.episode_id in self._cancelled:  # stopped while its world was being built: fly nothing
            self._cancelled.discard(mission.episode_id)
            sim.stop()
        self.bus.publish(self.k[Topic.MISSION], mission)
        if recording:
            self.recorder = SimRecorder(mission.episode_id, rrd=Path(rrd) if rrd else None,
                                        connect_url=s.rerun_connect)
        return mission

    def _before_state(self, due: Schedule) -> None:
        """What is due before this tick's state: truth and the perception wait (lockstep)."""
        t_s = self.sim.t_s
        if due.truth(t_s):
            self._publish_truth()
        if self.clock is not None:  # latency-faithful perception (DESIGN §4)
            with self.walls.time("perception_wait"):
                self.clock.wait_before(t_s, self.stop)

    def _publish_frames(self, due: Schedule, mission: MissionGoal) -> None:
        """The camera frames due at this tick, from this tick's state (the next state names them).

        The downward frame first: the planner's heavier frame (more depth points) then
        overlaps the forward camera's rendering.
        """
        t_s = self.sim.t_s
        if due.down_camera(t_s):
            with self.walls.time("camera"):
                self._down_seq = self._publish_down_frame(mission)
        if due.camera(t_s):
            with self.walls.time("camera"):
                self._camera_seq = self._publish_frame(mission)

    def _record_tick(self, state: VehicleState, cmd: ControlCommand | None) -> None:
        """To Rerun, once the planner has answered: recording never competes with its tick."""
        if self.recorder is None:
            return
        self.recorder.state(state)
        if cmd is not None and cmd.solve_ms is not None:
            self.recorder.mpc_solve(self.sim.t_s, cmd.solve_ms)

    def _publish_truth(self) -> None:
        truth = self.sim.truth()
        self.bus.publish(self.k[Topic.TRUTH], truth)
        if self.recorder:
            self.recorder.truth(truth)

    def _publish_frame(self, mission: MissionGoal) -> int:
        """Render and publish a camera frame; in lockstep, maybe as a perception request."""
        sim, clock = self.sim, self.clock
        if clock is not None:
            perceive = clock.should_perceive(sim.t_s)
        else:
            perceive = mission.perception != "none"
        frame = sim.render_frame(perceive=perceive)
        if clock is not None and perceive:
            clock.on_frame_sent(frame.header.seq, frame.header.stamp)
        self._send_frame(Topic.CAMERA, frame, mission)
        if self.recorder:
            self.recorder.camera(frame)  # the arrays, not a decode of what was just encoded
        return frame.header.seq

    def _publish_down_frame(self, mission: MissionGoal) -> int:
        frame = self.sim.render_frame(camera="down")
        self._send_frame(Topic.CAMERA_DOWN, frame, mission)
        if self.recorder:
            self.recorder.camera_down(frame)
        return frame.header.seq

    def _send_frame(self, topic: Topic, frame: CameraFrame, mission: MissionGoal) -> None:
        """Encode and publish; in lockstep never dropped under congestion (the sim and the
        planner wait for what a frame starts)."""
        self.bus.publish_bytes(self.k[topic], encode_frame(frame.header, frame.rgb, frame.depth_m),
                               block=mission.clock == "lockstep")

    def _publish_state(self, mission: MissionGoal) -> VehicleState:
        """This tick's state, naming the frames published before it and the specs in effect at
        this tick (lockstep)."""
        sim = self.sim
        released = self.clock.released_upto_s(sim.t_s) if self.clock is not None else None
        lockstep = mission.clock == "lockstep"
        state = sim.vehicle_state(camera_seq=self._camera_seq if lockstep else None,
                                  down_camera_seq=self._down_seq if lockstep else None,
                                  specs_released_upto_s=released)
        self.bus.publish(self.k[Topic.STATE], state, express=True)
        return state

    def _await_command(self, mission: MissionGoal, wall0: float) -> ControlCommand | None:
        """The command for this tick (lockstep: wait for it; realtime: the newest, wall-paced)."""
        sim = self.sim
        if mission.clock != "lockstep":
            time.sleep(max(0.0, wall0 + sim.t_s - time.perf_counter()))
            return _flown(self.commands.take_latest())
        # After a miss the planner is presumed dead: wait only briefly until it answers again,
        # so a dead planner costs the vehicle-side failsafe, not 10 s of wall time per tick.
        with self.walls.time("planner_wait"):
            if self._planner_ok:
                cmd = self._wait_for_planner(sim.seq)
            else:
                cmd = self.commands.wait_for(sim.seq, self._missed_planner_wait())
        self._planner_ok = cmd is not None
        cmd = _flown(cmd)
        if cmd is None and sim.score is not None:
            sim.score.observe_deadline_miss()
        return cmd

    def _wait_for_planner(self, seq: int) -> ControlCommand | None:
        """Lockstep: the command echoing ``seq``, or None for a planner that is gone or hung.

        Waits ``lockstep_timeout_s``, then on, a slice of that at a time, while the planner's
        liveliness token is up, up to ``lockstep_max_wait_s`` in all. A slow tick must not change
        the episode: a search at its largest budget took 9.7 s of wall beside other episodes on 2
        cores, and past the old fixed 10 s wait the failsafe flew the vehicle instead, so the same
        seed flew another episode under load (Exp 2 urban 12, baseline, at a94c218: a time-out in
        248 s of wall against a landing at 50.0 s alone). A planner whose process ends takes its
        token with it (Zenoh liveliness), so a dead planner is still a miss after the first slice. A
        stop (the service's, or the episode's) ends the wait at the next slice.
        """
        s, waited = self.settings, 0.0
        while True:
            cmd = self.commands.wait_for(seq, s.lockstep_timeout_s)
            waited += s.lockstep_timeout_s
            if (cmd is not None or waited >= s.lockstep_max_wait_s or self.stop.is_set() or self.sim.done
                    or not self._planner_alive()):
                return cmd
            log.warning("tick %d: no command after %.0f s of wall; the planner is alive, waiting on", seq, waited)

    def _missed_planner_wait(self) -> float:
        """After a miss, how long (s, wall) a tick waits for its command: :data:`DEAD_PLANNER_WAIT_S`
        while the planner's liveliness token is up (a hung planner may answer again), nothing once
        it is gone (asked at most every :data:`PLANNER_RECHECK_S`). A planner killed mid-episode
        then costs no wall time per tick: its fault run flew 90 s in 246 s of wall at 50 ms a
        tick. The commands flown are the same either way (a gone planner sends none)."""
        if time.perf_counter() - self._gone_checked_at >= PLANNER_RECHECK_S:
            self._planner_alive()
        return 0.0 if self._planner_gone else DEAD_PLANNER_WAIT_S

    def _planner_alive(self) -> bool:
        """Whether this drone's planner holds its liveliness token (a query, ≤ 1 s); the answer
        is kept for :meth:`_missed_planner_wait` (the miss that ended a wait asked already)."""
        up = bool(self.bus.alive(alive(self.settings.drone_id, "planner"), PLANNER_ALIVE_QUERY_S))
        self._planner_gone, self._gone_checked_at = not up, time.perf_counter()  # from the answer
        return up

    def _finish(self, mission: MissionGoal) -> None:
        sim, clock, rec = self.sim, self.clock, self.recorder
        if clock is not None:
            clock.finish(sim.t_s)
        result = sim.result(perception=clock, rrd_path=str(rec.path) if rec is not None and rec.path else None)
        if rec is not None:
            rec.close()
            self.recorder = None
        self.bus.publish(self.k[Topic.RESULT], result)
        log.info("episode %s: %s (success=%s, %.1f s sim in %.1f s wall, %d deadline misses, %d perception requests)",
                 mission.episode_id, result.outcome, result.success, result.sim_time_s,
                 result.wall_time_s, result.deadline_misses, result.perception_requests)
        log.info("episode %s wall time by part (s): %s", mission.episode_id, self.walls.summary())
        self.current = None
        self.clock = None


class WallTimes:
    """Wall time spent in each part of the episode loop (for the log: where does time go)."""

    def __init__(self) -> None:
        self.totals: dict[str, float] = {}

    @contextmanager
    def time(self, part: str) -> Iterator[None]:
        t0 = time.perf_counter()
        try:
            yield
        finally:
            self.totals[part] = self.totals.get(part, 0.0) + time.perf_counter() - t0

    def summary(self) -> dict[str, float]:
        return {k: round(v, 2) for k, v in sorted(self.totals.items())}


class Schedule:
    """Which periodic publications are due at a sim time (rates in Hz; 0 disables)."""

    def __init__(self, camera_hz: float, truth_hz: float, down_camera_hz: float = 0.0) -> None:
        rates = {"camera": camera_hz, "truth": truth_hz, "down_camera": down_camera_hz}
        self._period = {k: 1.0 / hz if hz > 0 else math.inf for k, hz in rates.items()}
        self._next = {k: 0.0 if hz > 0 else math.inf for k, hz in rates.items()}  # 0 Hz: never (was once, at 0 s)

    def _due(self, what: str, t_s: float) -> bool:
        if t_s + 1e-9 < self._next[what]:
            return False
        self._next[what] += self._period[what]
        return True

    def camera(self, t_s: float) -> bool:
        return self._due("camera", t_s)

    def truth(self, t_s: float) -> bool:
        return self._due("truth", t_s)

    def down_camera(self, t_s: float) -> bool:
        return self._due("down_camera", t_s)


def main() -> None:
    configure_logging()
    watch_launcher()
    settings = settings_or_exit(SimSettings)
    stop = shutdown_event()
    with Bus() as bus:
        service = SimService(settings, bus, stop)
        try:
            service.serve()
        finally:
            service.sim.close()


if __name__ == "__main__":
    main()
