"""Kinodynamic A* over constant-acceleration motion primitives (3-D double integrator).

State ``(p, v)`` (m, m/s, world frame). Each primitive holds ``a`` from a per-axis level grid
(``xy_levels`` × ``xy_levels`` × ``z_levels`` values in ``[-a_max, a_max]``) for ``tau_s``;
its cost is ``‖a‖²·τ + ρ·τ``. Children whose speed exceeds ``v_max`` or whose sampled
trajectory (points + slab tests between consecutive samples) touches an unsafe box, leaves
the workspace box or dips below the floor (``z_floor_m``, or ``floor_fn`` where it varies) are
dropped. Within ``shot_radius_m`` of the goal every expansion tries an analytic cubic
"one-shot" to ``(goal, v = 0)``; the search ends when one is feasible.

Heuristic ``h̃(p, v) = w · (h₀(p, v) + λ·φ(p))``. ``h₀ = ρ · T_lb`` with ``T_lb`` the larger of
``d_free(p) / v_max`` and the per-axis bang-bang minimum time under ``|a_d| ≤ a_max``,
``|v_d| ≤ v_max`` and ending at rest; ``d_free`` is the length of the shortest 8-connected path
to the goal on a plan-view grid around the regions too tall to fly over (Dijkstra from the goal,
``grid_res_m`` cells; the "holonomic with obstacles" heuristic of hybrid A*, so a big obstacle
between start and goal is walked around rather than pushed against); it is admissible up to
one cell, so ``w = 1`` is plain A*. The
default ``w = 3`` (weighted A*) keeps typical searches within the 50 ms budget, since the
time bound ignores the ``‖a‖²`` term and detours. ``φ`` is the paper's region penalty read
for *unsafe* boxes (the paper penalises leaving a safe box ``B``; here the safe set is the
free space, the complement of the unsafe boxes): for every unsafe box grown by
``penalty_margin_m`` that contains ``p``, add the squared distance needed to leave it through
its nearest face plus ``ε`` — the same ``(p_d − b_d)² + ε`` term, taken on the exit axis.
Since colliding primitives are rejected explicitly, φ acts in the margin band and steers the
search away from regions early.

Around the start and the goal, balls of ``clearance_radius_m`` are exempt from region, floor
and penalty checks (so a drone hovering inside an inflated box can still leave, and a goal
next to an obstacle stays reachable); anything outside these balls is always checked, so a
path never crosses a region away from its endpoints. The workspace box is never exempt.
"""

from __future__ import annotations

import heapq
import itertools
import logging
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from llmland_schemas.arrays import BoolArray, FloatArray
from numpy.typing import ArrayLike, NDArray
from scipy.ndimage import grey_erosion
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

from llmland_planner.path import Path, cubic_to_rest, resample, sample_cubic, sample_primitive
from llmland_planner.regions import (
    UnsafeRegion,
    boxes_array,
    mark_cell_ranges,
    points_in_boxes,
    segments_hit_boxes,
)
from llmland_planner.separation import separated

__all__ = ["Path", "SearchConfig", "penalty", "plan", "resample"]

log = logging.getLogger(__name__)


@dataclass
class SearchConfig:
    """Tuning of the kinodynamic search (SI units)."""

    a_max_mps2: float = 2.5
    v_max_mps: float = 2.0
    tau_s: float = 0.45
    xy_levels: int = 3
    z_levels: int = 3
    rho: float = 10.0
    penalty_lambda: float = 10.0
    penalty_eps: float = 0.01
    penalty_margin_m: float = 0.5
    heuristic_weight: float = 3.0
    clearance_radius_m: float = 0.5
    z_floor_m: float = 0.2
    #: the floor (m) at plan-view points ``(..., 2)`` where it varies (the terrain): it replaces
    #: ``z_floor_m`` in the checks, and ``z_floor_m`` must then be its minimum
    floor_fn: Callable[[FloatArray], FloatArray] | None = None
    workspace_lo: tuple[float, float, float] = (-100.0, -100.0, -1.0)
    workspace_hi: tuple[float, float, float] = (100.0, 100.0, 50.0)
    pos_res_m: float = 0.2
    vel_res_mps: float = 0.5
    shot_radius_m: float = 4.0
    #: plan-view grid of the obstacle-aware distance heuristic (m) and its margin around start/goal (m)
    grid_res_m: float = 0.5
    grid_margin_m: float = 15.0
    samples_per_primitive: int = 6
    max_expansions: int = 20000
    time_budget_s: float = 0.05


def penalty(points: ArrayLike, regions: list[UnsafeRegion], margin_m: float = 0.0,
            eps: float = 0.01) -> FloatArray:
    """Region penalty φ for ``points (M, 3)`` → ``(M,)`` (m²); see the module docstring."""
    pts = np.atleast_2d(np.asarray(points, dtype=float))
    lo, hi = boxes_array(regions)
    if lo.shape[0] == 0:
        return np.zeros(pts.shape[0])
    lo, hi = lo - margin_m, hi + margin_m
    inside = points_in_boxes(pts, lo, hi)
    exit_d = np.minimum(pts[:, None, :] - lo[None], hi[None] - pts[:, None, :]).min(axis=2)
    out: FloatArray = np.where(inside, exit_d ** 2 + eps, 0.0).sum(axis=1)
    return out


def _min_time_lb(p: FloatArray, v: FloatArray, goal: FloatArray, cfg: SearchConfig,
                 free_dist_m: FloatArray | None = None) -> FloatArray:
    """Admissible time (s) to reach ``goal`` at rest, for ``p, v (M, 3)`` → ``(M,)``.

    Per axis: bang-bang minimum time under ``|a_d| ≤ a_max``, ``|v_d| ≤ v_max`` ending at
    rest (first braking when moving away or when too fast to stop in time); the max over
    axes and the straight-line bound ``‖d‖ / v_max`` are both lower bounds.
    """
    a, vm = cfg.a_max_mps2, cfg.v_max_mps
    d = goal[None] - p
    sgn = np.where(d >= 0.0, 1.0, -1.0)
    dist, v0 = np.abs(d), np.clip(v * sgn, -vm, vm)
    stop_d = v0 * np.abs(v0) / (2.0 * a)
    direct = (v0 >= 0.0) & (stop_d <= dist)
    # direct: accelerate to the peak speed, then brake to rest at the goal
    v_peak = np.sqrt(np.maximum((2.0 * a * dist + v0 ** 2) / 2.0, 0.0))
    t_tri = (2.0 * v_peak - v0) / a
    t_trap = (2.0 * vm - v0) / a + (dist - (2.0 * vm ** 2 - v0 ** 2) / (2.0 * a)) / vm
    t_direct = np.where(v_peak <= vm, t_tri, t_trap)
    # otherwise: brake to rest first, then rest-to-rest over the remaining distance
    rem = np.abs(dist - stop_d)
    t_rr = np.where(rem <= vm ** 2 / a, 2.0 * np.sqrt(rem / a), rem / vm + vm / a)
    t_axis = np.where(direct, t_direct, np.abs(v0) / a + t_rr).max(axis=1)
    dist_lb = np.linalg.norm(d, axis=1) if free_dist_m is None else np.maximum(np.linalg.norm(d, axis=1), free_dist_m)
    out: FloatArray = np.maximum(t_axis, dist_lb / vm)
    return out


#: passes of the free-distance fill: blocked cells get the distance of their nearest reached
#: cell up to this many cells away (a box's cells reach at most one cell past it; the rest of
#: the passes cover the start's clearance ball inside a box, a few metres at 0.5 m cells)
FREE_DISTANCE_FILL_CELLS = 8


class _FreeDistance:
    """Shortest plan-view distance (m) to the goal around regions too tall to fly over.

    The grid blocks every cell a tall box touches, so it reaches up to one cell past each box.
    A vehicle there (beside the box, or in the start's clearance ball inside it) sits in a
    blocked cell; its distance is that of the nearest reached cell (:data:`FREE_DISTANCE_FILL_CELLS`
    passes of a 3×3 minimum), less the one-cell slack every lookup gets. Before, such points fell
    back to the straight line: a hole in the heuristic all along the face of a wide obstacle,
    where the search then spent its whole budget (open_field seed 34: 6,639 expansions for a way
    round a tree's keep-out that it now finds in about 1,100).
    """

    def __init__(self, regions: list[UnsafeRegion], start: FloatArray, goal: FloatArray, cfg: SearchConfig) -> None:
        res = cfg.grid_res_m
        self.res = res
        self.goal = goal
        self.origin = np.minimum(start[:2], goal[:2]) - cfg.grid_margin_m
        top = np.maximum(start[:2], goal[:2]) + cfg.grid_margin_m
        self.shape = (int(np.ceil((top[0] - self.origin[0]) / res)) + 1,
                      int(np.ceil((top[1] - self.origin[1]) / res)) + 1)
        nx, ny = self.shape
        blocked = np.zeros(self.shape, dtype=bool)
        lo, hi = boxes_array(regions)
        tall = hi[:, 2] >= cfg.workspace_hi[2] - cfg.clearance_radius_m  # the rest can be flown over
        mark_cell_ranges(blocked, np.floor((lo[tall, :2] - self.origin) / res),
                         np.ceil((hi[tall, :2] - self.origin) / res))
        ii, jj = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
        centres = self.origin + res * np.stack([ii, jj], axis=-1)
        free_balls = np.ones(self.shape, dtype=bool)
        for c in (start[:2], goal[:2]):  # the clearance balls are free
            free_balls &= np.linalg.norm(centres - c, axis=-1) > cfg.clearance_radius_m + res
        self.dist = self._dijkstra(blocked & free_balls)
        si, sj = self._cell(start[None, :2])
        if not np.isfinite(self.dist[si[0], sj[0]]):
            # a gap narrower than two cells closes when every cell a box touches is blocked: a
            # start in a pocket behind it read the straight line through the walls, and every
            # search spent its budget beside them (urban seed 12). Then block only the cells
            # wholly inside a box: a lower bound through any gap, as :func:`.separated` reads it.
            inner = np.zeros(self.shape, dtype=bool)
            mark_cell_ranges(inner, np.ceil((lo[tall, :2] - self.origin) / res + 0.5),
                             np.floor((hi[tall, :2] - self.origin) / res - 0.5))
            self.dist = self._dijkstra(inner & free_balls)

    def _dijkstra(self, blocked: NDArray[np.bool_]) -> FloatArray:
        nx, ny = self.shape
        idx = np.arange(nx * ny).reshape(nx, ny)
        rows, cols, w = [], [], []
        for di, dj in ((1, 0), (0, 1), (1, 1), (1, -1)):
            a = idx[max(0, -di):nx - max(0, di), max(0, -dj):ny - max(0, dj)]
            b = idx[max(0, di):nx - max(0, -di) or None, max(0, dj):ny - max(0, -dj) or None]
            ok = ~blocked.ravel()[a.ravel()] & ~blocked.ravel()[b.ravel()]
            rows.append(a.ravel()[ok])
            cols.append(b.ravel()[ok])
            w.append(np.full(int(ok.sum()), self.res * float(np.hypot(di, dj))))
        graph = csr_matrix((np.concatenate(w), (np.concatenate(rows), np.concatenate(cols))), shape=(nx * ny,) * 2)
        gi, gj = self._cell(self.goal[None, :2])
        d = dijkstra(graph, directed=False, indices=int(gi[0] * ny + gj[0]))
        return _fill_unreached(np.asarray(d, dtype=float).reshape(nx, ny), FREE_DISTANCE_FILL_CELLS)

    def _cell(self, xy: FloatArray) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
        ij = np.round((xy - self.origin) / self.res).astype(np.int64)
        return np.clip(ij[:, 0], 0, self.shape[0] - 1), np.clip(ij[:, 1], 0, self.shape[1] - 1)

    def __call__(self, p: FloatArray) -> FloatArray:
        """Distance lower bound (m) for points ``(M, 3)``: free-path length, at least the straight line."""
        pts = np.atleast_2d(p)
        i, j = self._cell(pts[:, :2])
        straight = np.linalg.norm(pts[:, :2] - self.goal[None, :2], axis=1)
        grid = self.dist[i, j] - self.res * np.sqrt(2.0)  # one cell of slack keeps it admissible
        return np.where(np.isfinite(grid), np.maximum(grid, straight), straight)


def _fill_unreached(dist: FloatArray, cells: int) -> FloatArray:
    """``dist (nx, ny)`` with each unreached (infinite) cell set to the smallest distance among
    the cells around it, repeated ``cells`` times (so up to ``cells`` cells from a reached one);
    cells farther from any reached cell stay infinite. A lower bound at the filled cells up to
    the distance to the cell whose value they took."""
    for _ in range(cells):
        unreached = ~np.isfinite(dist)
        if not unreached.any():
            break
        nearest = grey_erosion(dist, size=3, mode="nearest")
        fill = unreached & np.isfinite(nearest)
        if not fill.any():
            break
        dist = np.where(fill, nearest, dist)
    return dist


class _Checker:
    """Collision checks of sampled trajectories with clearance balls around start/goal."""

    def __init__(self, regions: list[UnsafeRegion], start: FloatArray, goal: FloatArray,
                 cfg: SearchConfig) -> None:
        self.lo, self.hi = boxes_array(regions)
        self.centers = np.stack([start, goal])
        self.cfg = cfg
        self.ws_lo, self.ws_hi = np.array(cfg.workspace_lo), np.array(cfg.workspace_hi)

    def exempt(self, pts: FloatArray) -> BoolArray:
        """Bool ``(...)``: points within a clearance ball."""
        d = np.linalg.norm(pts[..., None, :] - self.centers, axis=-1)
        out: BoolArray = np.any(d <= self.cfg.clearance_radius_m, axis=-1)
        return out

    def ok(self, pts: FloatArray) -> BoolArray:
        """Feasibility of ``(M, S, 3)`` sample chains (``pts[:, 0]`` = common/known-good start)."""
        m, s, _ = pts.shape
        ex = self.exempt(pts)
        good = np.all((pts >= self.ws_lo) & (pts <= self.ws_hi), axis=(1, 2))
        floor = self.cfg.z_floor_m if self.cfg.floor_fn is None else self.cfg.floor_fn(pts[..., :2])
        good &= np.all(ex | (pts[..., 2] >= floor), axis=1)
        flat = pts.reshape(-1, 3)
        near = np.all((self.lo <= flat.max(axis=0)) & (self.hi >= flat.min(axis=0)), axis=1)
        if not np.any(near):
            return good
        lo, hi = self.lo[near], self.hi[near]
        hit_pt = points_in_boxes(flat, lo, hi).any(axis=1).reshape(m, s)
        good &= ~np.any(hit_pt & ~ex, axis=1)
        a, b = pts[:, :-1].reshape(-1, 3), pts[:, 1:].reshape(-1, 3)
        ea, eb = ex[:, :-1].reshape(-1), ex[:, 1:].reshape(-1)
        a, b = self._clip_to_balls(a, b, ea, eb)
        check = ~(ea & eb) & np.repeat(good, s - 1)
        hit_seg = np.zeros(a.shape[0], dtype=bool)
        if np.any(check):
            hit_seg[check] = segments_hit_boxes(a[check], b[check], lo, hi).any(axis=1)
        good &= ~hit_seg.reshape(m, s - 1).any(axis=1)
        return good

    def _clip_to_balls(self, a: FloatArray, b: FloatArray, ea: BoolArray,
                       eb: BoolArray) -> tuple[FloatArray, FloatArray]:
        """Shorten mixed segments (one end exempt) to their part outside the clearance ball."""
        a, b = a.copy(), b.copy()
        r = self.cfg.clearance_radius_m
        for inside_mask, inner, outer in ((ea & ~eb, a, b), (eb & ~ea, b, a)):
            i = np.flatnonzero(inside_mask)
            if i.size == 0:
                continue
            p_in, p_out = inner[i], outer[i]
            nearest = np.argmin(np.linalg.norm(p_in[:, None, :] - self.centers[None], axis=2), axis=1)
            d = p_in - p_out
            f0 = p_out - self.centers[nearest]
            # the segment's entry into the ball: the smaller root of |f0 + s d|² = r², s in [0, 1]
            qa, qb, qc = _rowdot(d, d), 2.0 * _rowdot(f0, d), _rowdot(f0, f0) - r * r
            disc = np.maximum(qb * qb - 4.0 * qa * qc, 0.0)
            long = qa > 1e-12
            s = np.zeros(i.size)
            s[long] = (-qb[long] - np.sqrt(disc[long])) / (2.0 * qa[long])
            inner[i] = p_out + np.clip(s, 0.0, 1.0)[:, None] * d
        return a, b


def _rowdot(u: FloatArray, v: FloatArray) -> FloatArray:
    """Row-wise dot products ``(K,)`` of ``(K, 3)`` arrays."""
    out: FloatArray = np.einsum("ij,ij->i", u, v)
    return out


def _accel_set(cfg: SearchConfig) -> FloatArray:
    xy = np.linspace(-cfg.a_max_mps2, cfg.a_max_mps2, cfg.xy_levels)
    z = np.linspace(-cfg.a_max_mps2, cfg.a_max_mps2, cfg.z_levels)
    return np.array(list(itertools.product(xy, xy, z)), dtype=float)


def plan(start_p: ArrayLike, start_v: ArrayLike, goal_p: ArrayLike,
         regions: list[UnsafeRegion], config: SearchConfig | None = None, *,
         cancel: threading.Event | None = None) -> Path | None:
    """Search a path from ``(start_p, start_v)`` (each ``(3,)``) to rest at ``goal_p (3,)``.

    Returns ``None`` when no path is found within ``max_expansions``/``time_budget_s``, or at once
    when :func:`~.separation.separated` shows that none exists, or once ``cancel`` is set (checked
    before every expansion).
    """
    cfg = config or SearchConfig()
    p0, v0, goal = (np.asarray(x, dtype=float) for x in (start_p, start_v, goal_p))
    if separated(p0, goal, regions, z_floor_m=cfg.z_floor_m, z_ceiling_m=cfg.workspace_hi[2],
                 clearance_radius_m=cfg.clearance_radius_m, grid_res_m=cfg.grid_res_m, margin_m=cfg.grid_margin_m):
        log.info("search: no path can exist (start and goal separated by walls in plan view)")
        return None
    return _Search(p0, v0, goal, regions, cfg, cancel).run()


class _Search:
    """One kinodynamic A* search (paper §III-B): nodes, open heap and closed grid cells."""

    def __init__(self, p0: FloatArray, v0: FloatArray, goal: FloatArray, regions: list[UnsafeRegion],
                 cfg: SearchConfig, cancel: threading.Event | None = None) -> None:
        self.cfg, self.goal, self.regions = cfg, goal, regions
        self.cancel = cancel or threading.Event()
        self.t_start = time.perf_counter()
        self.chk = _Checker(regions, p0, goal, cfg)
        self.free = _FreeDistance(regions, p0, goal, cfg)
        self.acc = _accel_set(cfg)
        self.acc_cost = (np.sum(self.acc ** 2, axis=1) + cfg.rho) * cfg.tau_s
        self.ts = np.linspace(0.0, cfg.tau_s, cfg.samples_per_primitive + 1)
        self.scale = np.concatenate([np.full(3, 1.0 / cfg.pos_res_m), np.full(3, 1.0 / cfg.vel_res_mps)])
        self.nodes_p, self.nodes_v, self.nodes_g = [p0], [v0], [0.0]
        self.parent: list[int] = [-1]
        self.parent_acc: list[FloatArray] = [np.zeros(3)]
        self.tie = itertools.count()
        self.heap = [(float(self.heuristic(p0[None], v0[None])[0]), next(self.tie), 0)]
        self.closed: set[tuple[int, ...]] = set()
        self.best_g: dict[tuple[int, ...], float] = {self.keys(p0, v0)[0]: 0.0}

    def heuristic(self, p: FloatArray, v: FloatArray) -> FloatArray:
        """Weighted lower bound on the time cost to the goal plus the region penalty φ, (M,)."""
        cfg = self.cfg
        phi = np.where(self.chk.exempt(p), 0.0, penalty(p, self.regions, cfg.penalty_margin_m, cfg.penalty_eps))
        h: FloatArray = cfg.heuristic_weight * (cfg.rho * _min_time_lb(p, v, self.goal, cfg, self.free(p))
                                                + cfg.penalty_lambda * phi)
        return h

    def keys(self, p: FloatArray, v: FloatArray) -> list[tuple[int, ...]]:
        """Grid cells of states ``(p, v)`` ((3,) or (M, 3) each)."""
        grid = np.round(np.concatenate([p, v], axis=-1) * self.scale).astype(np.int64)
        return [tuple(row) for row in np.atleast_2d(grid).tolist()]

    def run(self) -> Path | None:
        cfg, expansions = self.cfg, 0
        while self.heap:
            _, _, idx = heapq.heappop(self.heap)
            p, v = self.nodes_p[idx], self.nodes_v[idx]
            k = self.keys(p, v)[0]
            if k in self.closed:
                continue
            self.closed.add(k)
            expansions += 1
            if self.cancel.is_set():
                log.info("search cancelled after %d expansions", expansions)
                return None
            if expansions > cfg.max_expansions or time.perf_counter() - self.t_start > cfg.time_budget_s:
                log.info("search gave up after %d expansions (%.1f ms)", expansions,
                         1e3 * (time.perf_counter() - self.t_start))
                return None
            path = self._shot(idx, expansions)
            if path is not None:
                return path
            self._expand(idx)
        log.info("search exhausted the open set after %d expansions", expansions)
        return None

    def _shot(self, idx: int, expansions: int) -> Path | None:
        """Near the goal: the collision-free cubic to rest at the goal from node ``idx``, if any."""
        cfg, p, v, g = self.cfg, self.nodes_p[idx], self.nodes_v[idx], self.nodes_g[idx]
        if np.linalg.norm(self.goal - p) > cfg.shot_radius_m:
            return None
        shot = cubic_to_rest(p, v, self.goal, cfg.rho, cfg.v_max_mps, cfg.a_max_mps2)
        if shot is None:
            return None
        coeffs, dur, cost = shot
        pts = sample_cubic(coeffs, np.linspace(0.0, dur, max(4, int(dur / 0.1) + 2)))[0]
        if not self.chk.ok(pts[None])[0]:
            return None
        chain = _backtrack(idx, self.parent, self.parent_acc, self.nodes_p, self.nodes_v)
        log.debug("search: %d expansions, cost %.2f", expansions, g + cost)
        return Path.from_pieces(chain, (coeffs, dur), cfg.tau_s, g + cost, expansions)

    def _expand(self, idx: int) -> None:
        """Push the node's feasible, improving successors (one motion primitive per acceleration)."""
        cfg, p, v, g = self.cfg, self.nodes_p[idx], self.nodes_v[idx], self.nodes_g[idx]
        pos, vel = sample_primitive(p, v, self.acc, self.ts)  # (M, S+1, 3)
        good = np.linalg.norm(vel[:, -1], axis=1) <= cfg.v_max_mps + 1e-9
        good &= self.chk.ok(pos)
        cand = np.flatnonzero(good)
        if cand.size == 0:
            return
        hs = self.heuristic(pos[cand, -1], vel[cand, -1])
        for j, h, kc in zip(cand, hs, self.keys(pos[cand, -1], vel[cand, -1]), strict=True):
            gc = g + float(self.acc_cost[j])
            if kc in self.closed or gc >= self.best_g.get(kc, np.inf):
                continue
            self.best_g[kc] = gc
            self.nodes_p.append(pos[j, -1])
            self.nodes_v.append(vel[j, -1])
            self.nodes_g.append(gc)
            self.parent.append(idx)
            self.parent_acc.append(self.acc[j])
            heapq.heappush(self.heap, (gc + float(h), next(self.tie), len(self.nodes_p) - 1))


def _backtrack(idx: int, parent: list[int], parent_acc: list[FloatArray],
               nodes_p: list[FloatArray], nodes_v: list[FloatArray]) -> list[tuple[FloatArray, FloatArray, FloatArray]]:
    """Chain ``[(p, v, a_applied_from_here)]`` from the root to node ``idx``."""
    chain: list[tuple[FloatArray, FloatArray, FloatArray]] = []
    child_acc = None
    while idx >= 0:
        a = child_acc if child_acc is not None else np.zeros(3)
        chain.append((nodes_p[idx], nodes_v[idx], a))
        child_acc = parent_acc[idx]
        idx = parent[idx]
    chain.reverse()
    return chain
