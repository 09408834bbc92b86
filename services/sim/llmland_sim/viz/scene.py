"""The 3D scene graph of a landing (DESIGN §9): drone body and path, actors and obstacles,
the planner's unsafe regions, corridors and landing gate. World frame, z up, metres.

``world/drone`` carries the body as boxes in the body frame and its pose as an
``InstancePoses3D``: that pose places the body only, never the children, so
``world/drone/trajectory`` is drawn where the drone actually was.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np
import rerun as rr
from llmland_schemas import GroundTruth, LandingGate, TruthObject, UnsafeBox

from ..vehicle.params import DEFAULT_PARAMS, QuadParams
from . import paths

GROUND_Z_M = 0.0
CLASS_COLOURS: dict[str, tuple[int, int, int]] = {
    "person": (230, 60, 60),
    "vehicle": (60, 110, 230),
    "building": (150, 150, 150),
    "tree": (40, 140, 60),
    "bush": (80, 170, 80),
    "shed": (160, 110, 60),
    "rock": (120, 110, 100),
    "pad": (240, 200, 40),
}
OTHER_COLOUR = (200, 200, 200)
PATH_COLOUR = (255, 140, 0)
PATH_RADIUS_M = 0.04
#: a path point every this much sim time (s); the path is re-logged with each new point
PATH_POINT_PERIOD_S = 0.2
REFERENCE_COLOUR = (0, 200, 255)
CORRIDOR_COLOUR = (0, 160, 255, 110)
UNSAFE_LINE_RADIUS_M = 0.015
UNSAFE_COLOURS = {"human": (255, 50, 50), "dynamic": (255, 150, 0), "static": (255, 215, 0)}
GATE_OPEN_COLOUR = (40, 200, 90, 70)
GATE_CLOSED_COLOUR = (230, 40, 40, 70)
GATE_DISC_THICKNESS_M = 0.02
CIRCLE_SEGMENTS = 48

# drone body, body frame (x forward, y left, z up): a hub, two crossed arms, four rotors
HUB_HALF_M = (0.07, 0.05, 0.03)
ARM_HALF_WIDTH_M = 0.015
ROTOR_HALF_M = (0.06, 0.06, 0.008)
HUB_COLOUR = (30, 30, 40)
ARM_COLOUR = (70, 70, 90)
FRONT_ROTOR_COLOUR = (255, 90, 20)
BACK_ROTOR_COLOUR = (20, 120, 255)
#: the body is drawn this many times its size (a 0.32 m quadrotor is a few pixels in a view
#: of the landing zone); its pose, and so the path, are exact
DRONE_DRAW_SCALE = 2.0


def drone_body(params: QuadParams = DEFAULT_PARAMS) -> rr.Boxes3D:
    """The quadrotor as boxes in its body frame: hub, arms along the diagonals, rotors."""
    rotors = params.rotor_positions_m
    half_arm = params.arm_length_m
    yaw = [math.pi / 4, -math.pi / 4]
    centers = [(0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)] + [tuple(r + [0, 0, 0.02]) for r in rotors]
    halves = [HUB_HALF_M] + [(half_arm, ARM_HALF_WIDTH_M, ARM_HALF_WIDTH_M)] * 2 + [ROTOR_HALF_M] * 4
    quats = [rr.Quaternion(xyzw=[0, 0, 0, 1])] + [
        rr.Quaternion(xyzw=[0, 0, math.sin(a / 2), math.cos(a / 2)]) for a in yaw
    ] + [rr.Quaternion(xyzw=[0, 0, 0, 1])] * 4
    colours = [HUB_COLOUR, ARM_COLOUR, ARM_COLOUR] + [
        FRONT_ROTOR_COLOUR if r[0] > 0 else BACK_ROTOR_COLOUR for r in rotors
    ]
    return rr.Boxes3D(centers=centers, half_sizes=halves, quaternions=quats, colors=colours,
                      fill_mode=rr.components.FillMode.Solid)


class PathLayer:
    """The flown path, sampled every ``PATH_POINT_PERIOD_S``; each sample is the drone's
    world position at the sim time the path is logged with."""

    def __init__(self) -> None:
        self.points: list[tuple[float, float, float]] = []
        self._next_s = 0.0

    def add(self, rec: rr.RecordingStream, t_s: float, position_m: Sequence[float]) -> None:
        if t_s + 1e-9 < self._next_s:
            return
        self._next_s = t_s + PATH_POINT_PERIOD_S
        self.points.append((float(position_m[0]), float(position_m[1]), float(position_m[2])))
        if len(self.points) >= 2:
            rec.log(paths.TRAJECTORY, rr.LineStrips3D([self.points], colors=[PATH_COLOUR], radii=PATH_RADIUS_M))


def person_capsule(o: TruthObject) -> rr.Capsules3D:
    """A person as a capsule of their height, standing on the ground under their centre."""
    sx, sy, h = o.size_m
    r = (sx + sy) / 4.0
    base = np.asarray(o.position_m, dtype=float) - [0.0, 0.0, h / 2.0]
    return rr.Capsules3D(translations=[base + [0.0, 0.0, r]], lengths=[max(h - 2 * r, 0.0)], radii=[r],
                         colors=[CLASS_COLOURS["person"]], labels=[o.obj_id],
                         fill_mode=rr.components.FillMode.Solid)


def log_truth(rec: rr.RecordingStream, msg: GroundTruth, first: bool) -> None:
    """Actors every time (they move), static obstacles and the target once."""
    if first:
        rec.log(paths.TARGET, rr.Points3D([msg.target_m], radii=0.15, colors=[(255, 200, 0)], labels=["target"]),
                static=True)
    for o in msg.objects:
        if not (o.dynamic or first):
            continue
        path = paths.child(paths.ACTORS if o.dynamic else paths.OBSTACLES, o.obj_id)
        if o.is_person or o.cls == "person":
            rec.log(path, person_capsule(o), static=not o.dynamic)
        else:
            rec.log(path, rr.Boxes3D(centers=[o.position_m], half_sizes=[np.asarray(o.size_m) / 2.0],
                                     colors=[CLASS_COLOURS.get(o.cls, OTHER_COLOUR)], labels=[o.cls]),
                    static=not o.dynamic)


def merged_regions(regions: Sequence[UnsafeBox]) -> dict[str, tuple[np.ndarray, np.ndarray, UnsafeBox]]:
    """One box per obstacle id (swept slices of a mover merged), clipped at the ground."""
    out: dict[str, tuple[np.ndarray, np.ndarray, UnsafeBox]] = {}
    for r in regions:
        lo, hi = np.asarray(r.lo_m, dtype=float), np.asarray(r.hi_m, dtype=float)
        if r.obj_id in out:
            lo0, hi0, first = out[r.obj_id]
            lo, hi, r = np.minimum(lo0, lo), np.maximum(hi0, hi), first
        out[r.obj_id] = (lo, hi, r)
    for lo, hi, _ in out.values():
        lo[2] = max(lo[2], GROUND_Z_M)
        hi[2] = max(hi[2], lo[2])
    return out


class UnsafeLayer:
    """``world/unsafe/<id>``: one labelled box per obstacle id, cleared when it goes away."""

    def __init__(self) -> None:
        self.shown: set[str] = set()

    def update(self, rec: rr.RecordingStream, regions: Sequence[UnsafeBox],
               describe: Callable[[UnsafeBox, np.ndarray], tuple[str, bool]]) -> None:
        """``describe(region, centre)`` gives its label and whether it may be a person."""
        boxes = merged_regions(regions)
        for obj_id, (lo, hi, r) in boxes.items():
            centre = (lo + hi) / 2.0
            label, person = describe(r, centre)
            kind = "human" if person or r.label == "person" else "dynamic" if r.is_dynamic else "static"
            rec.log(paths.child(paths.UNSAFE, obj_id),
                    rr.Boxes3D(centers=[centre], half_sizes=[(hi - lo) / 2.0], colors=[UNSAFE_COLOURS[kind]],
                               radii=UNSAFE_LINE_RADIUS_M, labels=[label],
                               fill_mode=rr.components.FillMode.MajorWireframe))
        for gone in self.shown - boxes.keys():
            rec.log(paths.child(paths.UNSAFE, gone), rr.Clear(recursive=True))
        self.shown = set(boxes)


def circle(centre_m: Sequence[float], radius_m: float) -> np.ndarray:
    """A closed horizontal circle (CIRCLE_SEGMENTS + 1, 3)."""
    a = np.linspace(0.0, 2 * np.pi, CIRCLE_SEGMENTS + 1)
    c = np.asarray(centre_m, dtype=float)
    return np.stack([c[0] + radius_m * np.cos(a), c[1] + radius_m * np.sin(a), np.full_like(a, c[2])], axis=1)


def log_gate(rec: rr.RecordingStream, gate: LandingGate | None, target_m: Sequence[float] | None) -> None:
    """Each possible person's reachable disc by the end of the descent, and the downward
    camera's coverage, while the planner has a gate decision; cleared otherwise."""
    if gate is None:
        rec.log(paths.GATE, rr.Clear(recursive=True))
        return
    colour = GATE_OPEN_COLOUR if gate.open else GATE_CLOSED_COLOUR
    state = "open" if gate.open else "closed"
    if gate.people:
        rec.log(paths.GATE_PEOPLE, rr.Cylinders3D(
            centers=[(p.centre_m[0], p.centre_m[1], p.centre_m[2] + GATE_DISC_THICKNESS_M) for p in gate.people],
            lengths=[GATE_DISC_THICKNESS_M] * len(gate.people), radii=[p.radius_m for p in gate.people],
            colors=[colour] * len(gate.people), fill_mode=rr.components.FillMode.Solid,
            labels=[f"{p.label or 'person?'} {p.track_id}: reach {p.radius_m:.1f} m (gate {state})"
                    for p in gate.people]))
    else:
        rec.log(paths.GATE_PEOPLE, rr.Clear(recursive=False))
    if target_m is not None and gate.coverage_m > 0:
        rec.log(paths.GATE_COVERAGE, rr.LineStrips3D([circle(target_m, gate.coverage_m)], colors=[colour[:3]],
                                                      radii=0.02, labels=[f"coverage {gate.coverage_m:.1f} m"]))
