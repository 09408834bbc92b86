"""``llmland-refpilot``: the reference pilot — a geometric position controller in the planner's seat.

It knows nothing of obstacles: it flies straight to above the target at cruise altitude,
descends and cuts thrust on touchdown. It is the early demo pilot and the test oracle for
the sim's lockstep protocol; ``llmland-planner`` replaces it for the real methods.

Subscribes ``sim/state`` and ``mission``; publishes ``planner/command`` echoing each
state's ``seq``.
"""

from __future__ import annotations

import logging
import threading
from dataclasses import dataclass

import numpy as np
from llmland_schemas import ControlCommand, MissionGoal, Topic, VehicleState, alive, key
from llmland_schemas.bus import Bus
from llmland_schemas.service import configure_logging, shutdown_event, watch_launcher
from pydantic_settings import BaseSettings, SettingsConfigDict

from .vehicle import DEFAULT_PARAMS, QuadParams, ReferencePositionController

log = logging.getLogger("llmland.refpilot")


class RefPilotSettings(BaseSettings):
    model_config = SettingsConfigDict(env_prefix="LLMLAND_REFPILOT_", extra="ignore")

    drone_id: str = "d0"
    cruise_altitude_m: float = 3.0
    descent_speed_mps: float = 0.6
    align_radius_m: float = 0.15
    cut_height_m: float = 0.12


@dataclass
class LandingPilot:
    """Approach above the target, descend, cut thrust. Pure logic, no bus."""

    target_m: np.ndarray
    settings: RefPilotSettings
    params: QuadParams = DEFAULT_PARAMS
    phase: str = "approach"

    def __post_init__(self) -> None:
        self.ctrl = ReferencePositionController(self.params)

    def update(self, state: VehicleState) -> tuple[np.ndarray, float, str]:
        """Body rates (rad/s), thrust (N) and the phase name for one state."""
        pos = np.asarray(state.position_m)
        vel = np.asarray(state.velocity_mps)
        s = self.settings
        ground = float(self.target_m[2])
        above = np.array([self.target_m[0], self.target_m[1], ground + s.cruise_altitude_m])
        horiz_err = float(np.linalg.norm(pos[:2] - self.target_m[:2]))
        if self.phase == "approach" and horiz_err < s.align_radius_m and np.linalg.norm(vel) < 0.3:
            self.phase = "descend"
        if self.phase == "descend" and (pos[2] - ground < s.cut_height_m or state.on_ground):
            self.phase = "disarm"
        if self.phase == "disarm":
            return np.zeros(3), 0.0, self.phase
        if self.phase == "approach":
            goal = above
            if pos[2] < ground + 1.0:  # climb before moving sideways
                goal = np.array([pos[0], pos[1], above[2]])
            rates, thrust = self.ctrl.update(pos, vel, np.asarray(state.quat_xyzw), goal)
        else:
            goal = np.array([self.target_m[0], self.target_m[1], ground - 0.05])
            target_vel = np.array([0.0, 0.0, -s.descent_speed_mps])
            carrot = np.array([goal[0], goal[1], max(goal[2], pos[2] - 0.4)])
            rates, thrust = self.ctrl.update(pos, vel, np.asarray(state.quat_xyzw), carrot, target_vel)
        return np.asarray(rates, dtype=float), float(thrust), self.phase


def main() -> None:
    configure_logging()
    watch_launcher()
    settings = RefPilotSettings()
    stop = shutdown_event()
    d = settings.drone_id
    lock = threading.Lock()
    pilots: dict[str, LandingPilot] = {}
    targets: dict[str, np.ndarray] = {}

    with Bus() as bus:
        cmd_key = key(d, Topic.COMMAND)

        def on_mission(_k: str, m: MissionGoal) -> None:
            if m.command == "start" and m.target_m is not None:
                with lock:
                    targets[m.episode_id] = np.asarray(m.target_m, dtype=float)

        def on_state(_k: str, st: VehicleState) -> None:
            with lock:
                pilot = pilots.get(st.episode_id)
                if pilot is None:
                    target = targets.get(st.episode_id)
                    if target is None:
                        return  # no mission seen for this episode: stay silent
                    pilot = pilots[st.episode_id] = LandingPilot(target, settings)
                rates, thrust, phase = pilot.update(st)
            bus.publish(
                cmd_key,
                ControlCommand(
                    drone_id=d, stamp=st.stamp, seq=st.seq, state_seq=st.seq,
                    body_rates_rps=tuple(rates), thrust_n=thrust, mode=phase, source="refpilot",
                ),
            )

        bus.subscribe(key(d, Topic.MISSION), MissionGoal, on_mission)
        bus.subscribe(key(d, Topic.STATE), VehicleState, on_state)
        bus.announce(alive(d, "pilot"))
        log.info("reference pilot ready (drone %s)", d)
        stop.wait()


if __name__ == "__main__":
    main()
