"""The hard limit (DESIGN §6/§8): no person ever within 1 m of the vehicle — a reachable-set gate.

The vehicle is within a person's reach only below ``head height + 1 m``; the planner's hover
and cruise altitudes stay above :data:`REACH_CEILING_M`, so only the final descent (and a
climb-out from it) can come near anyone. Before the vehicle commits to that descent, and at
every tick during it, :func:`commit_clearance` checks that **every person who could be near —
tracked or not — stays farther than 1 m from the landing point until touchdown is complete**:

- a tracked possible person ``i`` (observed at age ``a_i`` s ago at ``c_i`` with footprint radius
  ``r_i`` and speed ``s_i``) can be anywhere within ``|x − c_i| ≤ r_i + R(a_i + T, s_i)`` by the
  end ``T`` of the descent, where :meth:`HumanMotionBounds.reach_m` integrates the speed bound;
  it counts while observed within ``recent_s``, and after that while it cannot have walked out
  of the coverage (:func:`lost_inside`): a person not detected where they must still be is where
  the coverage assumption failed (hidden under a tree), not someone the untracked bound covers;
- anyone not tracked is, by the coverage assumption, outside the downward camera's coverage
  radius ``R_cov`` (everyone inside it is detected every frame: :mod:`.coverage` bounds the
  detector's point count on a person from below and takes ``R_cov`` where that bound is at least
  the detector's minimum) at the newest downward frame, so can close in by at most
  ``R(T + its age, v_max)`` (the age at least one frame period);
- the landing point is the vehicle's horizontal position at touchdown, within ``xy_margin_m``.

Assumptions (what the guarantee rests on): people's speed ≤ ``max_speed_mps`` (ISO 13855:2010
sizes separation distances for a walking approach speed of 1.6 m/s), their speed grows by at
most ``step_speed_mps`` at once (a first step) plus ``max_accel_mps2`` thereafter from the
tracked speed (tracking error ≤ ``speed_error_mps``), heads ≤ :data:`PERSON_MAX_HEIGHT_M`;
every person within ``R_cov`` is detected in every downward frame (their torso contains
:class:`.coverage.PersonTorso`, nothing occludes it from above, the depth is complete over it);
people are classified as possible people (an unknown or stale class counts as one); the
vehicle follows its descent profile within ``time_margin_s`` and ``xy_margin_m``. If one of
them fails (a runner, a missed detection), the per-tick check sees the reachable set touch and
the vehicle climbs out while that is the shorter way out of reach (``LandingLogic``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from llmland_schemas import PERSON_HARD_LIMIT_M
from llmland_schemas.arrays import FloatArray

#: Tallest person assumed (m, head height above their feet; adult stature, 99.9th percentile < 2 m).
PERSON_MAX_HEIGHT_M = 2.0
#: A person's body axis lies within this distance (m) of any part of their body seen.
PERSON_BODY_RADIUS_M = 0.3
#: Above this height over the ground (m) nobody can be within the hard limit.
REACH_CEILING_M = PERSON_MAX_HEIGHT_M + PERSON_HARD_LIMIT_M


@dataclass(frozen=True)
class HumanMotionBounds:
    """How fast a person may close in (the assumptions of the hard limit)."""

    #: ISO 13855:2010, walking approach speed used to size separation distances (m/s)
    max_speed_mps: float = 1.6
    #: speed gained at once by a standing person's first step (m/s)
    step_speed_mps: float = 0.5
    #: acceleration bound after that (m/s²; gait initiation reaches walking speed within ~1 s)
    max_accel_mps2: float = 2.0
    #: error of the tracked speed (m/s)
    speed_error_mps: float = 0.3

    def reach_m(self, horizon_s: float, speed_mps: float | None = None) -> float:
        """Farthest horizontal distance (m) a person can cover in ``horizon_s``.

        ``speed_mps``: tracked speed (None: unknown, i.e. already at ``max_speed_mps``).
        ``∫₀^τ min(s₀ + a·t, v_max) dt`` with ``s₀ = speed + error + step`` (capped at v_max).
        """
        if not math.isfinite(horizon_s):  # a NaN horizon must not read as no time at all
            return math.inf
        tau = max(0.0, horizon_s)
        if speed_mps is not None and not math.isfinite(speed_mps):
            speed_mps = None
        v_max, a = self.max_speed_mps, self.max_accel_mps2
        s0 = v_max if speed_mps is None else min(v_max, speed_mps + self.speed_error_mps + self.step_speed_mps)
        t_cap = (v_max - s0) / a if a > 0 else math.inf
        if tau <= t_cap:
            return s0 * tau + 0.5 * a * tau * tau
        return s0 * t_cap + 0.5 * a * t_cap * t_cap + v_max * (tau - t_cap)


@dataclass(frozen=True)
class PersonHypothesis:
    """A tracked obstacle that may be a person (world frame; m, s, m/s)."""

    track_id: str
    centre_xy: FloatArray
    radius_m: float
    #: tracked speed; None while the tracker has no velocity estimate yet (one sighting): then
    #: unknown, i.e. already walking at the bound (:meth:`HumanMotionBounds.reach_m`)
    speed_mps: float | None
    age_s: float  # time since it was last observed
    label: str = ""


@dataclass(frozen=True)
class Clearance:
    """Worst margin (m) over people to the hard limit by the end of a manoeuvre; ≥ 0 is safe."""

    margin_m: float
    track_id: str  # the binding person ("" for the untracked bound, "-" for nobody)

    @property
    def safe(self) -> bool:
        return self.margin_m >= 0.0


def commit_clearance(landing_xy: FloatArray, people: list[PersonHypothesis], duration_s: float,
                     bounds: HumanMotionBounds, *, coverage_m: float, unseen_s: float,
                     xy_margin_m: float, recent_s: float = math.inf, lost_within_m: float | None = None,
                     hard_limit_m: float = PERSON_HARD_LIMIT_M) -> Clearance:
    """Margin to the hard limit if the vehicle is at ``landing_xy`` until ``duration_s`` from now.

    Tracked people: ``|landing − c| − r − R(age + T, speed)``; untracked people:
    ``R_cov − R(T + unseen_s)`` (unknown speed), ``unseen_s`` being how long ago the coverage was
    seen (the newest downward frame's age, at least one frame period). Each minus ``xy_margin_m``
    and the limit.

    Which tracks count: every one observed within ``recent_s``, and every older one that
    :func:`lost_inside` the disc of radius ``lost_within_m`` about the landing point (default
    ``coverage_m``): a person who cannot have left the coverage since they were last seen, yet is
    not detected in it, is where the coverage assumption has failed (hidden under a tree, the
    detector missed them), so they keep their own reachable set. Older tracks that could have left
    are the untracked bound's.
    """
    untracked = coverage_m - bounds.reach_m(duration_s + unseen_s) - xy_margin_m - hard_limit_m
    worst = Clearance(-math.inf if math.isnan(untracked) else untracked, "")
    within = coverage_m if lost_within_m is None else lost_within_m
    for person, dist in counted_people(landing_xy, people, bounds, recent_s, within):
        reach = bounds.reach_m(person.age_s + duration_s, person.speed_mps)
        margin = dist - person.radius_m - reach - xy_margin_m - hard_limit_m
        if math.isnan(margin):  # a NaN position or radius: nothing is known, so nothing is clear
            margin = -math.inf
        if margin < worst.margin_m:
            worst = Clearance(margin, person.track_id)
    return worst


def counted_people(landing_xy: FloatArray, people: list[PersonHypothesis], bounds: HumanMotionBounds,
                   recent_s: float, within_m: float) -> list[tuple[PersonHypothesis, float]]:
    """The people the gate counts, each with their horizontal distance (m) from ``landing_xy``:
    observed within ``recent_s``, or :func:`lost_inside` the disc of radius ``within_m`` (a NaN
    position or age always counts: nothing is known of it)."""
    p = np.asarray(landing_xy, dtype=float)[:2]
    out = []
    for person in people:
        dist = float(np.linalg.norm(p - person.centre_xy[:2]))
        # written as "not older" so that a NaN age counts too
        if not person.age_s > recent_s or lost_inside(dist, person, within_m, bounds) or math.isnan(dist):
            out.append((person, dist))
    return out


def axis_clearance_m(landing_xy: FloatArray, people: list[PersonHypothesis], bounds: HumanMotionBounds,
                     times_s: FloatArray, heights_m: FloatArray, *, xy_margin_m: float, recent_s: float,
                     within_m: float, hard_limit_m: float = PERSON_HARD_LIMIT_M) -> float:
    """Worst margin (m) to the hard limit over a vertical manoeuvre above ``landing_xy``.

    The vehicle is at ``heights_m`` (n,) above the people's ground at ``times_s`` (n,) s from now;
    each counted person (:func:`counted_people`) may be anywhere within their reachable disc then
    (:func:`commit_clearance`'s), and the distance to their body axis, which ends at
    :data:`PERSON_MAX_HEIGHT_M`, is ``hypot(horizontal gap, height above the head)``. Compares two
    ways out of reach (finishing a descent, climbing out): the vertical gap counts, so a vehicle
    still well above the heads may let someone come closer horizontally. +inf with nobody counted.
    """
    t, h = np.asarray(times_s, dtype=float), np.asarray(heights_m, dtype=float)
    above = np.maximum(0.0, h - PERSON_MAX_HEIGHT_M)
    worst = math.inf
    for person, dist in counted_people(landing_xy, people, bounds, recent_s, within_m):
        reach = np.array([bounds.reach_m(person.age_s + tk, person.speed_mps) for tk in t.tolist()])
        gap = np.maximum(0.0, dist - person.radius_m - reach - xy_margin_m)
        margin = float(np.min(np.hypot(gap, above))) - hard_limit_m
        worst = min(worst, -math.inf if math.isnan(margin) else margin)
    return worst


def lost_inside(dist_m: float, person: PersonHypothesis, within_m: float, bounds: HumanMotionBounds) -> bool:
    """Whether ``person``, last seen ``dist_m`` from the centre, is still within ``within_m`` of it
    wherever they walked since: ``dist + r + R(age, speed) < within_m`` (m). Infinite ``within_m``
    (no coverage claimed) keeps nobody: the test is only a check on the coverage assumption."""
    if not math.isfinite(within_m):
        return False
    return dist_m + person.radius_m + bounds.reach_m(person.age_s, person.speed_mps) < within_m
