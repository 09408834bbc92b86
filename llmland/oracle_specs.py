"""Specs given directly from the simulator's ground truth (no perception).

For planner tests and ablations: it answers each camera frame sent for perception (the
header's ``perceive``), where the VLE → reasoner pipeline would: every obstacle in the latest
``sim/truth`` gets the spec of its class (a built-in table of the paper's defaults, overridden
by the mission's ``given_specs``), published on ``reasoner/spec`` with ``source="given"``,
stamped with the frame's stamp and ``frame_seq``. It claims ``latency_ms`` (default 50 ms, a
fast reasoner); in lockstep the sim's latency model decides when it takes effect (the CLI
uses ``fixed:50`` for oracle specs, so a seeded episode is reproducible). The planner still
sees geometry only from depth; it attaches these specs to its tracks by position, as it does
the reasoner's.
"""

from __future__ import annotations

import logging
import threading

from llmland_schemas import (
    PERSON_BUFFER_M,
    PERSON_Z_MIN_M,
    STATIC_BUFFER_M,
    VEHICLE_BUFFER_M,
    VEHICLE_Z_MIN_M,
    CameraFrameHeader,
    GroundTruth,
    MissionGoal,
    ObjectSpec,
    SafetySpec,
    SafetySpecMessage,
    Topic,
    key,
)
from llmland_schemas.bus import Bus
from llmland_schemas.frames import peek_header

log = logging.getLogger(__name__)

#: Frames kept while their episode's mission or truth has not arrived (the newest ones).
MAX_WAITING = 8


def _spec(label: str, dynamic: bool, z_min: float, buffer_m: float) -> SafetySpec:
    return SafetySpec(is_dynamic=dynamic, is_human=label == "person", z_min=z_min, buffer_m=buffer_m, label=label,
                      source="given", model="ground-truth")


#: Paper defaults: pedestrians 3 m, vehicles 5 m; static things a small buffer.
DEFAULT_SPECS: dict[str, SafetySpec] = {
    "person": _spec("person", True, PERSON_Z_MIN_M, PERSON_BUFFER_M),
    "vehicle": _spec("vehicle", True, VEHICLE_Z_MIN_M, VEHICLE_BUFFER_M),
    "building": _spec("building", False, 0.0, STATIC_BUFFER_M),
    "shed": _spec("shed", False, 0.0, STATIC_BUFFER_M),
    "tree": _spec("tree", False, 0.0, STATIC_BUFFER_M),
    "bush": _spec("bush", False, 0.0, 0.5),
    "rock": _spec("rock", False, 0.0, 0.5),
}


class OracleSpecPublisher:
    """Turns each GroundTruth into a SafetySpecMessage for the running episode."""

    def __init__(self, bus: Bus, drone_id: str = "d0", latency_ms: float = 50.0) -> None:
        self.bus = bus
        self.drone_id = drone_id
        self.latency_ms = latency_ms
        self._lock = threading.Lock()
        self._table: dict[str, dict[str, SafetySpec]] = {}
        self.published = 0
        self._spec_key = key(drone_id, Topic.SPEC)
        self._truth: dict[str, GroundTruth] = {}
        #: frames that came before their episode's mission or truth (callbacks of different
        #: subscriptions are not ordered): answered as soon as both are known
        self._waiting: list[CameraFrameHeader] = []
        bus.subscribe(key(drone_id, Topic.MISSION), MissionGoal, self._on_mission)
        bus.subscribe(key(drone_id, Topic.TRUTH), GroundTruth, self._on_truth)
        bus.subscribe_parsed(key(drone_id, Topic.CAMERA), peek_header, self._on_frame)

    def _on_mission(self, _k: str, m: MissionGoal) -> None:
        table = dict(DEFAULT_SPECS)
        table.update({g.cls: g.spec for g in m.given_specs})
        with self._lock:
            self._table[m.episode_id] = table
        self._answer_waiting()

    def _on_truth(self, _k: str, truth: GroundTruth) -> None:
        with self._lock:  # the newest truth (it may come before its episode's mission)
            self._truth = {truth.episode_id: truth}
        self._answer_waiting()

    def _on_frame(self, _k: str, header: CameraFrameHeader) -> None:
        if not header.perceive:
            return
        with self._lock:  # queued until its episode's mission and truth are known (at once, usually)
            self._waiting = [h for h in self._waiting if h.episode_id == header.episode_id][1 - MAX_WAITING:]
            self._waiting.append(header)
        self._answer_waiting()

    def _answer_waiting(self) -> None:
        with self._lock:
            ready = [(h, self._table[h.episode_id], self._truth[h.episode_id]) for h in self._waiting
                     if h.episode_id in self._table and h.episode_id in self._truth]
            if ready:
                self._waiting = [h for h in self._waiting if h.episode_id != ready[0][0].episode_id]
        for header, table, truth in ready:
            self._answer(header, table, truth)

    def _answer(self, header: CameraFrameHeader, table: dict[str, SafetySpec], truth: GroundTruth) -> None:
        objects = [
            ObjectSpec(obj_id=o.obj_id, centroid_m=o.position_m, size_m=o.size_m, spec=table[o.cls])
            for o in truth.objects
            if o.cls in table
        ]
        msg = SafetySpecMessage(
            drone_id=self.drone_id, stamp=header.stamp, seq=header.seq, frame_seq=header.seq,
            scene=_spec("scene", any(o.spec.is_dynamic for o in objects), 0.0, 0.0),
            objects=objects, latency_ms=self.latency_ms, episode_id=truth.episode_id,
        )
        self.bus.publish(self._spec_key, msg)
        self.published += 1
