"""Specs given directly from the simulator's ground truth (no perception).

For planner tests and ablations: every obstacle in ``sim/truth`` gets the spec of its class
(a built-in table of the paper's defaults, overridden by the mission's ``given_specs``),
published on ``reasoner/spec`` with ``source="given"``, exactly where the reasoner would
publish. Each message claims a fixed ``latency_ms`` (default 50 ms, a fast reasoner): the
planner applies it at ``stamp + latency``, which in lockstep is later than it can arrive
over the bus, so a seeded episode is reproducible (with zero latency, whether a spec made
the same tick would depend on the bus's timing). The planner still sees geometry only from depth; it attaches
these specs to its tracks by position, as it does the reasoner's.
"""

from __future__ import annotations

import logging
import threading

from llmland_schemas import (
    GroundTruth,
    MissionGoal,
    ObjectSpec,
    SafetySpec,
    SafetySpecMessage,
    Topic,
    key,
)
from llmland_schemas.bus import Bus

log = logging.getLogger(__name__)


def _spec(label: str, dynamic: bool, z_min: float, buffer_m: float) -> SafetySpec:
    return SafetySpec(is_dynamic=dynamic, z_min=z_min, buffer_m=buffer_m, label=label, source="given",
                      model="ground-truth")


#: Paper defaults: pedestrians 3 m, vehicles 5 m; static things a small buffer.
DEFAULT_SPECS: dict[str, SafetySpec] = {
    "person": _spec("person", True, 3.0, 3.0),
    "vehicle": _spec("vehicle", True, 3.0, 5.0),
    "building": _spec("building", False, 0.0, 1.0),
    "shed": _spec("shed", False, 0.0, 1.0),
    "tree": _spec("tree", False, 0.0, 1.0),
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
        bus.subscribe(key(drone_id, Topic.MISSION), MissionGoal, self._on_mission)
        bus.subscribe(key(drone_id, Topic.TRUTH), GroundTruth, self._on_truth)

    def _on_mission(self, _k: str, m: MissionGoal) -> None:
        table = dict(DEFAULT_SPECS)
        table.update({g.cls: g.spec for g in m.given_specs})
        with self._lock:
            self._table[m.episode_id] = table

    def _on_truth(self, _k: str, truth: GroundTruth) -> None:
        with self._lock:
            table = self._table.get(truth.episode_id)
        if table is None:
            return
        objects = [
            ObjectSpec(obj_id=o.obj_id, centroid_m=o.position_m, size_m=o.size_m, spec=table[o.cls])
            for o in truth.objects
            if o.cls in table
        ]
        msg = SafetySpecMessage(
            drone_id=self.drone_id, stamp=truth.stamp, seq=truth.seq, frame_seq=truth.seq,
            scene=_spec("scene", any(o.spec.is_dynamic for o in objects), 0.0, 0.0),
            objects=objects, latency_ms=self.latency_ms, episode_id=truth.episode_id,
        )
        self.bus.publish(self._spec_key, msg)
        self.published += 1
