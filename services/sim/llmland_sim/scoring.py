"""Episode scoring exactly as DESIGN §8.

Success = touchdown within 0.5 m (horizontal) of the target, no collision, and never
within 1 m of any person. Distances to a person are measured from the drone centre to the
person's body axis (a vertical segment from their feet to the top of their head).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from llmland_schemas import PERSON_HARD_LIMIT_M

SUCCESS_RADIUS_M = 0.5


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
