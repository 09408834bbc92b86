"""Landing logic: approach above everyone's reach, then one fast committed descent when provably safe.

Two layers (DESIGN §6):

- the **hard limit** — no person ever within 1 m — is kept by the reachable-set gate of
  :mod:`.hard_limit`: the vehicle stays above :data:`~.hard_limit.REACH_CEILING_M` (head height
  plus 1 m) except in the final descent, and starts that descent only when every possible
  person, tracked or not, is provably farther than 1 m from the landing point until touchdown
  is complete. The gate is re-checked every tick of the descent: if a reachable set is about to
  touch (an assumption failed: someone faster than assumed, a missed detection), the vehicle
  takes the way out that keeps people farther: it climbs out only when that keeps a larger
  distance to everyone's body axis than finishing (:meth:`LandingLogic.climb_out_is_safer`: near
  the top of the reach), else finishes;
- the **semantic keep-out** (the specs' buffers, with predicted motion) shapes the path and the
  hover point (:meth:`~.world_model.WorldModel.regions`), and the landing disc must stay clear
  of moving things' predicted buffers and still things' footprints during the descent
  (:meth:`~.world_model.WorldModel.landing_regions`).

Phases: ``approach`` (climb to cruise altitude first, then fly to the hover point above the
target), ``hold`` (hover there until the gate opens), ``descend`` (the profile of
:mod:`.descent`), ``climb-out`` (back up to the hover point), ``touchdown`` (thrust off).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from enum import StrEnum
from functools import cached_property

import numpy as np
from llmland_schemas.arrays import FloatArray

from .coverage import HEIGHT_STEP_M
from .descent import DescentProfile, climb_out_heights
from .ground import ReachFloor
from .hard_limit import (
    REACH_CEILING_M,
    Clearance,
    HumanMotionBounds,
    PersonHypothesis,
    axis_clearance_m,
    commit_clearance,
)
from .regions import UNSEEN_TOP, UnsafeRegion
from .settings import PlannerSettings

#: arrived at a hover point: within this height (m) of it and slower than this (m/s)
ARRIVE_HEIGHT_TOL_M = 0.3
ARRIVE_SPEED_MPS = 0.5
#: hover points keep this clearance (m) above the regions covering them
HOVER_REGION_CLEARANCE_M = 0.5
#: lost the hover point: farther than this (m) horizontally goes back to approach
HOLD_LOST_M = 1.7
#: heights (m) tried for a lowered hold: the coverage table's own step
HOLD_HEIGHT_STEP_M = HEIGHT_STEP_M
#: time step (s) of the two ways out of reach compared when a descent's check fails
WAY_OUT_STEP_S = 0.02


class Phase(StrEnum):
    APPROACH = "approach"
    HOLD = "hold"
    DESCEND = "descend"
    CLIMB_OUT = "climb-out"
    TOUCHDOWN = "touchdown"


@dataclass(frozen=True)
class Surroundings:
    """What the landing logic needs from the world model at one tick."""

    regions: list[UnsafeRegion]
    people: list[PersonHypothesis]
    #: radius (m) around the vehicle within which the downward camera sees everyone (0: none), or
    #: a function giving it, called only when it is needed (see :attr:`coverage_m`)
    coverage: float | Callable[[], float]
    #: regions the landing disc must stay clear of during a descent of the given duration (s)
    landing_regions: Callable[[float], list[UnsafeRegion]]
    #: age (s) of the newest downward frame the coverage stands on: untracked people were outside
    #: the coverage then, and have been walking since
    coverage_age_s: float = 0.0
    #: the hard limit's floor (m) at plan-view points ``(..., 2)``: out of everyone's reach over the
    #: terrain (:class:`~.ground.ReachFloor`); None: flat ground, ``REACH_CEILING_M`` over the target
    reach_floor: ReachFloor | None = None
    #: radius (m) about the landing point that the downward camera would cover from a hover at a
    #: given height (m) above the target (None: unknown; :meth:`LandingLogic.observation_height_m`)
    coverage_at: Callable[[float], float] | None = None

    def floor_at(self, xy: FloatArray) -> float:
        """The reach floor (m) at one plan-view point ``(2,)``, or -inf when none is given."""
        return -math.inf if self.reach_floor is None else float(self.reach_floor(np.asarray(xy, dtype=float)[:2]))

    @cached_property
    def coverage_m(self) -> float:
        """The coverage radius (m), evaluated at most once: only the gate of a descent not yet
        committed reads it (and displays), and a radius at a new height or tilt costs a table
        entry of :func:`~.coverage.detection_radius_m` (tens of ms)."""
        return float(self.coverage() if callable(self.coverage) else self.coverage)


@dataclass(frozen=True)
class GateDecision:
    """The gate at one tick: is the rest of the descent provably clear?"""

    duration_s: float  # until touchdown is complete (profile + margin + dwell)
    clearance: Clearance  # the hard limit's worst margin
    disc_clear: bool  # the semantic / geometric landing-disc check

    @property
    def open(self) -> bool:
        return self.clearance.safe and self.disc_clear


def disc_clear(target_xy: FloatArray, radius_m: float, regions: list[UnsafeRegion]) -> bool:
    """True when no region's footprint (box in x, y) meets the disc around ``target_xy``."""
    cx, cy = np.asarray(target_xy, dtype=float)[:2].tolist()
    for r in regions:  # scalar maths: every region, every control tick while holding
        lo_x, lo_y, _ = r.lo.tolist()
        hi_x, hi_y, _ = r.hi.tolist()
        dx = min(max(cx, lo_x), hi_x) - cx  # to the footprint's nearest point
        dy = min(max(cy, lo_y), hi_y) - cy
        if math.sqrt(dx * dx + dy * dy) < radius_m:  # np.linalg.norm's sum, bit for bit
            return False
    return True


def hover_altitude(target_m: FloatArray, regions: list[UnsafeRegion], settings: PlannerSettings, *,
                   footprints_only: bool = False) -> float:
    """Cruise altitude above the target, raised over any region that covers the hover point and can
    be overflown (one too tall to overfly cannot be honoured by height; the world model keeps
    still ones off the landing disc).

    ``footprints_only``: raise only over regions whose footprint itself covers the target (the box
    less its horizontal buffer) and over boxes guessed above a view cut at the top (what may reach
    over the target there is unknown), not over those that cover it with their buffer alone: the
    height the vertical column above the target must keep (:meth:`LandingLogic.update`)."""
    t = np.asarray(target_m, dtype=float)
    z = t[2] + settings.cruise_altitude_m
    ceiling = t[2] + settings.max_altitude_m - HOVER_REGION_CLEARANCE_M
    tx, ty = float(t[0]), float(t[1])
    for r in regions:  # scalar maths: this runs over every region several times per control tick
        lo_x, lo_y, _ = r.lo.tolist()
        hi_x, hi_y, hi_z = r.hi.tolist()
        if hi_z + HOVER_REGION_CLEARANCE_M > ceiling:
            continue
        grow = 0.0 if not footprints_only or r.meta.get(UNSEEN_TOP) else r.buffer_m
        if lo_x + grow <= tx <= hi_x - grow and lo_y + grow <= ty <= hi_y - grow:
            z = max(z, hi_z + HOVER_REGION_CLEARANCE_M)
    return z


@dataclass
class LandingLogic:
    """The phase machine. ``update`` returns the phase and the current goal point."""

    target_m: FloatArray
    settings: PlannerSettings
    phase: Phase = Phase.APPROACH
    climbed: bool = False
    last_gate: GateDecision | None = None
    #: coverage radius (m) of the last uncommitted gate, the one a descent was committed on
    commit_coverage_m: float = math.inf
    #: the approach's hover height (z, m: over every region holding the target) and the height the
    #: vehicle holds and starts its descent at (lower when the coverage needs it; see ``update``)
    approach_z: float = math.nan
    hold_z: float = math.nan
    profile: DescentProfile = field(init=False)
    bounds: HumanMotionBounds = field(init=False)
    _untracked_passes: dict[tuple[float, float], bool] = field(init=False, default_factory=dict)

    def __post_init__(self) -> None:
        s = self.settings
        self.profile = DescentProfile(s.descent_speed_mps, s.descent_accel_mps2, s.descent_brake_mps2,
                                      s.descent_touchdown_speed_mps)
        self.bounds = HumanMotionBounds(s.human_max_speed_mps, s.human_step_speed_mps, s.human_max_accel_mps2,
                                        s.human_speed_error_mps)
        if s.cruise_altitude_m < REACH_CEILING_M + ARRIVE_HEIGHT_TOL_M:
            raise ValueError(f"cruise_altitude_m must be >= {REACH_CEILING_M + ARRIVE_HEIGHT_TOL_M} m "
                             "(above everyone's reach with a tracking margin)")

    def descent_duration_s(self, height_m: float, sink_mps: float) -> float:
        """Time (s) the vehicle stays within reach for the rest of a descent from ``height_m`` sinking
        at ``sink_mps``: the profile's time to touchdown, the tracking lag margin, the touchdown dwell."""
        s = self.settings
        return (self.profile.time_to_touchdown_s(height_m, sink_mps, s.touchdown_height_m)
                + s.descent_time_margin_s + s.touchdown_dwell_s)

    def gate(self, height_m: float, sink_mps: float, around: Surroundings, *, committed: bool = False,
             offset_m: float = 0.0) -> GateDecision:
        """The hard-limit gate for the rest of a descent from ``height_m`` sinking at ``sink_mps``.

        ``offset_m``: the vehicle's horizontal distance (m) from the target now; the descent
        re-centres on the target, so until touchdown the vehicle is within this plus the landing
        point's error (``landing_xy_margin_m``) of it: the hold's arrival tolerance
        (``align_radius_m``) is wider than that error alone.

        ``committed``: re-checking a descent under way. The untracked bound was shown at the
        commit for the whole descent (anyone outside the coverage then cannot reach the landing
        point before touchdown) and only holds more easily since; the coverage shrinks as the
        vehicle sinks, so it is not re-evaluated. Everyone tracked is re-checked.
        """
        s = self.settings
        duration = self.descent_duration_s(height_m, sink_mps)
        coverage = around.coverage_m if s.require_coverage and not committed else float("inf")
        # untracked people: outside the coverage at the newest downward frame, at least one frame
        # period ago (a frame may land between two checks), walking since
        unseen_s = max(s.coverage_frame_period_s, around.coverage_age_s)
        if not committed:
            self.commit_coverage_m = coverage
        # tracks lost where they cannot have left the coverage shown at the commit keep their own
        # reachable set while the descent is under way (hard_limit.lost_inside)
        clearance = commit_clearance(self.target_m[:2], around.people, duration, self.bounds, coverage_m=coverage,
                                     unseen_s=unseen_s, xy_margin_m=self._xy_margin_m(offset_m),
                                     recent_s=self._recent_s(), lost_within_m=self.commit_coverage_m)
        clear = disc_clear(self.target_m[:2], s.landing_disc_radius_m, around.landing_regions(duration))
        self.last_gate = GateDecision(duration, clearance, clear)
        return self.last_gate

    def _xy_margin_m(self, offset_m: float) -> float:
        """The landing point's horizontal error (m) with the vehicle ``offset_m`` off the target now."""
        return self.settings.landing_xy_margin_m + max(0.0, offset_m)

    def _recent_s(self) -> float:
        """How recently (s) a track must have been seen to count one by one. Without the coverage
        assumption (``require_coverage`` off) no track can be left to the untracked bound, however
        old: every possible person counts."""
        s = self.settings
        return s.recent_observation_s if s.require_coverage else math.inf

    def climb_out_is_safer(self, height_m: float, sink_mps: float, offset_m: float, around: Surroundings) -> bool:
        """Whether climbing out now keeps every counted person farther from the vehicle than
        finishing the descent would (:func:`~.hard_limit.axis_clearance_m` over each way out).

        Finishing follows the descent profile to touchdown and the dwell; climbing out brakes at the
        profile's own deceleration (what the MPC is known to track) and climbs at
        ``climb_speed_mps`` until above :data:`~.hard_limit.REACH_CEILING_M` over the target (or the
        reach floor there, if higher). Sinking at 2–3 m/s the vehicle drops another ≈ 0.5 m before
        it can climb, and climbs at 1.5 m/s: low down, finishing is out of reach sooner; near the
        top of the reach, climbing keeps the vehicle above the heads. The distance to a body axis
        counts the height above the head, so neither time in reach nor one height threshold decides.
        """
        s = self.settings
        exit_m = max(REACH_CEILING_M, around.floor_at(self.target_m) - float(self.target_m[2]))
        finish = self.profile.time_to_touchdown_s(height_m, sink_mps, s.touchdown_height_m) + s.touchdown_dwell_s
        n = int(math.ceil(finish / WAY_OUT_STEP_S)) + 1
        finish_h, _ = self.profile.reference(height_m, sink_mps, WAY_OUT_STEP_S, n)
        climb_h = climb_out_heights(height_m, sink_mps, exit_m, s.climb_speed_mps, s.descent_brake_mps2, WAY_OUT_STEP_S)

        def margin(heights: FloatArray) -> float:
            return axis_clearance_m(self.target_m[:2], around.people, self.bounds,
                                    WAY_OUT_STEP_S * np.arange(len(heights)), heights,
                                    xy_margin_m=self._xy_margin_m(offset_m), recent_s=self._recent_s(),
                                    within_m=self.commit_coverage_m)

        return margin(climb_h) > margin(finish_h)

    @property
    def lowered_hold(self) -> bool:
        """True when the vehicle holds below the approach's hover height (:meth:`update`)."""
        return bool(self.hold_z < self.approach_z - ARRIVE_HEIGHT_TOL_M)

    def observation_height_m(self, bottom_m: float, top_m: float, around: Surroundings) -> float | None:
        """The lowest hold height (m above the target, ``bottom_m`` and up in ``HOLD_HEIGHT_STEP_M``
        steps, at most ``top_m``) from which the gate's untracked-people bound can pass: the
        coverage radius there is at least what anyone outside it could walk before touchdown
        (:func:`~.hard_limit.commit_clearance` with nobody tracked). The lowest, because a shorter
        descent leaves tracked people less time to close in. None when no height passes (or the
        coverage is unknown)."""
        if around.coverage_at is None or not self.settings.require_coverage:
            return None
        for i in range(int(math.floor((top_m - bottom_m) / HOLD_HEIGHT_STEP_M + 1e-9)) + 1):
            h = bottom_m + i * HOLD_HEIGHT_STEP_M
            if self._untracked_bound_passes(h, around.coverage_at(h)):
                return h
        return None

    def _untracked_bound_passes(self, height_m: float, coverage_m: float) -> bool:
        """Whether the gate's untracked-people bound passes for a descent from ``height_m`` with the
        coverage ``coverage_m`` (memoised: the hold scan runs every control tick while a hover is
        raised, over the same few heights and radii). The margin takes the farthest the hold may
        be off the target when it counts as arrived (``align_radius_m``), as the gate will."""
        key = (height_m, coverage_m)
        if key not in self._untracked_passes:
            s = self.settings
            self._untracked_passes[key] = commit_clearance(
                self.target_m[:2], [], self.descent_duration_s(height_m, 0.0), self.bounds, coverage_m=coverage_m,
                unseen_s=s.coverage_frame_period_s, xy_margin_m=s.landing_xy_margin_m + s.align_radius_m).safe
        return self._untracked_passes[key]

    def _hold_heights(self, around: Surroundings) -> tuple[float, float]:
        """The approach's hover height and the hold height (z, m).

        The approach ends above every region that holds the target (:func:`hover_altitude`). The
        downward camera's coverage collapses above a few metres (a person's torso seen from high up
        covers too few pixels to be detected for sure; :mod:`.coverage`), and with no coverage the
        hard-limit gate can never open. So when only regions' buffers raised it, the vehicle holds
        lower, straight above the target: at the lowest height from which the gate can pass
        (:meth:`observation_height_m`), from what covers the target with its footprint
        (``footprints_only``), the cruise altitude and the reach floor up. What it leaves above it
        there is the keep-out of regions that hold the target with their buffer alone, not the
        things themselves: the final descent passes there anyway, the column above the landing
        point being clear of still things' footprints (the gate's disc check)."""
        s, tgt = self.settings, np.asarray(self.target_m, dtype=float)
        floor = around.floor_at(tgt)
        approach = max(hover_altitude(tgt, around.regions, s), floor)
        if approach <= tgt[2] + s.cruise_altitude_m + ARRIVE_HEIGHT_TOL_M:
            return approach, approach
        kept = max(hover_altitude(tgt, around.regions, s, footprints_only=True), floor)
        if kept >= approach - ARRIVE_HEIGHT_TOL_M:
            return approach, approach
        seen = self.observation_height_m(kept - tgt[2], approach - tgt[2], around)
        return approach, approach if seen is None else tgt[2] + seen

    def update(self, pos_m: FloatArray, vel_mps: FloatArray, t_s: float,
               around: Surroundings) -> tuple[Phase, FloatArray]:
        s = self.settings
        tgt = np.asarray(self.target_m, dtype=float)
        pos, vel = np.asarray(pos_m, dtype=float), np.asarray(vel_mps, dtype=float)
        # never below the reach floor over the target (terrain rising around it)
        self.approach_z, self.hold_z = self._hold_heights(around)
        approach = np.array([tgt[0], tgt[1], self.approach_z])
        hover = np.array([tgt[0], tgt[1], self.hold_z])
        height = float(pos[2] - tgt[2])
        horiz = float(np.linalg.norm(pos[:2] - tgt[:2]))

        if self.phase == Phase.TOUCHDOWN:
            return self.phase, tgt
        if self.phase == Phase.DESCEND:
            if height < s.touchdown_height_m:
                self.phase = Phase.TOUCHDOWN
                return self.phase, tgt
            sink = max(0.0, -float(vel[2]))
            gate = self.gate(height, sink, around, committed=True, offset_m=horiz)
            if gate.open:
                return self.phase, tgt
            if not gate.clearance.safe:  # someone may reach the vehicle: the way out that keeps them farther
                climb = self.climb_out_is_safer(height, sink, horiz, around)
            else:  # only the landing disc is blocked (a thing moving onto the pad): do not land on it
                climb = height > s.commit_height_m
            if climb:
                self.phase = Phase.CLIMB_OUT
                return self.phase, hover
            return self.phase, tgt
        if not self.climbed:  # take-off climb: above everyone's reach before flying anywhere
            climb_z = max(tgt[2] + s.cruise_altitude_m, around.floor_at(pos) + ARRIVE_HEIGHT_TOL_M)
            if pos[2] >= climb_z - ARRIVE_HEIGHT_TOL_M:
                self.climbed = True
            else:
                return self.phase, np.array([pos[0], pos[1], climb_z])

        def arrived_at(point: FloatArray) -> bool:
            return (horiz < s.align_radius_m and abs(pos[2] - point[2]) < ARRIVE_HEIGHT_TOL_M
                    and float(np.linalg.norm(vel)) < ARRIVE_SPEED_MPS)

        arrived = arrived_at(hover)
        if self.phase in (Phase.APPROACH, Phase.CLIMB_OUT) and (arrived or (
                self.phase == Phase.APPROACH and arrived_at(approach))):
            self.phase = Phase.HOLD  # a lowered hold is reached straight down from the approach's end
        if self.phase == Phase.HOLD:
            if arrived and self.gate(height, max(0.0, -float(vel[2])), around, offset_m=horiz).open:
                self.phase = Phase.DESCEND
                return self.phase, tgt
            if horiz > HOLD_LOST_M:
                self.phase = Phase.APPROACH
        return self.phase, approach if self.phase == Phase.APPROACH else hover
