"""Fallback when the kinodynamic search exhausts its budget: a plan-view grid detour.

Weighted A* over motion primitives (:mod:`.search`) keys its closed set on a 6-D state grid
(position and velocity), so a narrow passage is flooded with every speed at every cell before
the search squeezes through it; a detour that exists can need more expansions than the
largest budget, and the vehicle then holds (safe, but it never lands). Exp 2 open_field seed 34
(at 2eff93c): the only way from the start around a tree's crown reach runs through a 1.7 m
gap; the search needed 6 558 expansions against the 6 400 allowed and the drone held for 90 s.

This module finds such a detour in milliseconds, in three steps:

1. **Grid path.** At one cruise altitude ``z_c = max(start z, goal z, z_floor_m)`` (raised over
   a varying floor, the reach floor over people, where the grid path meets it) a plan-view
   grid of ``grid_res_m`` cells marks every cell meeting the footprint of a box that spans
   ``z_c`` (optionally grown by a margin), frees the cells near the start and goal clearance
   discs, and Dijkstra on the 8-connected grid gives the shortest cell chain — the
   "holonomic with obstacles" path of hybrid A* (Dolgov, Thrun, Montemerlo, Diebel, 2010),
   the same grid the search's distance heuristic uses.
2. **Line-of-sight shortcut** (post-smoothing of grid paths, Botea, Müller, Schaeffer 2004):
   from each kept waypoint, the farthest later one whose straight leg passes the checker.
3. **Rest-to-rest legs.** Each leg (a climb to ``z_c`` from the start, the plan-view legs, a
   descent to the goal) is flown on a trapezoidal speed profile, ``|a| ≤ a_max``,
   ``|v| ≤ v_max`` along the leg, from rest to rest: the vehicle stops at every corner, so it
   never cuts one at speed.

**Safety.** The grid only proposes. The whole sampled path is checked by the search's own
checker (:class:`.search._Checker`: every sample and every segment between samples against
every box, the floor and the workspace, waived only inside the start and goal clearance balls),
so a detour promises exactly what a searched path promises; the corridors and the MPC then
treat it like any other path. If no leg passes, there is no detour and the vehicle holds, as
before.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable

import numpy as np
from llmland_schemas.arrays import BoolArray, FloatArray
from numpy.typing import NDArray
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

from .path import Path
from .regions import UnsafeRegion, boxes_array, mark_cell_ranges

log = logging.getLogger(__name__)

#: Sample spacing (m) of a straight leg when it is checked, and sample period (s) of the path.
LEG_CHECK_SPACING_M = 0.1
DETOUR_SAMPLE_DT_S = 0.05
#: Margins (m) the grid grows boxes by, tried in turn: a detour off the regions' edges first.
DETOUR_GRID_MARGINS_M = (0.5, 0.0)
#: The cruise altitude is raised to this (m) over the varying floor along the grid path, in at
#: most this many rounds (a higher altitude changes which boxes it meets, hence the path).
DETOUR_FLOOR_MARGIN_M = 0.2
DETOUR_FLOOR_ROUNDS = 3

#: ``feasible(pts (M, S, 3)) -> (M,)``: whether each sampled chain is clear (the search's check).
ChainCheck = Callable[[FloatArray], BoolArray]
#: ``floor(xy (..., 2)) -> (...)``: the floor (m) where it varies.
FloorFn = Callable[[FloatArray], FloatArray]


def eight_way_graph(blocked: BoolArray, res_m: float) -> csr_matrix:
    """Undirected 8-connected graph of a plan-view grid's free cells (``blocked (nx, ny)``),
    edge weights the centre distances (m); node ``i * ny + j`` is cell ``(i, j)``."""
    nx, ny = blocked.shape
    idx = np.arange(nx * ny).reshape(nx, ny)
    rows, cols, w = [], [], []
    for di, dj in ((1, 0), (0, 1), (1, 1), (1, -1)):
        a = idx[max(0, -di):nx - max(0, di), max(0, -dj):ny - max(0, dj)]
        b = idx[max(0, di):nx - max(0, -di) or None, max(0, dj):ny - max(0, -dj) or None]
        ok = ~blocked.ravel()[a.ravel()] & ~blocked.ravel()[b.ravel()]
        rows.append(a.ravel()[ok])
        cols.append(b.ravel()[ok])
        w.append(np.full(int(ok.sum()), res_m * float(np.hypot(di, dj))))
    return csr_matrix((np.concatenate(w), (np.concatenate(rows), np.concatenate(cols))), shape=(nx * ny,) * 2)


def rest_to_rest(a_m: FloatArray, b_m: FloatArray, v_max_mps: float, a_max_mps2: float,
                 dt_s: float) -> tuple[FloatArray, FloatArray, FloatArray]:
    """A straight leg from rest at ``a_m`` to rest at ``b_m`` (each ``(3,)``) on the
    minimum-time trapezoidal (or triangular) speed profile; samples every ``dt_s`` and at the
    end: ``t (S,)`` s from 0, ``p (S, 3)`` m, ``v (S, 3)`` m/s."""
    d = b_m - a_m
    length = float(np.linalg.norm(d))
    if length < 1e-9:
        return np.zeros(1), a_m[None].copy(), np.zeros((1, 3))
    u = d / length
    v_peak = min(v_max_mps, math.sqrt(a_max_mps2 * length))
    t_acc = v_peak / a_max_mps2
    t_cruise = (length - v_peak * t_acc) / v_peak
    total = 2.0 * t_acc + t_cruise
    t = np.append(np.arange(0.0, total, dt_s), total)
    t_dec = np.maximum(t - t_acc - t_cruise, 0.0)
    s = (0.5 * a_max_mps2 * np.minimum(t, t_acc) ** 2 + v_peak * np.clip(t - t_acc, 0.0, t_cruise)
         + v_peak * t_dec - 0.5 * a_max_mps2 * t_dec ** 2)
    speed = np.where(t < t_acc, a_max_mps2 * t, np.where(t_dec > 0.0, v_peak - a_max_mps2 * t_dec, v_peak))
    s[-1], speed[-1] = length, 0.0
    return t, a_m + s[:, None] * u, np.maximum(speed, 0.0)[:, None] * u


def _grid_path(start_xy: FloatArray, goal_xy: FloatArray, lo: FloatArray, hi: FloatArray, *,
               res_m: float, margin_m: float, free_radius_m: float) -> FloatArray | None:
    """Cell centres ``(K, 2)`` of the shortest 8-connected chain from the start's cell to the
    goal's around the footprints ``lo, hi (R, 2)``; None if the goal's cell is unreachable."""
    origin = np.minimum(start_xy, goal_xy) - margin_m
    shape = np.ceil((np.maximum(start_xy, goal_xy) + margin_m - origin) / res_m).astype(int) + 1
    nx, ny = int(shape[0]), int(shape[1])
    blocked = np.zeros((nx, ny), dtype=bool)
    mark_cell_ranges(blocked, np.floor((lo - origin) / res_m), np.ceil((hi - origin) / res_m))
    ii, jj = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
    centres = origin + res_m * np.stack([ii, jj], axis=-1)
    for c in (start_xy, goal_xy):
        blocked &= np.linalg.norm(centres - c, axis=-1) > free_radius_m
    si, sj = np.clip(np.round((start_xy - origin) / res_m).astype(int), 0, [nx - 1, ny - 1])
    gi, gj = np.clip(np.round((goal_xy - origin) / res_m).astype(int), 0, [nx - 1, ny - 1])
    dist, pred = dijkstra(eight_way_graph(blocked, res_m), directed=False, indices=int(si * ny + sj),
                          return_predecessors=True)
    node = int(gi * ny + gj)
    if not np.isfinite(dist[node]):
        return None
    chain = [node]
    while chain[-1] != si * ny + sj:
        chain.append(int(pred[chain[-1]]))
    cells: NDArray[np.int64] = np.array(chain[::-1])
    out: FloatArray = origin + res_m * np.stack([cells // ny, cells % ny], axis=-1)
    return out


def _leg_samples(a: FloatArray, b: FloatArray, count: int) -> FloatArray:
    """``count`` evenly spaced points ``(count, 3)`` from ``a`` to ``b`` inclusive."""
    out: FloatArray = a + np.linspace(0.0, 1.0, count)[:, None] * (b - a)
    return out


def _shortcut(points: FloatArray, feasible: ChainCheck) -> FloatArray | None:
    """Line-of-sight shortcut of waypoints ``(K, 3)``: from each kept one, the farthest later
    one with a clear straight leg. None when some waypoint has no clear leg onward."""
    kept, i = [0], 0
    while i < len(points) - 1:
        later = np.arange(i + 1, len(points))
        longest = float(np.max(np.linalg.norm(points[later] - points[i], axis=1)))
        count = max(2, math.ceil(longest / LEG_CHECK_SPACING_M) + 1)
        chains = np.stack([_leg_samples(points[i], points[j], count) for j in later])
        ok = np.flatnonzero(feasible(chains))
        if ok.size == 0:
            return None
        i = int(later[ok[-1]])
        kept.append(i)
    out: FloatArray = points[kept]
    return out


def grid_detour(start_m: FloatArray, goal_m: FloatArray, regions: list[UnsafeRegion], feasible: ChainCheck, *,
                z_floor_m: float, v_max_mps: float, a_max_mps2: float, rho: float, res_m: float,
                grid_margin_m: float, clearance_radius_m: float, floor_fn: FloorFn | None = None) -> Path | None:
    """A rest-to-rest polyline path ``start_m → goal_m`` (each ``(3,)``, m) around ``regions`` at
    one cruise altitude, every leg and the whole sampled path passing ``feasible``; None if
    there is none on the grid. ``floor_fn``: where the floor varies (the reach floor over
    people), the floor (m) at plan-view points ``(..., 2)``; the cruise altitude is raised to
    ``DETOUR_FLOOR_MARGIN_M`` over its highest value along the grid path. ``cost``:
    ``ρ·T + ∫‖a‖² dt`` as the search's; ``expansions`` 0."""
    lo, hi = boxes_array(regions)
    for margin in DETOUR_GRID_MARGINS_M:
        z_c = max(float(start_m[2]), float(goal_m[2]), z_floor_m)
        for _ in range(DETOUR_FLOOR_ROUNDS):
            spans = (lo[:, 2] <= z_c) & (hi[:, 2] >= z_c)
            cells = _grid_path(start_m[:2], goal_m[:2], lo[spans, :2] - margin, hi[spans, :2] + margin,
                               res_m=res_m, margin_m=grid_margin_m, free_radius_m=clearance_radius_m + res_m)
            if cells is None or floor_fn is None:
                break
            need = float(np.max(floor_fn(cells))) + DETOUR_FLOOR_MARGIN_M
            if need <= z_c:
                break
            z_c = need
        if cells is None:
            continue
        top, bottom = np.append(start_m[:2], z_c), np.append(goal_m[:2], z_c)
        waypoints = np.vstack([start_m, top, np.column_stack([cells[1:-1], np.full(len(cells) - 2, z_c)]),
                               bottom, goal_m])
        kept = _shortcut(waypoints, feasible)
        if kept is None:
            log.info("search: grid detour at %.1f m (grid margin %.1f m): no clear leg", z_c, margin)
            continue
        path = _fly(kept, v_max_mps, a_max_mps2, rho)
        if bool(feasible(path.p[None])[0]):
            log.info("search: grid detour of %d legs, %.1f m, %.1f s at %.1f m (grid margin %.1f m)", len(kept) - 1,
                     float(np.sum(np.linalg.norm(np.diff(kept, axis=0), axis=1))), path.duration_s, z_c, margin)
            return path
    return None


def _fly(waypoints: FloatArray, v_max_mps: float, a_max_mps2: float, rho: float) -> Path:
    """Rest-to-rest legs through ``waypoints (K, 3)`` as one sampled :class:`Path`."""
    ts, ps, vs, t0, effort = [], [], [], 0.0, 0.0
    for a, b in zip(waypoints[:-1], waypoints[1:], strict=True):
        if float(np.linalg.norm(b - a)) < 1e-9:
            continue
        t, p, v = rest_to_rest(a, b, v_max_mps, a_max_mps2, DETOUR_SAMPLE_DT_S)
        ts.append(t0 + t[:-1])
        ps.append(p[:-1])
        vs.append(v[:-1])
        t_acc = min(v_max_mps, math.sqrt(a_max_mps2 * float(np.linalg.norm(b - a)))) / a_max_mps2
        effort += 2.0 * a_max_mps2 ** 2 * t_acc
        t0 += float(t[-1])
    ts.append(np.array([t0]))
    ps.append(waypoints[-1][None])
    vs.append(np.zeros((1, 3)))
    return Path(np.concatenate(ts), np.concatenate(ps), np.concatenate(vs), rho * t0 + effort, 0)
