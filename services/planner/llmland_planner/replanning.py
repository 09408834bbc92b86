"""The path side of the planner: search on a worker thread, adopt plans by the mission's clock, follow.

Path search runs on a worker thread so a slow search never blocks the control loop. When
its plan is adopted depends on the mission's clock:

- ``realtime``: the search is bounded by ``search_budget_s`` of wall time and its plan is
  adopted once the sim clock has advanced by the search's measured wall time;
- ``lockstep``: the search is bounded by ``search_max_expansions`` (not wall time) and its
  plan is adopted exactly ``search_budget_s`` of sim time after it started (the tick waits
  for the worker if it is late), so a seeded episode flies the same way on any machine.

A failed search doubles the next one's budget (:meth:`Replanner.search_budget_scale`); the
adopted path is followed by :meth:`Replanner.reference` (a window of the path ahead and its
corridors' half-spaces for the MPC).
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np
from llmland_schemas.arrays import FloatArray

from .corridors import Corridor, corridors_for_path, halfspaces_at_times
from .mpc import Halfspaces
from .path import Path, resample
from .regions import UNSEEN_TOP, UnsafeRegion, boxes_array, escape_distance_m, no_closer_than_now, segments_hit_boxes
from .search import SearchConfig, plan
from .settings import PlannerSettings

log = logging.getLogger(__name__)

#: Farther than this (m) outside the current corridor, its rows are dropped and we replan.
CORRIDOR_EXIT_M = 0.3
#: a failed search doubles the next one's budget, at most this many times in a row (×16)
SEARCH_BUDGET_DOUBLINGS = 4
#: The search's workspace spans ± this (m) horizontally (up to ``max_altitude_m``).
WORKSPACE_HALF_XY_M = 100.0
#: A goal that moved farther than this (m) from the active plan's is replanned for.
GOAL_MOVED_REPLAN_M = 0.3
#: Inside a region at the start, the start clearance reaches this far (m) beyond its depth.
START_CLEARANCE_MARGIN_M = 0.3
#: The nearest path point is looked for among this many points past the last progress.
PROGRESS_WINDOW_POINTS = 40
#: a path that grazes a region by less than this (m) is not blocked by it: the resampled path
#: cuts the search's sampled chains by millimetres, and a path along a shrunk box's face grazed it
PATH_GRAZE_M = 0.05
#: Sim times closer than this (s) are the same instant.
EPS_S = 1e-9


@dataclass
class ActivePlan:
    path: Path
    corridors: list[Corridor]
    goal_m: FloatArray
    made_at_s: float
    search_ms: float
    progress_idx: int = 0
    #: radius (m) of the clearance ball around the path's start its search waived (0: none)
    start_clearance_m: float = 0.0
    #: index of the first path point outside that ball, at least 1 (``len(path.p)`` if none):
    #: fixed per plan, so worked out once here rather than on every control tick
    first_checked_idx: int = field(init=False)

    def __post_init__(self) -> None:
        p = self.path.p
        outside = np.flatnonzero(np.linalg.norm(p - p[0], axis=1) > self.start_clearance_m)
        self.first_checked_idx = max(1, int(outside[0]) if outside.size else len(p))


@dataclass
class _Job:
    t0_s: float
    goal_m: FloatArray
    wall_s: float = 0.0
    result: ActivePlan | None = None
    done: threading.Event = field(default_factory=threading.Event)
    #: set to end the search early (its episode is over)
    cancel: threading.Event = field(default_factory=threading.Event)


def start_clearance_m(pos: FloatArray, regions: list[UnsafeRegion]) -> float:
    """Radius (m) of the start's clearance ball: the shortest way out of every region that holds
    the vehicle to a point ``START_CLEARANCE_MARGIN_M`` clear of all of them
    (:func:`~.regions.escape_distance_m`), at least the deepest single region's depth plus that
    margin, at most the smallest keep-out buffer among them plus the margin; and never as far as
    any thing itself (:func:`_thing_distance_m`), held or not: the ball waives every keep-out
    inside it, so it stops short of each box's thing.

    Regressions: urban seed 21 through the pipeline held at its start for 90 s inside an
    unknown's box whose nearest face opened onto a 3 cm slit before the next box (an escape of
    0.67 m the search cannot fly); with the slit no way out, the ball grew to 5.3 m and would
    have reached the tree beside the vehicle, had the things' distances not capped it.

    A box kept out above a cut view (``meta[UNSEEN_TOP]``: what may reach over a trunk) is a
    guess, wide around a thin thing: it adds no depth."""
    inside = [r for r in regions if r.contains(pos)]
    if not inside:
        return START_CLEARANCE_MARGIN_M
    depth = max((-r.signed_distance(pos) for r in inside if not r.meta.get(UNSEEN_TOP)), default=0.0)
    # the way out ends START_CLEARANCE_MARGIN_M clear of every box (a slit between two is none)
    escape = min(escape_distance_m(pos, regions, clear_m=START_CLEARANCE_MARGIN_M),
                 min(r.buffer_m for r in inside) + START_CLEARANCE_MARGIN_M)
    radius = max(depth + START_CLEARANCE_MARGIN_M, escape)
    return min([radius] + [d for r in regions if (d := _thing_distance_m(pos, r)) is not None])


def _thing_distance_m(pos: FloatArray, r: UnsafeRegion) -> float | None:
    """Distance (m) from ``pos (3,)`` to the thing a keep-out box is grown around: its footprint
    (:meth:`~.regions.UnsafeRegion.footprint_xy`) over the box's height. For a guess above a cut
    view (``meta[UNSEEN_TOP]``) it is 0 over that footprint; for any other box, ``None`` (no bound)
    when the vehicle is horizontally over the thing: its way out is up, and the box's depth bounds
    the ball."""
    lo, hi = r.footprint_xy()
    if not r.meta.get(UNSEEN_TOP) and np.all((pos[:2] >= lo) & (pos[:2] <= hi)):
        return None
    core = UnsafeRegion(np.append(lo, r.lo[2]), np.append(hi, r.hi[2]))
    return max(0.0, core.signed_distance(pos))


class Replanner:
    """Searches, adopts and follows paths for one drone (called from the control tick only)."""

    def __init__(self, settings: PlannerSettings) -> None:
        self.settings = s = settings
        workspace_hi = (WORKSPACE_HALF_XY_M, WORKSPACE_HALF_XY_M, s.max_altitude_m)
        self.search_cfg = SearchConfig(time_budget_s=s.search_budget_s, workspace_hi=workspace_hi)
        self.lockstep = False
        self.active: ActivePlan | None  # set, with the rest of an episode's state, below
        self._job: _Job | None
        self._forget_episode()

    def _forget_episode(self) -> None:
        """Every piece of per-episode state, in one place: what one episode leaves here must not
        change the next (the same seed flies the same episode whatever the stack flew before)."""
        self.active, self._job = None, None
        self._last_replan_s = -1e9
        self.failed_searches = 0
        self._failed_in_row = 0
        #: replan at the next tick (the vehicle left its corridor)
        self.force_replan = False

    def cancel_search(self) -> None:
        """End the running search, if any, at its next expansion (thread-safe; the tick that waits
        for it in lockstep then reads a failed search).

        Called when a new episode starts, before it waits for the tick thread: a search of the
        episode that ended (up to ×16 the budget, ~10 s of wall time when the machine is loaded)
        otherwise held the tick thread, and with it the new episode's start, for that long; the
        sim read the silence as a dead planner and flew the new episode's first seconds on its
        failsafe (Exp 1 conservative seed 8 at 25135e6: 25 s holding at the 2.5 m spawn height
        while a pedestrian passed within 0.996 m)."""
        job = self._job
        if job is not None:
            job.cancel.set()

    def start(self, lockstep: bool) -> None:
        """A new episode: forget plans and the last episode's failed searches; bound searches by
        expansions (lockstep) or wall time.

        Every count a search's budget depends on starts again here: the failures in a row of the
        episode before used to carry over, so the first searches of the next episode in the same
        stack got up to ×16 the budget (found while chasing why open_field seed 22 flew another
        episode after seed 21; that one was the MPC's solver, :meth:`MpcController.reset`)."""
        self.cancel_search()
        s = self.settings
        self.lockstep = lockstep
        if lockstep:
            self.search_cfg = replace(self.search_cfg, time_budget_s=float("inf"),
                                      max_expansions=s.search_max_expansions)
        else:
            self.search_cfg = replace(self.search_cfg, time_budget_s=s.search_budget_s,
                                      max_expansions=SearchConfig.max_expansions)
        self._forget_episode()

    def maybe_replan(self, t: float, pos: FloatArray, vel: FloatArray, goal: FloatArray,
                     regions: list[UnsafeRegion], z_floor_m: float,
                     floor_fn: Callable[[FloatArray], FloatArray] | None = None) -> bool:
        """Adopt a finished search when it is due, start a new one when needed; True if adopted.

        ``z_floor_m``: the lowest altitude (m) a new path may take; ``floor_fn``: where the floor
        varies (the terrain), the floor at plan-view points ``(..., 2)``, ``z_floor_m`` its minimum.
        """
        adopted = self._adopt_due(t, regions)
        need = (
            self.force_replan
            or self.active is None
            or float(np.linalg.norm(self.active.goal_m - goal)) > GOAL_MOVED_REPLAN_M
            or t - self._last_replan_s >= self.settings.replan_period_s
            or self.path_blocked(self.active, regions)
        )
        # at the full budget, failures are retried once per replan period, not back to back
        # (each costs ~16× a search: in lockstep the sim waits for it), also off the corridor:
        # ``force_replan`` stays set and starts the search when the period ends, the old path
        # tracked meanwhile without corridors and dropped if blocked (as while any search runs)
        backing_off = (self._failed_in_row > SEARCH_BUDGET_DOUBLINGS
                       and t - self._last_replan_s < self.settings.replan_period_s)
        if need and self._job is None and not backing_off:
            self.force_replan = False
            self._last_replan_s = t
            self._job = _Job(t0_s=t, goal_m=goal.copy())
            threading.Thread(target=self._search, args=(self._job, pos.copy(), vel.copy(), list(regions),
                                                        z_floor_m, self.search_budget_scale(), floor_fn),
                             daemon=True).start()
        return adopted

    def _adopt_due(self, t: float, regions: list[UnsafeRegion]) -> bool:
        job = self._job
        if job is None:
            return False
        if self.lockstep:
            due = t >= job.t0_s + self.settings.search_budget_s - EPS_S
            if due:
                job.done.wait()  # a fixed adoption time; the worker is normally done by now
        else:
            due = job.done.is_set() and t >= job.t0_s + job.wall_s
        if not due:
            return False
        self._job = None
        if job.result is not None:
            self._failed_in_row = 0
            self.active = job.result
            return True
        self.failed_searches += 1
        self._failed_in_row += 1
        if self.active is not None and self.path_blocked(self.active, regions):
            self.active = None  # never keep following a path into a region: hold instead
        return False

    def search_budget_scale(self) -> int:
        """Budget multiplier after failed searches in a row: 2^k, k ≤ ``SEARCH_BUDGET_DOUBLINGS``.

        A way around a wide obstacle next to the goal can need more expansions than the
        per-replan budget; while no plan exists the vehicle holds (safe), so each failure
        doubles the next search's budget (expansions in lockstep, wall time in realtime)
        instead of retrying the same search for ever. Deterministic: it depends only on the
        count of failures.
        """
        return 2 ** min(self._failed_in_row, SEARCH_BUDGET_DOUBLINGS)

    def _search(self, job: _Job, pos: FloatArray, vel: FloatArray, regions: list[UnsafeRegion],
                z_floor_m: float, budget_scale: int = 1,
                floor_fn: Callable[[FloatArray], FloatArray] | None = None) -> None:
        t0 = time.perf_counter()
        try:
            # Clearance region at the start (paper App.): if regions have grown over the
            # vehicle, let the path leave them; the heuristic's penalty φ pushes it out. A still
            # keep-out that holds the vehicle is shrunk to its present distance from the thing.
            regions = no_closer_than_now(pos, regions)
            clearance = max(self.search_cfg.clearance_radius_m, start_clearance_m(pos, regions))
            cfg = replace(self.search_cfg, clearance_radius_m=clearance, z_floor_m=z_floor_m, floor_fn=floor_fn,
                          max_expansions=self.search_cfg.max_expansions * budget_scale,
                          time_budget_s=self.search_cfg.time_budget_s * budget_scale)
            path = plan(pos, vel, job.goal_m, regions, cfg, cancel=job.cancel)
            if path is None:
                log.info("no path at t=%.1f s from %s to %s (floor %.1f m): %s", job.t0_s, np.round(pos, 1),
                         np.round(job.goal_m, 1), z_floor_m, where_blocked(pos, job.goal_m, regions))
            else:
                cors = corridors_for_path(path, regions, max_halfspaces=self.settings.max_halfspaces)
                job.result = ActivePlan(path, cors, job.goal_m, job.t0_s, 1e3 * (time.perf_counter() - t0),
                                        start_clearance_m=clearance)
        except Exception:  # a search bug must not stop the control loop
            log.exception("path search failed")
        job.wall_s = time.perf_counter() - t0
        job.done.set()

    @staticmethod
    def path_blocked(plan: ActivePlan, regions: list[UnsafeRegion]) -> bool:
        """Whether the plan's path ahead crosses a region by more than :data:`PATH_GRAZE_M`.

        Checked from the segment before the vehicle's nearest path point on (what lies behind is
        not flown again), and never inside the clearance ball around the path's start that its
        search waived (``plan.start_clearance_m``, at least the first segment), with the still
        keep-outs that held the path's start shrunk as for its search
        (:func:`~.regions.no_closer_than_now`). Shrunk at the vehicle's position instead, a box
        grows as the vehicle leaves it and a path along its old face reads as blocked: a replan
        every tick, and the plan dropped (a hold inside the box) whenever one failed. The graze
        tolerance absorbs the millimetres by which the resampled path cuts the searched chains
        (each new plan along a shrunk face read as blocked at once: open_field seed 34 with
        specs from truth); it is small against every buffer (≥ 1 m) and the hard 1 m limit is
        kept by the descent gate, not by this check (planner README)."""
        path = plan.path.p
        p = path[max(plan.first_checked_idx, plan.progress_idx - 1):]
        if not regions or len(p) < 2:
            return False  # all of it in the start clearance ball the search waived
        lo, hi = boxes_array(no_closer_than_now(path[0], regions))
        lo, hi = lo + PATH_GRAZE_M, np.maximum(hi - PATH_GRAZE_M, lo + PATH_GRAZE_M)
        return bool(np.any(segments_hit_boxes(p[:-1], p[1:], lo, hi)))

    def look_ahead_m(self, pos: FloatArray, distance_m: float) -> FloatArray | None:
        """The first point ``(3,)`` of the active path past the vehicle's progress that lies at
        least ``distance_m`` away horizontally (where the vehicle is about to fly), else the path's
        end; None without a plan."""
        act = self.active
        if act is None:
            return None
        ahead = act.path.p[act.progress_idx:]
        far = np.flatnonzero(np.linalg.norm(ahead[:, :2] - pos[:2], axis=1) >= distance_m)
        return ahead[int(far[0])] if len(far) else ahead[-1]

    def reference(self, pos: FloatArray, hold: bool = False) -> tuple[FloatArray, FloatArray, Halfspaces | None]:
        """MPC references ``(N+1, 3)`` position and velocity along the active path, with its
        corridors' half-spaces per stage (None: none); without a plan, hold where the vehicle is.
        ``hold``: wait at the nearest path point (the camera has not seen the way ahead yet,
        :mod:`.look_ahead`); progress along the path resumes from there."""
        n, dt = self.settings.horizon, self.settings.mpc_dt_s
        act = self.active
        if act is None:  # no plan yet: hold here (never rush toward the goal blind)
            return np.tile(pos, (n + 1, 1)), np.zeros((n + 1, 3)), None
        p = act.path
        lo = act.progress_idx
        hi = min(len(p.p), lo + PROGRESS_WINDOW_POINTS)
        idx = lo + int(np.argmin(np.linalg.norm(p.p[lo:hi] - pos, axis=1)))
        act.progress_idx = idx
        if hold:
            ref_p, ref_v = np.tile(p.p[idx], (n + 1, 1)), np.zeros((n + 1, 3))
            times = np.full(n, float(p.t[idx]))
        else:
            t_ref = float(p.t[idx]) + dt
            ref = resample(p, dt, t_start=t_ref, count=n + 1)
            ref_p, ref_v = ref.p, ref.v
            times = t_ref + dt * np.arange(1, n + 1)
        hs = halfspaces_at_times(act.corridors, times, self.settings.max_halfspaces) if act.corridors else None
        if hs is not None:
            a0, b0 = hs[0]
            if float(np.max(a0 @ pos - b0)) > CORRIDOR_EXIT_M:
                # Off the corridor (disturbance, held position, changed goal): corridor rows
                # from here would only be slack; track the path without them and replan now.
                self.force_replan = True
                hs = None
        return ref_p, ref_v, hs


def where_blocked(start_m: FloatArray, goal_m: FloatArray, regions: list[UnsafeRegion]) -> str:
    """For the log when a search fails: the regions holding the start and the goal (label, track,
    footprint size and top, m)."""

    def holding(p: FloatArray) -> str:
        inside = [f"{r.label or '?'} {r.obj_id} {r.hi[0] - r.lo[0]:.1f}x{r.hi[1] - r.lo[1]:.1f} to {r.hi[2]:.1f}"
                  for r in regions if r.contains(p)]
        return ", ".join(inside) if inside else "none"

    return f"start inside {holding(start_m)}; goal inside {holding(goal_m)}"
