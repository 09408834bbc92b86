"""Unsafe regions as axis-aligned boxes in the world frame (m).

Every obstacle the reasoner flags (a person, a car, a tree) becomes one or more
:class:`UnsafeRegion` boxes ``[lo, hi]``. A footprint is given by its half sizes along x and y:
a still thing's axis-aligned bounds as seen (a long wall stays a long box), or one radius ``r``
for anything that may turn (a walking person, a driving car: the disc it sweeps when turning
on the spot), whose axis-aligned bounding box is the square of half-width ``r``. The buffer is
added along each axis: the box contains every point within ``buffer_m`` (Euclidean) of the
footprint (the Minkowski sum of a box and a disc lies in the box grown by the radius). Boxes
keep point/segment tests, signed distances and the corridor separation exact and cheap, at the
cost of the corners (≈27 % more area than a disc).

Vertical extent: from ``z_ground_m − 1`` (below the ground, so the floor never leaves a gap)
up to ``max(height_m + min(buffer_m, OVERFLY_CLEARANCE_M), z_min)``: ``z_min`` is the spec's
altitude to overfly the obstacle (the paper's field; a person or a car: 3 m), and the drone
never skims an obstacle's top closer than the clearance. The horizontal buffer is horizontal.

Dynamic obstacles are swept along constant-velocity motion over ``horizon_s``: we return one
box per time slice (each covering the footprint's motion during its slice) rather than one
box covering the whole swept footprint. For diagonal motion the slices hug the swept strip
while a single bounding box would block the whole rectangle spanned by it, so slices keep the
corridors less conservative; for axis-aligned motion both coincide.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from llmland_schemas.arrays import BoolArray, FloatArray
from numpy.typing import ArrayLike

MAX_SWEEP_SLICES = 8
#: vertical clearance (m) kept above an obstacle's top, at most its buffer
OVERFLY_CLEARANCE_M = 0.5
#: regions reach this far (m) below the ground, so the floor never leaves a gap
BELOW_GROUND_M = 1.0
#: a moving obstacle's sweep is cut into slices of this duration (s)
SWEEP_SLICE_S = 0.25
#: ``UnsafeRegion.meta`` key of a box guessed above a view cut at the top (its ``buffer_m`` is
#: the guessed reach past the seen footprint; ``world_model.WorldModel._keepout``)
UNSEEN_TOP = "unseen_top"
#: ``UnsafeRegion.meta`` key of a possible person's box (whatever its ``is_dynamic``: geometry
#: alone keeps one who walked and stopped as a still box)
POSSIBLE_PERSON = "possible_person"


def _vec3(a: ArrayLike) -> FloatArray:
    """``a`` as a float (3,) array, returned as is when it already is one: regions are built by the
    dozen on every control tick, where the conversion's call cost more than the check."""
    if type(a) is np.ndarray and a.dtype == np.float64 and a.shape == (3,):
        return a
    return np.asarray(a, dtype=float).reshape(3)


@dataclass
class UnsafeRegion:
    """Axis-aligned box ``lo ≤ p ≤ hi`` (world frame, metres) the drone must not enter."""

    lo: FloatArray
    hi: FloatArray
    obj_id: str = ""
    label: str = ""
    is_dynamic: bool = False
    buffer_m: float = 0.0
    z_min: float = 0.0
    meta: dict[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        lo, hi = self.lo, self.hi = _vec3(self.lo), _vec3(self.hi)
        if (hi < lo).any():
            raise ValueError(f"region {self.obj_id!r}: hi {hi} below lo {lo}")

    def contains(self, p: ArrayLike, margin_m: float = 0.0) -> bool:
        """True when ``p (3,)`` lies in the box grown by ``margin_m`` (closed set)."""
        q = np.asarray(p, dtype=float)
        return bool(np.all(q >= self.lo - margin_m) and np.all(q <= self.hi + margin_m))

    def footprint_xy(self) -> tuple[FloatArray, FloatArray]:
        """The thing the keep-out is grown around, in plan view: ``(lo (2,), hi (2,))`` of the box
        less its ``buffer_m`` along x and y (what :func:`from_obstacle` adds), m; an axis the buffer
        overfills collapses to the box's centre."""
        mid = 0.5 * (self.lo[:2] + self.hi[:2])
        return np.minimum(self.lo[:2] + self.buffer_m, mid), np.maximum(self.hi[:2] - self.buffer_m, mid)

    def signed_distance(self, p: ArrayLike) -> float:
        """Box SDF (m) at ``p (3,)``: positive outside, negative inside (depth to nearest face)."""
        q = np.asarray(p, dtype=float)
        center = 0.5 * (self.lo + self.hi)
        half = 0.5 * (self.hi - self.lo)
        d = np.abs(q - center) - half
        outside = float(np.linalg.norm(np.maximum(d, 0.0)))
        inside = float(min(np.max(d), 0.0))
        return outside + inside


#: Escape directions from inside regions: horizontal both ways and up (never down toward people).
ESCAPE_DIRECTIONS = np.array([[1.0, 0, 0], [-1.0, 0, 0], [0, 1.0, 0], [0, -1.0, 0], [0, 0, 1.0]])
#: A point this far (m) past a box's face is outside it.
ESCAPE_EPS_M = 1e-6


def escape_distance_m(p: ArrayLike, regions: list[UnsafeRegion], clear_m: float = 0.0) -> float:
    """Shortest straight way (m) out of *every* region from ``p (3,)``: along ±x, ±y or +z, the
    distance to the first point at least ``clear_m`` (m) from all of them (0 when ``p`` is in none;
    inf if no direction gets out). A start inside overlapping keep-outs (conservative buffers of
    unknown things) needs this, not the depth in each box alone: leaving one box may land inside
    the next; and with ``clear_m > 0`` a gap between two boxes narrower than ``2 clear_m`` is no way
    out (a path search cannot fly through a slit of a few centimetres)."""
    start = np.asarray(p, dtype=float)
    if not any(r.contains(start) for r in regions):
        return 0.0
    lo, hi = boxes_array(regions)
    lo, hi = lo - clear_m, hi + clear_m
    best = math.inf
    for e in ESCAPE_DIRECTIONS:
        q, travelled = start.copy(), 0.0
        for _ in range(len(regions) + 1):
            inside = points_in_boxes(q[None], lo, hi)[0]
            if not inside.any():
                best = min(best, travelled)
                break
            # along e, each box is left where its face across e is passed
            faces = np.where(e > 0, hi[inside] - q, q - lo[inside]) @ np.abs(e)
            step = float(faces.max()) + ESCAPE_EPS_M
            q, travelled = q + e * step, travelled + step
    return best


#: a keep-out shrunk around the vehicle leaves it this far (m) outside its new face
SHRINK_EPS_M = 1e-3


def no_closer_than_now(p: ArrayLike, regions: list[UnsafeRegion]) -> list[UnsafeRegion]:
    """``regions`` for a path from ``p (3,)``: a still keep-out that holds ``p`` is shrunk so the path
    may leave it but never come nearer the thing than the vehicle is now.

    Applies to boxes that are not dynamic, not a possible person's (``meta[POSSIBLE_PERSON]``) and
    not a sweep slice, with ``p`` horizontally outside the
    thing's footprint (the box less its ``buffer_m`` along x and y, which :func:`from_obstacle` adds):
    the box becomes that footprint grown by ``c − SHRINK_EPS_M``, ``c`` the Chebyshev (max-axis)
    distance of ``p`` from it, so ``p`` lies just outside; the vertical extent stays. Every other
    region is returned as it is (the same objects). A vehicle in the buffer of a still thing got
    there from outside it (the region grew over it: a new track, a wider spec, a guess above a view
    cut at the top); the buffer is the keep-out's margin, not the thing, and what this keeps is that
    the margin left to the thing only grows. People (dynamic) and moving things keep their boxes and
    the start's clearance ball (:func:`~.replanning.start_clearance_m`), and the hard limit never
    reads regions. Regressions: open_field seeds 26 and 34 with specs from truth (e912de4), each
    start inside a tree's keep-out, and seed 34 through the pipeline (6cdb917), inside the box guessed
    above "tall grass" cut at the top of the view (3 m past the grass, up to 10.5 m): the clearance
    ball stopped short of the thing, every search from inside the box failed, and the vehicle held
    there for 90 s.
    """
    q = np.asarray(p, dtype=float)
    lo, hi = boxes_array(regions)
    holding = points_in_boxes(q[None], lo, hi)[0]  # one vector test: this runs on every control tick
    out = list(regions)
    for i in np.flatnonzero(holding).tolist():
        r = regions[i]
        if r.is_dynamic or "t0_s" in r.meta or r.meta.get(POSSIBLE_PERSON):
            continue
        core_lo, core_hi = r.footprint_xy()
        c = float(np.max(np.maximum(core_lo - q[:2], q[:2] - core_hi)))  # Chebyshev distance, m
        if c <= SHRINK_EPS_M:
            continue  # over the thing itself: the clearance ball's case
        grow = c - SHRINK_EPS_M
        new_lo = np.array([max(r.lo[0], core_lo[0] - grow), max(r.lo[1], core_lo[1] - grow), r.lo[2]])
        new_hi = np.array([min(r.hi[0], core_hi[0] + grow), min(r.hi[1], core_hi[1] + grow), r.hi[2]])
        out[i] = UnsafeRegion(new_lo, new_hi, r.obj_id, r.label, r.is_dynamic, grow, r.z_min, dict(r.meta))
    return out


def from_obstacle(center_xy: ArrayLike, half_size_m: float | ArrayLike, height_m: float, buffer_m: float,
                  z_min: float, velocity_xy: ArrayLike | None = None, horizon_s: float = 0.0,
                  dt_s: float = SWEEP_SLICE_S, *, obj_id: str = "", label: str = "",
                  z_ground_m: float = 0.0, is_dynamic: bool | None = None) -> list[UnsafeRegion]:
    """Boxes for an obstacle: centre ``(2,)`` m, footprint half sizes (a scalar radius, or ``(2,)``
    half extents along x, y; m), height above ground (m).

    Static obstacles (no velocity or ``horizon_s <= 0``) give one box. Dynamic ones give one
    box per slice of ``dt_s`` (at most :data:`MAX_SWEEP_SLICES`, slices widen when capped),
    slice ``i`` covering the footprint between ``t_i`` and ``t_{i+1}``. The boxes'
    ``is_dynamic`` is ``is_dynamic`` when given (a person standing still is dynamic), else
    whether the obstacle moves.
    """
    cx, cy = np.asarray(center_xy, dtype=float).reshape(2).tolist()
    hx, hy = (np.broadcast_to(np.asarray(half_size_m, dtype=float), (2,)) + buffer_m).tolist()
    if hx < 0.0 or hy < 0.0:
        raise ValueError(f"obstacle {obj_id!r}: negative half size {half_size_m!r}")
    top = z_ground_m + max(height_m + min(buffer_m, OVERFLY_CLEARANCE_M), z_min)
    bottom = z_ground_m - BELOW_GROUND_M
    vx, vy = (0.0, 0.0) if velocity_xy is None else np.asarray(velocity_xy, dtype=float).reshape(2).tolist()
    moving = velocity_xy is not None and math.sqrt(vx * vx + vy * vy) > 1e-9
    dynamic = moving if is_dynamic is None else is_dynamic
    if not moving or horizon_s <= 0.0:
        return [UnsafeRegion(np.array([cx - hx, cy - hy, bottom]), np.array([cx + hx, cy + hy, top]), obj_id, label,
                             dynamic, buffer_m, z_min)]
    n = max(1, min(MAX_SWEEP_SLICES, math.ceil(horizon_s / max(dt_s, 1e-6))))
    times = np.linspace(0.0, horizon_s, n + 1)
    # all slices at once (scalar per-slice numpy calls cost more than the maths): slice i covers
    # the footprint between t_i and t_{i+1}
    xs, ys = cx + vx * times, cy + vy * times
    lo_x = (np.minimum(xs[:-1], xs[1:]) - hx).tolist()
    lo_y = (np.minimum(ys[:-1], ys[1:]) - hy).tolist()
    hi_x = (np.maximum(xs[:-1], xs[1:]) + hx).tolist()
    hi_y = (np.maximum(ys[:-1], ys[1:]) + hy).tolist()
    ts = times.tolist()
    return [UnsafeRegion(np.array([lo_x[i], lo_y[i], bottom]), np.array([hi_x[i], hi_y[i], top]), obj_id, label,
                         dynamic, buffer_m, z_min, {"t0_s": ts[i], "t1_s": ts[i + 1]}) for i in range(n)]


def boxes_array(regions: list[UnsafeRegion]) -> tuple[FloatArray, FloatArray]:
    """Stack region bounds into ``(lo (R, 3), hi (R, 3))``."""
    if not regions:
        return np.zeros((0, 3)), np.zeros((0, 3))
    return np.stack([r.lo for r in regions]), np.stack([r.hi for r in regions])


def mark_cell_ranges(grid: BoolArray, first: ArrayLike, last: ArrayLike) -> None:
    """Set ``grid[i0:i1 + 1, j0:j1 + 1]`` for each inclusive cell range ``first[k] = (i0, j0)``,
    ``last[k] = (i1, j1)`` (``(K, 2)`` ints), clipped to the grid; a range wholly outside it marks
    nothing. Plain slicing would read a negative end from the far side (a box 20 m west of a
    plan-view grid once marked most of it)."""
    n = np.array(grid.shape[:2]) - 1
    lo = np.maximum(np.asarray(first, dtype=np.int64).reshape(-1, 2), 0)
    hi = np.minimum(np.asarray(last, dtype=np.int64).reshape(-1, 2), n)
    for (i0, j0), (i1, j1) in zip(lo, hi, strict=True):
        if i0 <= i1 and j0 <= j1:
            grid[i0:i1 + 1, j0:j1 + 1] = True


def segments_hit_boxes(a: ArrayLike, b: ArrayLike, lo: FloatArray, hi: FloatArray) -> BoolArray:
    """Vectorised slab test: ``a, b (S, 3)`` segments vs ``lo, hi (R, 3)`` boxes → bool ``(S, R)``.

    A segment touching a box face counts as a hit (closed boxes).
    """
    a = np.asarray(a, dtype=float)[:, None, :]
    d = np.asarray(b, dtype=float)[:, None, :] - a
    lo_b, hi_b = lo[None, :, :], hi[None, :, :]
    parallel = np.abs(d) < 1e-12
    safe_d = np.where(parallel, 1.0, d)
    t1 = (lo_b - a) / safe_d
    t2 = (hi_b - a) / safe_d
    t_near = np.where(parallel, -np.inf, np.minimum(t1, t2))
    t_far = np.where(parallel, np.inf, np.maximum(t1, t2))
    inside_slab = (a >= lo_b) & (a <= hi_b)
    ok_parallel = np.all(~parallel | inside_slab, axis=2)
    t_enter = np.maximum(np.max(t_near, axis=2), 0.0)
    t_exit = np.minimum(np.min(t_far, axis=2), 1.0)
    result: BoolArray = ok_parallel & (t_enter <= t_exit)
    return result


def segment_hits(a: ArrayLike, b: ArrayLike, region: UnsafeRegion) -> bool:
    """True when the segment ``a → b`` (each ``(3,)``) touches ``region``."""
    hit = segments_hit_boxes(np.reshape(a, (1, 3)), np.reshape(b, (1, 3)),
                             region.lo[None, :], region.hi[None, :])
    return bool(hit[0, 0])


def points_in_boxes(points: ArrayLike, lo: FloatArray, hi: FloatArray) -> BoolArray:
    """Membership ``(P, R)`` bool of ``points (P, 3)`` in closed boxes ``lo, hi (R, 3)``."""
    p = np.asarray(points, dtype=float)[:, None, :]
    result: BoolArray = np.all((p >= lo[None]) & (p <= hi[None]), axis=2)
    return result
