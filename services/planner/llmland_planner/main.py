"""``llmland-planner``: unsafe regions, kinodynamic search, safe corridors and MPC as a service.

Subscribes ``llmland/<d>/mission`` (the resolved MissionGoal), ``sim/state`` (one MPC tick
per state), ``sim/camera`` (depth → tracked obstacles) and ``reasoner/spec`` (semantic
buffers). Publishes ``planner/command`` (echoing each state's ``seq``) and
``planner/plan`` (reference, corridors, unsafe regions) whenever a new plan is adopted.
"""

from __future__ import annotations

import logging
import threading

from llmland_schemas import (
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
from llmland_schemas.service import configure_logging, shutdown_event

from .planner import Planner
from .settings import PlannerSettings

log = logging.getLogger("llmland.planner")


class PlannerService:
    """Bus wiring around :class:`Planner`; one episode at a time."""

    def __init__(self, settings: PlannerSettings, bus: Bus) -> None:
        self.settings = settings
        self.bus = bus
        self.planner = Planner(settings)
        self.episode_id: str | None = None
        self._tick_lock = threading.Lock()
        d = settings.drone_id
        self.cmd_key, self.plan_key = key(d, Topic.COMMAND), key(d, Topic.PLAN)
        bus.subscribe(key(d, Topic.MISSION), MissionGoal, self._on_mission)
        bus.subscribe(key(d, Topic.STATE), VehicleState, self._on_state)
        bus.subscribe_parsed(key(d, Topic.CAMERA), decode_frame, self._on_frame)
        bus.subscribe(key(d, Topic.SPEC), SafetySpecMessage, self._on_spec)
        bus.announce(alive(d, "planner"))

    def _on_mission(self, _k: str, m: MissionGoal) -> None:
        if m.command == "stop" or m.target_m is None or m.start_m is None or m.episode_id == self.episode_id:
            return  # only the sim's resolved mission starts an episode here
        with self._tick_lock:
            self.planner.start(m)
            self.episode_id = m.episode_id

    def _on_frame(self, _k: str, frame: CameraFrame) -> None:
        if frame.header.episode_id == self.episode_id:
            self.planner.on_frame(frame)

    def _on_spec(self, _k: str, msg: SafetySpecMessage) -> None:
        if msg.episode_id in ("", self.episode_id):
            self.planner.on_spec(msg)

    def _on_state(self, _k: str, st: VehicleState) -> None:
        if st.episode_id != self.episode_id:
            return
        with self._tick_lock:
            out = self.planner.tick(st)
        cmd = ControlCommand(
            drone_id=self.settings.drone_id, stamp=st.stamp, seq=st.seq, state_seq=st.seq,
            body_rates_rps=vec3(out.body_rates_rps), thrust_n=max(0.0, out.thrust_n),
            mode=out.mode, source="planner",
            solve_ms=out.mpc.solve_ms if out.mpc else None, tick_ms=out.tick_ms,
        )
        self.bus.publish(self.cmd_key, cmd)
        if out.snapshot is not None:
            self.bus.publish(self.plan_key, out.snapshot)


def main() -> None:
    configure_logging()
    settings = PlannerSettings()
    stop = shutdown_event()
    with Bus() as bus:
        PlannerService(settings, bus)
        log.info("planner ready (drone %s)", settings.drone_id)
        stop.wait()


if __name__ == "__main__":
    main()
