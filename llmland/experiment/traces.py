"""What an episode looked like from above, for the trajectory plots: drone path, people's paths,
the unsafe regions the planner used, the target. One small JSON per trial.
"""

from __future__ import annotations

import json
import threading
from pathlib import Path
from typing import Any

from llmland_schemas import GroundTruth, PlanSnapshot, Topic, VehicleState, key
from llmland_schemas.bus import Bus

#: keep every Nth drone state (50 Hz → 5 Hz)
STATE_EVERY = 10
#: keep every Nth truth message (10 Hz → 2 Hz)
TRUTH_EVERY = 5


class TraceRecorder:
    """Records the current episode of one drone from the bus (thread-safe)."""

    def __init__(self, bus: Bus, drone_id: str = "d0") -> None:
        self._lock = threading.Lock()
        self._episode = ""
        self._reset("")
        bus.subscribe(key(drone_id, Topic.STATE), VehicleState, self._on_state)
        bus.subscribe(key(drone_id, Topic.TRUTH), GroundTruth, self._on_truth)
        bus.subscribe(key(drone_id, Topic.PLAN), PlanSnapshot, self._on_plan)

    def _reset(self, episode_id: str) -> None:
        self._episode = episode_id
        self._drone: list[list[float]] = []
        self._people: dict[str, list[list[float]]] = {}
        self._regions: list[dict[str, Any]] = []
        self._target: list[float] | None = None
        self._n_state = self._n_truth = 0

    def start(self, episode_id: str) -> None:
        with self._lock:
            self._reset(episode_id)

    def _on_state(self, _k: str, st: VehicleState) -> None:
        with self._lock:
            if st.episode_id != self._episode:
                return
            if self._n_state % STATE_EVERY == 0:
                self._drone.append([round(st.stamp, 2), *(round(v, 3) for v in st.position_m)])
            self._n_state += 1

    def _on_truth(self, _k: str, truth: GroundTruth) -> None:
        with self._lock:
            if truth.episode_id != self._episode:
                return
            self._target = list(truth.target_m)
            if self._n_truth % TRUTH_EVERY == 0:
                for o in truth.objects:
                    if o.is_person:
                        self._people.setdefault(o.obj_id, []).append(
                            [round(truth.stamp, 2), round(o.position_m[0], 3), round(o.position_m[1], 3)])
            self._n_truth += 1

    def _on_plan(self, _k: str, plan: PlanSnapshot) -> None:
        with self._lock:
            if plan.episode_id != self._episode:
                return
            self._regions = [{"lo": list(r.lo_m), "hi": list(r.hi_m), "label": r.label, "dynamic": r.is_dynamic}
                             for r in plan.regions]

    def save(self, path: Path) -> None:
        with self._lock:
            data = {"episode_id": self._episode, "target": self._target, "drone": self._drone,
                    "people": self._people, "regions": self._regions}
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(data, separators=(",", ":")))


def load_trace(path: Path) -> dict[str, Any]:
    return dict(json.loads(path.read_text()))
