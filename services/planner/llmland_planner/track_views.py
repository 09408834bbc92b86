"""How each method sees one track: is it moving, may it be a person, which buffer it gets.

The methods differ only here (DESIGN §6): ``llm`` and ``llm-land`` read the track's spec
(:func:`spec_in_force`); ``conservative`` treats every obstacle as a person; ``baseline``
knows geometry and motion only. Every method shares the tracker and the motion test
(:func:`is_moving`), so the comparison is about semantics.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from llmland_schemas import PERSON_BUFFER_M, PERSON_Z_MIN_M, SEMANTIC_METHODS, SafetySpec

from .hard_limit import PERSON_MAX_HEIGHT_M
from .settings import PlannerSettings
from .tracking import TrackedObstacle

#: a track up to this much (m) taller than the tallest person may still be one
PERSON_HEIGHT_SLACK_M = 0.3
#: the method that treats every obstacle as a person
BLIND_CAUTION_METHOD = "conservative"


@dataclass(frozen=True)
class TrackView:
    """One track as the planner uses it at a time: geometry, motion and class."""

    track: TrackedObstacle
    #: its predicted motion is used (a measured motion the method believes)
    moving: bool
    buffer_m: float
    z_min: float
    label: str
    dynamic: bool
    possible_person: bool
    #: known to be a person (their height is bounded)
    human: bool = False


def says_person(spec: SafetySpec) -> bool:
    """Whether a spec leaves its thing a possible person (as :func:`view_track` reads it, before the
    motion test): a person, or a mover it cannot say is not one."""
    return spec.is_human is True or (spec.is_dynamic and spec.is_human is not False)


def spec_in_force(track: TrackedObstacle, t_s: float, settings: PlannerSettings) -> SafetySpec:
    """The track's spec, or the most conservative class when it has none or it no longer holds.

    A spec of something that may move (a person, a vehicle, unknown) holds for
    ``spec_stale_s``; after that the track may be someone else. A static thing's spec holds
    while the track keeps its shape: if its height changes by more than
    ``spec_height_tolerance_m`` (a person stepped next to the rock and the two now form one
    blob) the spec is void. A static thing that moves is caught by :func:`view_track`.
    """
    attached = track.spec
    if attached is None:
        return SafetySpec.conservative()
    s, spec = settings, attached.spec
    if spec.is_dynamic or spec.is_human is not False:
        if t_s - attached.applied_s > s.spec_stale_s:
            return SafetySpec.conservative()
    else:
        height, was = track.height_m, attached.height_m
        if was < s.person_min_height_m <= height - s.spec_height_tolerance_m:  # grew to a person's height
            return SafetySpec.conservative()
    return spec


def is_moving(tr: TrackedObstacle, settings: PlannerSettings) -> bool:
    """The motion test every method shares: its visible edges move together faster than
    ``moving_speed_mps`` now (the rigid velocity) and, summed over its views, they have carried it
    more than ``moving_displacement_m`` from some earlier point of that path (the rigid excursion,
    :meth:`ObstacleTracker._extend_rigid_path`: a walker who turned back counts). A still object
    seen from new angles shifts its visible centroid (one edge at a time, as more or less of it
    comes into view), now and then both edges for one frame (a tree's crown and trunk seen in
    turn), but it does not travel metres: those shifts go back and forth and cancel in the sum."""
    s = settings
    displaced = tr.rigid_excursion_m > s.moving_displacement_m
    return displaced and float(np.linalg.norm(tr.rigid_velocity_mps[:2])) > s.moving_speed_mps


def person_sized(tr: TrackedObstacle, settings: PlannerSettings) -> bool:
    """A person's height (``person_min_height_m`` up to 2 m + slack) and footprint (half
    diagonal at most ``person_max_radius_m``)."""
    s = settings
    height = tr.height_m
    tall_enough = s.person_min_height_m <= height <= PERSON_MAX_HEIGHT_M + PERSON_HEIGHT_SLACK_M
    return tall_enough and tr.half_diagonal_m <= s.person_max_radius_m


def taller_than_a_person(tr: TrackedObstacle) -> bool:
    """A side view cut it at the top with more than a person's height (2 m + slack) already seen:
    whatever a spec says, it is not only a person (a trunk under a crown the forward camera
    cannot see, captioned "person": bounded at a person's height, its crown was flown into,
    urban seed 12), so no person's height bound applies to it."""
    return tr.touches_top and tr.height_m > PERSON_MAX_HEIGHT_M + PERSON_HEIGHT_SLACK_M


def view_track(tr: TrackedObstacle, t_s: float, method: str, settings: PlannerSettings) -> TrackView:
    """How the method sees one track at ``t_s``.

    Semantic methods trust the spec for the keep-out: a thing the KB calls static is not swept
    along an apparent motion (the visible surface of a tree shifts as the drone moves around it).
    Not for who may be a person: a thing with a static spec that moves or has moved (the rigid
    motion test, :func:`is_moving`) contradicts its spec, so the class was misread and it is a
    possible person, as geometry alone would say — whether the spec says "not human" or cannot
    say. (It used to take "not human" for a misread only when the thing was also person-sized;
    seen from above a person's blob is not, and the LLM without retrieval, which read a walking
    person as a static non-human thing, let them walk under its descent: exp1 seed 3.)
    """
    s, moving = settings, is_moving(tr, settings)
    if method in SEMANTIC_METHODS:
        spec = spec_in_force(tr, t_s, settings)
        # a person, or a mover the spec cannot say is not one; a static class that moves was
        # misread: never less careful than geometry alone
        person = says_person(spec) or (not spec.is_dynamic and (moving or tr.has_moved))
        believed = moving and (spec.is_dynamic or person)
        return TrackView(tr, believed, spec.buffer_m, spec.z_min, spec.label, spec.is_dynamic or person, person,
                         human=spec.is_human is True and not taller_than_a_person(tr))
    if method == BLIND_CAUTION_METHOD:
        return TrackView(tr, moving, PERSON_BUFFER_M, PERSON_Z_MIN_M, "person?", True, True)
    # geometry cannot tell a standing person from a post, but one who has walked stays a possible person
    return TrackView(tr, moving, s.baseline_margin_m, 0.0, "obstacle", moving, moving or tr.has_moved)
