"""Run one episode over the bus: send the mission, wait for its EpisodeResult."""

from __future__ import annotations

import logging
import threading
import time
import uuid
from collections.abc import Callable

from llmland_schemas import EpisodeResult, MissionGoal, Topic, VehicleState, key
from llmland_schemas.bus import Bus

log = logging.getLogger(__name__)


def new_episode_id(world: str, seed: int, method: str) -> str:
    return f"{world}-s{seed}-{method}-{uuid.uuid4().hex[:6]}"


class EpisodeRunner:
    """Sends missions on one drone's keys and collects their results."""

    def __init__(self, bus: Bus, drone_id: str = "d0") -> None:
        self.bus = bus
        self.drone_id = drone_id
        self._cond = threading.Condition()
        self._results: dict[str, EpisodeResult] = {}
        self._started: set[str] = set()
        self._aborted = False
        self._latest: str | None = None  # the episode of the newest state seen
        self._mine: set[str] = set()  # the episodes sent here
        bus.subscribe(key(drone_id, Topic.RESULT), EpisodeResult, self._on_result)
        bus.subscribe(key(drone_id, Topic.STATE), VehicleState, self._on_state)

    def _on_result(self, _k: str, msg: EpisodeResult) -> None:
        with self._cond:
            self._results[msg.episode_id] = msg
            self._cond.notify_all()

    def _on_state(self, _k: str, msg: VehicleState) -> None:
        self._latest = msg.episode_id
        if msg.episode_id not in self._started:
            with self._cond:
                self._started.add(msg.episode_id)
                self._cond.notify_all()

    def stop(self, mission: MissionGoal) -> None:
        """Ask the sim to end ``mission``: the running episode is aborted, a queued one not flown."""
        self.bus.publish(key(self.drone_id, Topic.MISSION), mission.model_copy(update={"command": "stop"}))

    def busy_with(self) -> str | None:
        """The episode this drone's sim flies now when it is not one sent here (the newest state's)."""
        return self._latest if self._latest is not None and self._latest not in self._mine else None

    def _unlocked(self, check: Callable[[], None]) -> None:
        """Run a wait's ``check`` without holding the condition: it may ask the bus (a liveliness
        query, up to a second) while results and states arrive on the bus's callback threads."""
        self._cond.release()
        try:
            check()
        finally:
            self._cond.acquire()

    def abort(self) -> None:
        """Make a waiting and every later :meth:`run` raise ``RuntimeError`` (an interrupted experiment)."""
        with self._cond:
            self._aborted = True
            self._cond.notify_all()

    def _check_aborted(self) -> None:
        if self._aborted:
            raise RuntimeError("episode aborted")

    def run(self, mission: MissionGoal, wall_timeout_s: float | None = None,
            watch: Callable[[], None] | None = None) -> EpisodeResult:
        """Start ``mission`` (re-sent until the sim answers) and wait for its result.

        ``watch``: called at each wake-up of the wait (every 0.5 s before the sim starts the
        episode, every second after); what it raises ends the wait (a
        stack's check that its simulator is still running: :meth:`~.stacks.RunningStack.watch`).
        """
        mission_key = key(self.drone_id, Topic.MISSION)
        wall_timeout_s = wall_timeout_s or max(120.0, 20.0 * mission.timeout_s)
        deadline = time.monotonic() + wall_timeout_s
        check = watch or (lambda: None)
        self._mine.add(mission.episode_id)
        with self._cond:
            while mission.episode_id not in self._started and mission.episode_id not in self._results:
                self._check_aborted()
                self._unlocked(check)
                if time.monotonic() > deadline:
                    self.stop(mission)  # it may still be queued behind another episode: not to be flown
                    raise TimeoutError(f"the sim did not start episode {mission.episode_id} within "
                                       f"{wall_timeout_s:.0f} s of wall time")
                self.bus.publish(mission_key, mission)
                self._cond.wait_for(lambda: mission.episode_id in self._started or mission.episode_id in self._results,
                                    0.5)  # a state or result that came during the check ends it at once
            while mission.episode_id not in self._results:
                self._check_aborted()
                self._unlocked(check)
                left = deadline - time.monotonic()
                if left <= 0:
                    self.stop(mission)
                    raise TimeoutError(f"no result for episode {mission.episode_id} after {wall_timeout_s:.0f} s")
                self._cond.wait_for(lambda: mission.episode_id in self._results, min(left, 1.0))
            return self._results.pop(mission.episode_id)
