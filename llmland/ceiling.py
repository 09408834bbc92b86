"""``llmland ceiling``: how often *any* method that keeps the hard limit could land on these seeds.

The hard limit (services/planner/README.md, "Safety argument") lets a descent start only when no
person can reach 1 m of the landing point before touchdown, under the stated motion bounds
(ISO 13855 walking speed, bounded acceleration). Some worlds keep people around the pad for
minutes. This command replays each seed's people alone (no drone: the pedestrians do not react
to it) and feeds their *true* positions and speeds — perfect perception, no latency, nobody out
of view — to the planner's own gate (:func:`llmland_planner.hard_limit.commit_clearance`) at
the hover point above the target. The first time it opens is when the earliest safe descent
could begin; a seed where it never opens before ``timeout − descent`` cannot be landed by any
method that respects the bounds. The share of seeds where it opens is the ceiling the
experiments' success rates are read against (with perfect perception and no travel time it
is an upper bound, not a prediction).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pybullet as p
from llmland_planner.hard_limit import PERSON_BODY_RADIUS_M, PersonHypothesis, commit_clearance
from llmland_planner.landing import LandingLogic
from llmland_planner.settings import PlannerSettings
from llmland_sim.world.worlds import build_world

#: people's states are sampled this often (s)
SAMPLE_PERIOD_S = 0.05


@dataclass(frozen=True)
class SeedCeiling:
    """One seed: when the gate with perfect perception first opens (None: never)."""

    world: str
    seed: int
    first_open_s: float | None
    #: the share of the episode (before ``timeout − descent``) the gate is open
    open_fraction: float
    #: the closest any person came to the target (m, horizontal)
    closest_person_m: float


def gate_duration_s(settings: PlannerSettings) -> float:
    """Time (s) within reach for a descent from the hover height, at rest: the gate's own duration."""
    return LandingLogic(np.zeros(3), settings).descent_duration_s(settings.cruise_altitude_m, 0.0)


def seed_ceiling(world: str, seed: int, timeout_s: float, settings: PlannerSettings,
                 n_pedestrians: int | None = None) -> SeedCeiling:
    """Replay ``world``/``seed``'s people (``n_pedestrians``: the world's default when None) for
    ``timeout_s`` and run the gate on their true states."""
    s = settings
    bounds = LandingLogic(np.zeros(3), s).bounds  # the gate's motion bounds, built from the settings
    duration = gate_duration_s(s)
    client = p.connect(p.DIRECT)
    try:
        w = build_world(client, world, seed, n_pedestrians=n_pedestrians)
        target = np.asarray(w.target_m, dtype=float)[:2]
        people = [(o.obj_id, o.actor) for o in w.objects if o.cls == "person" and o.actor is not None]
        first, n_open, n, closest, t = None, 0, 0, math.inf, 0.0
        while t + duration <= timeout_s:
            hyps = []
            for obj_id, actor in people:
                pos, _ = actor.pose()
                hyps.append(PersonHypothesis(obj_id, np.asarray(pos, dtype=float)[:2], PERSON_BODY_RADIUS_M,
                                             float(np.linalg.norm(actor.velocity()[:2])), 0.0, "person"))
                closest = min(closest, float(np.linalg.norm(np.asarray(pos, dtype=float)[:2] - target)))
            gate = commit_clearance(target, hyps, duration, bounds, coverage_m=math.inf, unseen_s=0.0,
                                    xy_margin_m=s.landing_xy_margin_m)
            if gate.safe:
                n_open += 1
                first = t if first is None else first
            n += 1
            w.step_actors(SAMPLE_PERIOD_S)
            t += SAMPLE_PERIOD_S
        return SeedCeiling(world, seed, first, n_open / max(n, 1), closest)
    finally:
        p.disconnect(client)


def summary(rows: list[SeedCeiling], timeout_s: float, settings: PlannerSettings) -> dict[str, object]:
    """Per world: seeds where the gate opens, the share, and the seeds where it never does."""
    out: dict[str, object] = {"timeout_s": timeout_s, "gate_duration_s": round(gate_duration_s(settings), 3),
                              "human_max_speed_mps": settings.human_max_speed_mps}
    for world in sorted({r.world for r in rows}):
        mine = [r for r in rows if r.world == world]
        opened = [r for r in mine if r.first_open_s is not None]
        firsts = sorted(r.first_open_s for r in opened if r.first_open_s is not None)
        out[world] = {
            "seeds": len(mine),
            "gate_opens": len(opened),
            "ceiling": round(len(opened) / max(len(mine), 1), 3),
            "never_opens": [r.seed for r in mine if r.first_open_s is None],
            "first_open_s_median": round(float(np.median(firsts)), 1) if firsts else None,
        }
    return out
