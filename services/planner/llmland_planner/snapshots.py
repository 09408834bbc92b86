"""Plan snapshots for displays: the reference, corridors, unsafe boxes and the landing gate."""

from __future__ import annotations

import numpy as np
from llmland_schemas import CorridorPolytope, LandingGate, PlanSnapshot, ReachDisc, UnsafeBox, vec3

from .corridors import Corridor
from .landing import LandingLogic, Surroundings
from .path import Path
from .regions import UnsafeRegion

#: Gate margins are shown clipped to ± this (m) (no people and no coverage limit: infinite).
GATE_MARGIN_SHOWN_M = 99.0
#: Plan snapshots carry every this-many-th path point and at most this many corridors.
SNAPSHOT_PATH_STRIDE = 2
SNAPSHOT_MAX_CORRIDORS = 20


def gate_view(landing: LandingLogic | None, around: Surroundings | None) -> LandingGate | None:
    """The last gate decision for displays, with each possible person's reachable disc."""
    gate = landing.last_gate if landing is not None else None
    if gate is None or landing is None:
        return None
    people = around.people if around is not None else []
    discs = [ReachDisc(track_id=p.track_id, label=p.label,
                       centre_m=(float(p.centre_xy[0]), float(p.centre_xy[1]), float(landing.target_m[2])),
                       radius_m=p.radius_m + landing.bounds.reach_m(p.age_s + gate.duration_s, p.speed_mps))
             for p in people]
    return LandingGate(open=gate.open, duration_s=gate.duration_s,
                       margin_m=float(np.clip(gate.clearance.margin_m, -GATE_MARGIN_SHOWN_M, GATE_MARGIN_SHOWN_M)),
                       binding=gate.clearance.track_id, disc_clear=gate.disc_clear,
                       coverage_m=around.coverage_m if around is not None else 0.0, people=discs)


def plan_snapshot(drone_id: str, episode_id: str, t: float, landing: LandingLogic | None,
                  regions: list[UnsafeRegion], around: Surroundings | None, path: Path | None,
                  corridors: list[Corridor], search_ms: float | None) -> PlanSnapshot:
    """What the planner has at ``t``: its phase, the active path and corridors, the regions, the gate."""
    return PlanSnapshot(
        drone_id=drone_id,
        stamp=t,
        mode=landing.phase.value if landing else "",
        reference_m=[vec3(q) for q in path.p[::SNAPSHOT_PATH_STRIDE]] if path is not None else [],
        corridors=[CorridorPolytope(A=[vec3(r) for r in c.A], b=[float(x) for x in c.b])
                   for c in corridors][:SNAPSHOT_MAX_CORRIDORS],
        regions=[UnsafeBox(obj_id=r.obj_id, lo_m=vec3(r.lo), hi_m=vec3(r.hi),
                           label=r.label, is_dynamic=r.is_dynamic) for r in regions],
        search_ms=search_ms,
        episode_id=episode_id,
        target_m=vec3(landing.target_m) if landing else None,
        gate=gate_view(landing, around),
    )
