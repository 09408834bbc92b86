"""Convex safe corridors ``{x | A x ≤ b}`` (world frame, m) around path segments.

For a segment ``[a, b]``: start from its bounding box grown by ``margin_m`` (6 rows); then,
nearest box first, for every unsafe box that intersects the current polytope add the plane
orthogonal to the closest-point direction between segment and box. The plane offset comes
from the box's *support function*, ``β = max_{x ∈ B} n·x + κ``, so the box lies strictly
outside (``n·x ≤ β − κ`` on ``B``) whatever the rounding in ``n``; ``κ = min(kappa_m, d/2)``
with ``d`` the segment–box distance keeps the segment strictly inside. Boxes already at least
``SEP_TOL_M`` outside the polytope get no row. A segment that itself touches a box cannot be separated: that box is
cut off by its face that keeps most of the segment, and ``segment_clear`` is ``False``
(touching means closer than ``TOUCH_TOL_M``).

If more than ``max_halfspaces`` rows are needed, the margin shrinks; if that is not enough
the caller splits the segment (:func:`corridors_for_path` halves it). Rows are unit normals.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from llmland_schemas.arrays import FloatArray
from numpy.typing import ArrayLike

from llmland_planner.path import Path
from llmland_planner.regions import UnsafeRegion, boxes_array, segments_hit_boxes

log = logging.getLogger(__name__)

_EYE6 = np.vstack([np.eye(3), -np.eye(3)])
SEP_TOL_M = 1e-6  # a box counts as excluded only if it lies this far outside a row
TOUCH_TOL_M = 1e-6  # a segment closer than this to a box counts as touching it


@dataclass
class Corridor:
    """Polytope ``A (K, 3) x ≤ b (K,)`` valid for path times ``[t0, t1]`` s."""

    A: FloatArray
    b: FloatArray
    t0: float = 0.0
    t1: float = 0.0
    seg_a: FloatArray | None = None
    seg_b: FloatArray | None = None
    segment_clear: bool = True

    def contains(self, p: ArrayLike, tol: float = 1e-9) -> bool:
        """True when ``p (3,)`` satisfies every row up to ``tol`` (m)."""
        return bool(np.all(self.A @ np.asarray(p, dtype=float) <= self.b + tol))


def segment_box_closest(a: FloatArray, b: FloatArray, lo: FloatArray,
                        hi: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Closest points between segment ``a→b`` and boxes ``lo, hi (R, 3)``.

    Exact: ``dist²(a + t(b − a), B)`` is convex piecewise quadratic in ``t``; we evaluate it
    at the breakpoints, the ends and each piece's stationary point.
    Returns ``(t (R,), seg_pt (R, 3), box_pt (R, 3))``.
    """
    d = b - a
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        br = np.concatenate([(lo - a) / d, (hi - a) / d], axis=1)  # (R, 6)
    br = np.where(np.isfinite(br), np.clip(br, 0.0, 1.0), 0.0)
    knots = np.sort(np.concatenate([np.zeros((lo.shape[0], 1)), br,
                                    np.ones((lo.shape[0], 1))], axis=1), axis=1)  # (R, 8)
    mid = 0.5 * (knots[:, :-1] + knots[:, 1:])  # (R, 7)
    pm = a + mid[..., None] * d  # (R, 7, 3)
    target = np.clip(pm, lo[:, None], hi[:, None])
    active = (pm < lo[:, None]) | (pm > hi[:, None])
    num = np.sum(np.where(active, d * (target - a), 0.0), axis=2)
    den = np.sum(np.where(active, d * d, 0.0), axis=2)
    stat = np.where(den > 1e-15, num / np.where(den > 1e-15, den, 1.0), mid)
    stat = np.clip(stat, knots[:, :-1], knots[:, 1:])
    cand = np.concatenate([knots, stat], axis=1)  # (R, 15)
    pts = a + cand[..., None] * d
    dist2 = np.sum((pts - np.clip(pts, lo[:, None], hi[:, None])) ** 2, axis=2)
    k = np.argmin(dist2, axis=1)
    t = cand[np.arange(lo.shape[0]), k]
    seg_pt = a + t[:, None] * d
    return t, seg_pt, np.clip(seg_pt, lo, hi)


def _box_min(rows: FloatArray, lo: FloatArray, hi: FloatArray) -> FloatArray:
    """``min_{x ∈ [lo, hi]} rows @ x`` for ``rows (K, 3)`` → ``(K,)``."""
    out: FloatArray = np.sum(np.minimum(rows * lo, rows * hi), axis=1)
    return out


def corridor_for_segment(a: FloatArray, b: FloatArray, regions: list[UnsafeRegion],
                         margin_m: float = 1.0, kappa_m: float = 0.02,
                         max_halfspaces: int = 8) -> Corridor | None:
    """Polytope containing ``a→b`` (each ``(3,)``) and disjoint from every region.

    Returns ``None`` only when even a tight bounding box needs more than ``max_halfspaces``.
    """
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    lo, hi = boxes_array(regions)
    clear = True
    if lo.size:
        _, s_all, q_all = segment_box_closest(a, b, lo, hi)
        clear = bool(np.min(np.linalg.norm(s_all - q_all, axis=1)) > TOUCH_TOL_M)
    margin = margin_m
    for _ in range(6):
        rows = [r for r in _EYE6]
        rhs = list(np.concatenate([np.maximum(a, b) + margin, -(np.minimum(a, b) - margin)]))
        if lo.size:
            grow = margin + SEP_TOL_M
            near = np.all((lo <= np.maximum(a, b) + grow) & (hi >= np.minimum(a, b) - grow), 1)
            idx = np.flatnonzero(near)
            _, seg_pt, box_pt = segment_box_closest(a, b, lo[idx], hi[idx])
            dist = np.linalg.norm(seg_pt - box_pt, axis=1)
            for i in np.argsort(dist, kind="stable"):
                blo, bhi = lo[idx[i]], hi[idx[i]]
                if np.any(_box_min(np.array(rows), blo, bhi) > np.array(rhs) + SEP_TOL_M):
                    continue  # already outside the polytope
                if dist[i] > TOUCH_TOL_M:
                    n = (seg_pt[i] - box_pt[i]) / dist[i]
                    beta = float(np.sum(np.maximum(n * blo, n * bhi))) + min(kappa_m, 0.5 * dist[i])
                else:
                    n, beta = _face_cut(a, b, blo, bhi, kappa_m)
                rows.append(-n)
                rhs.append(-beta)
        if len(rows) <= max_halfspaces:
            return Corridor(np.array(rows), np.array(rhs), seg_a=a, seg_b=b, segment_clear=clear)
        margin *= 0.5
    log.debug("corridor for %s→%s needs more than %d rows", a, b, max_halfspaces)
    return None


def _face_cut(a: FloatArray, b: FloatArray, lo: FloatArray, hi: FloatArray,
              kappa_m: float) -> tuple[FloatArray, float]:
    """Outward face half-space ``n·x ≥ β`` of box ``[lo, hi]`` keeping most of ``a→b``."""
    ends = np.stack([a, b])
    reach = np.concatenate([np.max(ends - hi, axis=0), np.max(lo - ends, axis=0)])  # (6,)
    k = int(np.argmax(reach))
    n = _EYE6[k]
    beta = (hi[k] if k < 3 else -lo[k - 3]) + kappa_m
    return n, float(beta)


def _chords(path: Path, lo: FloatArray, hi: FloatArray, chord_tol_m: float,
            max_len_m: float) -> list[tuple[int, int]]:
    """Greedy split of the path samples into collision-free chords ``(i, j)``."""
    pts, out, i = path.p, [], 0
    m = pts.shape[0]
    while i < m - 1:
        j = i + 1
        while j + 1 < m:
            a, c = pts[i], pts[j + 1]
            seg = c - a
            length = float(np.linalg.norm(seg))
            if length > max_len_m:
                break
            mid = pts[i + 1:j + 1] - a
            u = seg / max(length, 1e-12)
            dev = np.linalg.norm(mid - np.outer(mid @ u, u), axis=1)
            if np.any(dev > chord_tol_m) or (lo.size and np.any(
                    segments_hit_boxes(a[None], c[None], lo, hi))):
                break
            j += 1
        out.append((i, j))
        i = j
    return out


def corridors_for_path(path: Path, regions: list[UnsafeRegion], max_halfspaces: int = 8,
                       margin_m: float = 1.0, kappa_m: float = 0.02, chord_tol_m: float = 0.1,
                       max_len_m: float = 3.0) -> list[Corridor]:
    """One corridor per collision-free chord of ``path``, timed by the chord's samples."""
    lo, hi = boxes_array(regions)
    result: list[Corridor] = []
    for i, j in _chords(path, lo, hi, chord_tol_m, max_len_m):
        stack = [(path.p[i], path.p[j], float(path.t[i]), float(path.t[j]))]
        while stack:
            a, b, t0, t1 = stack.pop()
            cor = corridor_for_segment(a, b, regions, margin_m, kappa_m, max_halfspaces)
            if cor is None and float(np.linalg.norm(b - a)) > 0.2:
                mid = 0.5 * (a + b)
                stack += [(mid, b, 0.5 * (t0 + t1), t1), (a, mid, t0, 0.5 * (t0 + t1))]
                continue
            if cor is None:
                cor = corridor_for_segment(a, b, regions, 0.0, kappa_m, 10_000)
                assert cor is not None
            if not cor.segment_clear:
                # routine while a region grows over the planned path (replanning follows): DEBUG,
                # not INFO, or it floods the service log (about 20 lines per sim second then)
                log.debug("path chord %s→%s touches an unsafe region", a, b)
            cor.t0, cor.t1 = t0, t1
            result.append(cor)
    return result


def active_halfspaces(corridor: Corridor | None, k_max: int) -> tuple[FloatArray, FloatArray]:
    """Exactly ``k_max`` rows ``(A (k_max, 3), b (k_max,))``, padded with ``0·x ≤ 1``.

    A corridor with more rows keeps those tightest at its segment midpoint (logged).
    """
    a_out, b_out = np.zeros((k_max, 3)), np.ones(k_max)
    if corridor is None:
        return a_out, b_out
    rows, rhs = corridor.A, corridor.b
    if rows.shape[0] > k_max:
        log.debug("corridor has %d rows, keeping %d", rows.shape[0], k_max)  # expected: once per stage per tick
        mid = np.zeros(3) if corridor.seg_a is None or corridor.seg_b is None else (
            0.5 * (corridor.seg_a + corridor.seg_b))
        keep = np.argsort(rhs - rows @ mid, kind="stable")[:k_max]
        rows, rhs = rows[keep], rhs[keep]
    a_out[: rows.shape[0]] = rows
    b_out[: rows.shape[0]] = rhs
    return a_out, b_out


def halfspaces_at_times(corridors: list[Corridor], times_s: ArrayLike,
                        k_max: int) -> list[tuple[FloatArray, FloatArray]]:
    """Per query time ``(N,)`` s the padded rows of the corridor covering it (clamped)."""
    times = np.atleast_1d(np.asarray(times_s, dtype=float))
    if not corridors:
        return [active_halfspaces(None, k_max) for _ in times]
    starts = np.array([c.t0 for c in corridors])
    idx = np.clip(np.searchsorted(starts, times, side="right") - 1, 0,
                  len(corridors) - 1)
    return [active_halfspaces(corridors[int(i)], k_max) for i in idx]
