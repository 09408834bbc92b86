"""Match depth blobs to ground-truth objects by world position.

Used by the oracle backend (labels each blob with the nearest truth object) and by the
held-out evaluation of simcap on depth-blob crops. Only plain numbers go in, so neither
needs the simulator: truth comes from ``sim/truth`` (:class:`GroundTruth`) messages or from
the training code.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from llmland_schemas import GroundTruth

#: A blob matches an object when its centroid is within the object's horizontal half
#: diagonal plus this slack (m) ...
MATCH_SLACK_M = 0.5
#: ... and, when the blob's size is given, its horizontal diagonal is at most this factor
#: times the object's plus :data:`SIZE_SLACK_M` (a blob of terrain reaching under a tree
#: is not that tree).
SIZE_FACTOR = 2.0
SIZE_SLACK_M = 2.0


@dataclass(frozen=True)
class TruthItem:
    """What the truth says about one object (world frame, SI units)."""

    obj_id: str
    cls: str
    position_m: tuple[float, float, float]  # bounding-box centre
    size_m: tuple[float, float, float]
    velocity_mps: tuple[float, float, float] = (0.0, 0.0, 0.0)
    dynamic: bool = False

    @property
    def speed_mps(self) -> float:
        return float(math.hypot(self.velocity_mps[0], self.velocity_mps[1]))

    @property
    def radius_m(self) -> float:
        """Half the horizontal diagonal of the object's box."""
        return 0.5 * math.hypot(self.size_m[0], self.size_m[1])


def items_from_truth(truth: GroundTruth) -> list[TruthItem]:
    """Truth items of a ``sim/truth`` message (the landing pad is left out: it is flat)."""
    return [
        TruthItem(
            obj_id=o.obj_id,
            cls=o.cls,
            position_m=(float(o.position_m[0]), float(o.position_m[1]), float(o.position_m[2])),
            size_m=(float(o.size_m[0]), float(o.size_m[1]), float(o.size_m[2])),
            velocity_mps=(float(o.velocity_mps[0]), float(o.velocity_mps[1]), float(o.velocity_mps[2])),
            dynamic=o.dynamic,
        )
        for o in truth.objects
        if o.cls != "pad"
    ]


def match_position(
    centroid_m: Sequence[float] | np.ndarray,
    items: Sequence[TruthItem],
    size_m: Sequence[float] | np.ndarray | None = None,
    slack_m: float = MATCH_SLACK_M,
) -> int | None:
    """Index of the truth item a blob (centroid, optional size) belongs to, or None.

    Candidates are items whose horizontal distance to the centroid is within their half
    diagonal plus ``slack_m`` (and, with ``size_m``, not much smaller than the blob); the
    one with the smallest distance relative to that reach wins, so a person standing under
    a tree crown matches the person, not the tree.
    """
    if not items:
        return None
    c = np.asarray(centroid_m, dtype=float)
    pos = np.array([it.position_m[:2] for it in items], dtype=float)
    radius = np.array([it.radius_m for it in items], dtype=float)
    reach = radius + slack_m
    d = np.hypot(pos[:, 0] - c[0], pos[:, 1] - c[1])
    ok = d <= reach
    if size_m is not None:
        blob_diag = float(np.hypot(size_m[0], size_m[1]))
        ok &= blob_diag <= SIZE_FACTOR * 2.0 * radius + SIZE_SLACK_M
    rel = np.where(ok, d / reach, np.inf)
    k = int(np.argmin(rel))
    return k if np.isfinite(rel[k]) else None
