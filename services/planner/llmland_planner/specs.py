"""Semantic specs on the planner side: queued until their release, then attached to tracks.

A ``reasoner/spec`` message carries one :class:`~llmland_schemas.ObjectSpec` per object; each
waits as a :class:`PendingSpec` until it is due (DESIGN §4), then every track at the object's
position takes it as an :class:`AttachedSpec` (the spec, when it arrived, the track's height
then). When several specs reach one track, :func:`more_careful` picks.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from llmland_schemas import ObjectSpec, SafetySpec
from llmland_schemas.arrays import FloatArray


@dataclass(frozen=True)
class PendingSpec:
    """An object's spec waiting for its release."""

    #: realtime: the sim time (s) it applies from (frame stamp + reported latency)
    apply_at_s: float
    #: the source frame's stamp (s): in lockstep the sim says up to which stamp specs apply
    stamp_s: float
    obj: ObjectSpec

    @property
    def spec(self) -> SafetySpec:
        return self.obj.spec

    @property
    def position_m(self) -> FloatArray:
        """The object's centroid (3,) in the world frame (m)."""
        return np.asarray(self.obj.centroid_m, dtype=float)

    @property
    def radius_m(self) -> float:
        """Horizontal radius (m) of the object: every track within it takes the spec."""
        return 0.5 * max(self.obj.size_m[0], self.obj.size_m[1])


@dataclass(frozen=True)
class AttachedSpec:
    """A spec as a track holds it."""

    spec: SafetySpec
    #: sim time (s) it was attached: a spec of something that may move goes stale after a while
    applied_s: float
    #: the track's height (m) then: a static thing's spec is void once the track's shape changes
    height_m: float


def more_careful(a: SafetySpec, b: SafetySpec) -> SafetySpec:
    """The spec asking more of the drone: human first, dynamic, the larger buffer, then ``z_min``."""

    def rank(s: SafetySpec) -> tuple[int, bool, float, float]:
        return (2 if s.is_human else 1 if s.is_human is None else 0, s.is_dynamic, s.buffer_m, s.z_min)

    return b if rank(b) > rank(a) else a
