"""Episode scoring exactly as DESIGN §8: one scorer owns every metric and builds the result.

Success = touchdown within 0.5 m (horizontal) of the target, no collision, and never
within 1 m of any person. Distances to a person are measured from the drone centre to the
person's body axis (a vertical segment from their feet to the top of their head).

:class:`EpisodeScore` is fed by the simulation each tick (people, contacts, the vehicle's
height and speed, the command applied) and by the sim service (specs received, lockstep
deadline misses); :meth:`EpisodeScore.result` turns it, with the perception clock's figures,
into the :class:`~llmland_schemas.EpisodeResult`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from llmland_schemas import PERSON_HARD_LIMIT_M, ControlCommand, EpisodeResult, SafetySpecMessage, vec3

if TYPE_CHECKING:
    from .perception_clock import PerceptionClock

SUCCESS_RADIUS_M = 0.5
#: Touchdown: this close to the ground (m, vehicle centre) and this slow (m/s) ...
TOUCHDOWN_HEIGHT_M = 0.15
TOUCHDOWN_SPEED_MPS = 0.35
#: ... (ground contact counts as close when the centre is within this much more, m) ...
TOUCHDOWN_CONTACT_SLACK_M = 0.1
#: ... for this long (s) counts as landed.
TOUCHDOWN_DWELL_S = 0.3
#: Hitting the ground faster than this (m/s) is a crash.
CRASH_SPEED_MPS = 2.5


def distance_to_person(drone_m: np.ndarray, person_base_m: np.ndarray, height_m: float) -> float:
    """Distance (m) from a point to a person's axis segment [base, base + height·ẑ]."""
    dz = float(np.clip(drone_m[2] - person_base_m[2], 0.0, height_m))
    closest = np.array([person_base_m[0], person_base_m[1], person_base_m[2] + dz])
    return float(np.linalg.norm(drone_m - closest))


@dataclass
class EpisodeScore:
    """Accumulates what the result needs while an episode runs."""

    target_m: np.ndarray
    min_person_distance_m: dict[str, float] = field(default_factory=dict)
    close_call_people: set[str] = field(default_factory=set)
    collisions: list[str] = field(default_factory=list)
    touchdown_m: np.ndarray | None = None
    touchdown_t_s: float | None = None
    #: control ticks whose command came late (lockstep) or whose controller overran its period
    deadline_misses: int = 0
    #: ticks flown without a command (held input or the vehicle-side failsafe)
    commands_missing: int = 0
    mpc_solve_ms: list[float] = field(default_factory=list)
    #: spec latencies (ms) as their producers reported them, and fallback object specs received
    spec_latencies_ms: list[float] = field(default_factory=list)
    fallback_specs: int = 0
    _low_and_slow_since_s: float | None = None

    @property
    def finished(self) -> bool:
        """The episode has ended on its own: landed or collided."""
        return self.touchdown_m is not None or bool(self.collisions)

    def observe_people(self, drone_m: np.ndarray, people: dict[str, tuple[np.ndarray, float]]) -> None:
        """Update min distances; ``people`` maps id → (base position, height)."""
        for pid, (base, height) in people.items():
            d = distance_to_person(drone_m, base, height)
            if d < self.min_person_distance_m.get(pid, np.inf):
                self.min_person_distance_m[pid] = d
            if d < PERSON_HARD_LIMIT_M:
                self.close_call_people.add(pid)

    def observe_collision(self, obj_id: str) -> None:
        if obj_id not in self.collisions:
            self.collisions.append(obj_id)

    def observe_ground(self, t_s: float, drone_m: np.ndarray, speed_mps: float, height_m: float,
                       ground_contact: bool) -> None:
        """One tick near the ground: a crash (contact faster than ``CRASH_SPEED_MPS``) or a
        touchdown (low and slow for ``TOUCHDOWN_DWELL_S``, stamped when that began)."""
        if ground_contact and speed_mps > CRASH_SPEED_MPS:
            self.observe_collision("ground")
        low_and_slow = (ground_contact or height_m < TOUCHDOWN_HEIGHT_M) and speed_mps < TOUCHDOWN_SPEED_MPS
        if not (low_and_slow and height_m < TOUCHDOWN_HEIGHT_M + TOUCHDOWN_CONTACT_SLACK_M):
            self._low_and_slow_since_s = None
        elif self._low_and_slow_since_s is None:
            self._low_and_slow_since_s = t_s
        elif t_s - self._low_and_slow_since_s >= TOUCHDOWN_DWELL_S:
            self.observe_touchdown(drone_m, self._low_and_slow_since_s)

    def observe_command(self, cmd: ControlCommand | None, control_period_ms: float) -> None:
        """The command applied this tick (None: none arrived)."""
        if cmd is None:
            self.commands_missing += 1
            return
        if cmd.tick_ms is not None and cmd.tick_ms > control_period_ms:
            self.deadline_misses += 1  # the controller overran its control period
        if cmd.solve_ms is not None:
            self.mpc_solve_ms.append(cmd.solve_ms)

    def observe_deadline_miss(self) -> None:
        """Lockstep: the tick's command did not come within the wait."""
        self.deadline_misses += 1

    def observe_spec(self, msg: SafetySpecMessage) -> None:
        """A spec for this episode: its reported latency, and how many of its objects fell back."""
        self.spec_latencies_ms.append(msg.latency_ms)
        self.fallback_specs += sum(o.spec.source == "fallback" for o in msg.objects)

    def observe_touchdown(self, drone_m: np.ndarray, t_s: float) -> None:
        if self.touchdown_m is None:
            self.touchdown_m = np.asarray(drone_m, dtype=float).copy()
            self.touchdown_t_s = t_s

    @property
    def touchdown_error_m(self) -> float | None:
        if self.touchdown_m is None:
            return None
        return float(np.linalg.norm(self.touchdown_m[:2] - self.target_m[:2]))

    def outcome(self, *, aborted: bool = False) -> tuple[bool, str]:
        """(success, outcome) with the precedence collision > close call > landing."""
        if self.collisions:
            return False, "collision"
        if self.close_call_people:
            return False, "close_call"
        if self.touchdown_m is None:
            return False, "aborted" if aborted else "timeout"
        err = self.touchdown_error_m
        if err is not None and err <= SUCCESS_RADIUS_M:
            return True, "landed"
        return False, "off_target"

    def result(self, *, aborted: bool, perception: PerceptionClock | None, **fields: Any) -> EpisodeResult:
        """The scored :class:`EpisodeResult`; ``perception``: the lockstep perception clock (None in
        realtime or without perception); ``fields``: the envelope and run figures the
        simulation knows (drone_id, stamp, seq, episode_id, world, seed, method, clock,
        sim_time_s, wall_time_s, control_ticks, latency_model, rrd_path)."""
        success, outcome = self.outcome(aborted=aborted)
        solve = np.asarray(self.mpc_solve_ms, dtype=float)
        result = EpisodeResult(
            success=success,
            outcome=outcome,  # type: ignore[arg-type]
            touchdown_m=vec3(self.touchdown_m) if self.touchdown_m is not None else None,
            touchdown_error_m=self.touchdown_error_m,
            time_to_land_s=self.touchdown_t_s,
            min_person_distance_m={k: round(v, 4) for k, v in self.min_person_distance_m.items()},
            close_calls=len(self.close_call_people),
            collisions=list(self.collisions),
            deadline_misses=self.deadline_misses,
            commands_missing=self.commands_missing,
            mpc_solve_ms_p50=float(np.percentile(solve, 50)) if solve.size else None,
            mpc_solve_ms_p95=float(np.percentile(solve, 95)) if solve.size else None,
            fallback_specs=self.fallback_specs,
            **fields,
        )
        if perception is not None:  # lockstep: the latencies that took effect (DESIGN §4)
            result.perception_requests = perception.requests
            result.perception_lost = perception.lost
            result.perception_degraded = perception.ever_degraded
            result.perception_degraded_s = round(perception.degraded_s, 3)
            if perception.effective_latency_ms:
                result.spec_latency_ms_mean = float(np.mean(perception.effective_latency_ms))
                result.spec_compute_ms_mean = float(np.mean(perception.compute_ms))
        elif self.spec_latencies_ms:  # realtime: what the producers reported
            result.spec_latency_ms_mean = float(np.mean(self.spec_latencies_ms))
            result.spec_compute_ms_mean = result.spec_latency_ms_mean
        return result
