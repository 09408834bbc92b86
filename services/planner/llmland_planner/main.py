"""``llmland-planner``: unsafe regions, kinodynamic search, safe corridors and MPC as a service.

Subscribes ``llmland/<d>/mission`` (the resolved MissionGoal), ``sim/state`` (one MPC tick
per state), ``sim/camera`` and ``sim/camera_down`` (depth → tracked obstacles) and
``reasoner/spec`` (semantic buffers). Publishes ``planner/command`` (echoing each state's ``seq``) and
``planner/plan`` (reference, corridors, unsafe regions) whenever a new plan is adopted.
"""

from __future__ import annotations

import logging
import queue
import threading
from collections import deque

from llmland_schemas import (
    ABSTAIN_MODE,
    ControlCommand,
    MissionGoal,
    SafetySpecMessage,
    Topic,
    VehicleState,
    alive,
    key,
    vec3,
)
from llmland_schemas.bus import Bus
from llmland_schemas.frames import CameraFrame, decode_frame
from llmland_schemas.service import configure_logging, settings_or_exit, shutdown_event, watch_launcher

from .planner import Planner
from .settings import PlannerSettings

log = logging.getLogger("llmland.planner")


#: longest wait (s, wall) for the frame or spec a lockstep state says has been published; only
#: a lost message should run into it (a shorter limit made seeded runs diverge under heavy load)
INPUT_WAIT_S = 10.0
#: longest wait (s, wall) for the mission of a state from an episode not started here yet: the
#: sim publishes the resolved mission and then its first state on another key, and the two
#: callbacks race (a state dropped then cost the sim a 10 s lockstep timeout and its first tick)
MISSION_WAIT_S = 2.0
#: frames of an episode whose mission has not arrived yet are kept (at most this many) and
#: handed over when it does, for the same race
EARLY_FRAMES_MAX = 8
#: Spec messages kept for an episode whose mission has not arrived yet (the newest).
EARLY_SPECS_MAX = 8


class PlannerService:
    """Bus wiring around :class:`Planner`; one episode at a time.

    States are handled on a worker thread, never on Zenoh's: in lockstep the worker first
    waits (bounded by :data:`INPUT_WAIT_S`) until the camera frame and the specs that the state
    says were published have been received, so what the planner knows at a tick does not
    depend on bus timing and a seeded episode is reproducible.
    """

    def __init__(self, settings: PlannerSettings, bus: Bus) -> None:
        self.settings = settings
        self.bus = bus
        self.planner = Planner(settings)
        self.episode_id: str | None = None
        self._tick_lock = threading.Lock()
        self._inputs = threading.Condition()
        self._frame_seq = {"forward": -1, "down": -1}  # newest frame per camera handed to the planner
        self._spec_stamp = -1.0  # newest spec stamp of this episode received
        self._states: queue.Queue[VehicleState | None] = queue.Queue()
        self._waited_for: str | None = None  # the last unknown episode a state made us wait for
        self._started: deque[str] = deque(maxlen=16)  # episodes started here (never waited for again)
        self._early_frames: list[CameraFrame] = []  # of an episode whose mission is not in yet
        self._early_specs: list[SafetySpecMessage] = []  # the same for specs
        self.late_inputs = 0
        d = settings.drone_id
        self.cmd_key, self.plan_key = key(d, Topic.COMMAND), key(d, Topic.PLAN)
        bus.subscribe(key(d, Topic.MISSION), MissionGoal, self._on_mission)
        bus.subscribe(key(d, Topic.STATE), VehicleState, lambda _k, st: self._states.put(st))
        bus.subscribe_parsed(key(d, Topic.CAMERA), decode_frame, self._on_frame)
        bus.subscribe_parsed(key(d, Topic.CAMERA_DOWN), decode_frame, self._on_frame)
        bus.subscribe(key(d, Topic.SPEC), SafetySpecMessage, self._on_spec)
        self._worker = threading.Thread(target=self._run, name="planner-tick", daemon=True)
        self._worker.start()
        bus.announce(alive(d, "planner"))

    def _on_mission(self, _k: str, m: MissionGoal) -> None:
        if m.command == "stop" or m.target_m is None or m.start_m is None or m.episode_id == self.episode_id:
            return  # only the sim's resolved mission starts an episode here
        # a search of the episode that ended may hold the tick thread (lockstep adoption): end it
        # first, or the new episode waits for it under the tick lock (Replanner.cancel_search)
        self.planner.paths.cancel_search()
        with self._tick_lock:
            self.planner.start(m)
            with self._inputs:
                self.episode_id = m.episode_id
                self._started.append(m.episode_id)
                self._frame_seq, self._spec_stamp = {"forward": -1, "down": -1}, -1.0
                early, self._early_frames = [f for f in self._early_frames if f.header.episode_id == m.episode_id], []
                early_specs = [x for x in self._early_specs if x.episode_id == m.episode_id]
                self._early_specs = []
                self._inputs.notify_all()
        for frame in early:
            self._take_frame(frame)
        for msg in early_specs:
            self._take_spec(msg)

    def _on_frame(self, _k: str, frame: CameraFrame) -> None:
        with self._inputs:
            if frame.header.episode_id != self.episode_id:
                if frame.header.episode_id:  # maybe its mission is on the way: keep the newest few
                    self._early_frames = (self._early_frames + [frame])[-EARLY_FRAMES_MAX:]
                return
        self._take_frame(frame)

    def _take_frame(self, frame: CameraFrame) -> None:
        self.planner.on_frame(frame)  # drops it if another episode has started meanwhile
        with self._inputs:
            if frame.header.episode_id != self.episode_id:
                return
            cam = frame.header.camera
            self._frame_seq[cam] = max(self._frame_seq[cam], frame.header.seq)
            self._inputs.notify_all()

    def _on_spec(self, _k: str, msg: SafetySpecMessage) -> None:
        with self._inputs:
            if msg.episode_id not in ("", self.episode_id):
                # its mission may be on the way (on a loaded machine the first spec can come first:
                # dropped, every tick waited 10 s for it until the next one, Exp 2 forest_edge 38)
                self._early_specs = (self._early_specs + [msg])[-EARLY_SPECS_MAX:]
                return
        self._take_spec(msg)

    def _take_spec(self, msg: SafetySpecMessage) -> None:
        self.planner.on_spec(msg)
        with self._inputs:
            self._spec_stamp = max(self._spec_stamp, msg.stamp)
            self._inputs.notify_all()

    def _wait_inputs(self, st: VehicleState) -> None:
        """Lockstep: wait until the frame and specs this state refers to are in."""
        def ready() -> bool:
            frame_ok = ((st.camera_seq is None or self._frame_seq["forward"] >= st.camera_seq)
                        and (st.down_camera_seq is None or self._frame_seq["down"] >= st.down_camera_seq))
            spec_ok = st.specs_released_upto_s is None or self._spec_stamp >= st.specs_released_upto_s - 1e-9
            return frame_ok and spec_ok

        with self._inputs:
            if not self._inputs.wait_for(ready, timeout=INPUT_WAIT_S):
                self.late_inputs += 1
                log.warning("state %d: frame %s / specs up to %s not received within %.1f s (%d so far)",
                            st.seq, st.camera_seq, st.specs_released_upto_s, INPUT_WAIT_S, self.late_inputs)

    def _run(self) -> None:
        while (st := self._states.get()) is not None:
            try:
                self._handle_state(st)
            except Exception:  # a planner bug must not stop the service: the sim's failsafe holds
                log.exception("planner tick failed")
                self._abstain(st)

    def _abstain(self, st: VehicleState) -> None:
        """Say at once that this tick has no command (:data:`ABSTAIN_MODE`), so the sim flies it as a
        missing one without waiting for it in lockstep (up to 300 s while this service is alive)."""
        try:
            self.bus.publish(self.cmd_key, ControlCommand(
                drone_id=self.settings.drone_id, stamp=st.stamp, seq=st.seq, state_seq=st.seq,
                body_rates_rps=(0.0, 0.0, 0.0), thrust_n=0.0, mode=ABSTAIN_MODE, source="planner"), express=True)
        except Exception:
            log.exception("could not publish the abstention of tick %d", st.seq)

    def _known_episode(self, st: VehicleState) -> bool:
        """Whether ``st`` belongs to the episode started here, waiting (once per unknown episode, at
        most :data:`MISSION_WAIT_S`) for its mission to arrive first; a state of an episode that
        was started here and has ended is dropped at once."""
        with self._inputs:
            if (st.episode_id != self.episode_id and st.episode_id != self._waited_for
                    and st.episode_id not in self._started):
                self._waited_for = st.episode_id
                self._inputs.wait_for(lambda: self.episode_id == st.episode_id, timeout=MISSION_WAIT_S)
            return st.episode_id == self.episode_id

    def _handle_state(self, st: VehicleState) -> None:
        if not self._known_episode(st):
            return
        self._wait_inputs(st)
        with self._tick_lock:
            out = self.planner.tick(st)
        cmd = ControlCommand(
            drone_id=self.settings.drone_id, stamp=st.stamp, seq=st.seq, state_seq=st.seq,
            body_rates_rps=vec3(out.body_rates_rps), thrust_n=max(0.0, out.thrust_n),
            mode=out.mode, source="planner",
            solve_ms=out.mpc.solve_ms if out.mpc else None, tick_ms=out.tick_ms,
        )
        self.bus.publish(self.cmd_key, cmd, express=True)
        if out.snapshot is not None:
            self.bus.publish(self.plan_key, out.snapshot)

    def close(self) -> None:
        self._states.put(None)
        self._worker.join(timeout=5.0)


def main() -> None:
    configure_logging()
    watch_launcher()
    settings = settings_or_exit(PlannerSettings)
    stop = shutdown_event()
    with Bus() as bus:
        service = PlannerService(settings, bus)
        log.info("planner ready (drone %s)", settings.drone_id)
        stop.wait()
        service.close()


if __name__ == "__main__":
    main()
