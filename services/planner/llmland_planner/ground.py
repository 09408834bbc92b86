"""A 2.5-D terrain estimate from depth points, so hills are ground and not obstacles.

The planner is never told the terrain. Every depth frame's points vote for the lowest height
seen in each ``cell_m`` cell of a grid centred on the landing target; the ground under a point
is the lower envelope ``g(x) = min_j (z_min_j + max_slope · |x − x_j|)`` over cells within
``window_m`` (a grey erosion with a cone), so a cell whose lowest point is an object's top (a
car roof seen from above) takes the height of the ground seen next to it, while gentle terrain
(slopes below ``max_slope``) keeps its own height. Unobserved cells fall back to the target's
ground height. Points above ``g + tolerance`` are obstacle points (``llmland_schemas.depth``).

:meth:`GroundMap.reach_floor` turns the estimate into the hard limit's floor: the highest ground
within reach of each point, so that paths over a mound stay above the heads of people standing on
it (:class:`ReachFloor`).

Points are staged (:meth:`GroundMap.stage`, from any thread, in any order) and folded in by
:meth:`GroundMap.commit` in stamp order; :meth:`GroundMap.height` reads only committed points,
so what a frame's blobs look like never depends on the order two cameras' frames arrived in.
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass

import numpy as np
from llmland_schemas.arrays import FloatArray
from scipy import ndimage

#: grid cell (m), half size of the mapped square (m) and erosion window radius (m)
CELL_M = 1.0
HALF_SIZE_M = 40.0
WINDOW_M = 3.0
#: steepest terrain the estimate follows (rise per run); steeper rises are obstacles
MAX_SLOPE = 0.25


@dataclass(frozen=True)
class ReachFloor:
    """The lowest altitude (m) out of everyone's reach over a plan-view grid, frozen at one instant.

    ``top[i, j]``: the highest ground (m) any person whose body axis is within the reach radius of a
    point of cell ``(i, j)`` can stand on, estimate error included (:meth:`GroundMap.reach_floor`);
    the floor is ``top + clearance_m``. Outside the grid: ``outside_m + clearance_m``.
    """

    origin: FloatArray  # (2,) m, the grid's corner
    cell_m: float
    top: FloatArray  # (n, n) m
    outside_m: float
    clearance_m: float

    @property
    def lowest_m(self) -> float:
        """The floor's minimum (m) anywhere."""
        return min(float(self.top.min()), self.outside_m) + self.clearance_m

    def __call__(self, xy: FloatArray) -> FloatArray:
        """Floor (m) at plan-view points ``(..., 2)`` → ``(...)``."""
        p = np.asarray(xy, dtype=float)
        i = np.floor((p[..., 0] - self.origin[0]) / self.cell_m).astype(np.int64)
        j = np.floor((p[..., 1] - self.origin[1]) / self.cell_m).astype(np.int64)
        n = self.top.shape[0]
        inside = (i >= 0) & (i < n) & (j >= 0) & (j < n)
        out = np.full(p.shape[:-1], self.outside_m)
        out[inside] = self.top[i[inside], j[inside]]
        return out + self.clearance_m


@dataclass(frozen=True)
class GroundSurface:
    """The ground estimate frozen at one commit (:meth:`GroundMap.surface`): ``ground[i, j]`` (m)
    over the cell with corner ``origin + (i, j) · cell_m``, ``outside_m`` off the grid.

    ``lowest_m`` is no higher than the height anywhere (the minimum of both), so a point lower
    than ``lowest_m + tolerance`` is ground without looking its cell up
    (``llmland_schemas.depth.find_blobs``'s ``ground_floor_m``). Never changed in place: safe to
    read on another thread while the map commits new points.
    """

    origin: FloatArray  # (2,) m
    cell_m: float
    ground: FloatArray  # (n, n) m
    outside_m: float

    @property
    def lowest_m(self) -> float:
        return min(float(self.ground.min()), self.outside_m)

    def __call__(self, x: FloatArray, y: FloatArray) -> FloatArray:
        """Ground height (m) under world points (vectorised over equal shapes)."""
        xa, ya = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
        n = self.ground.shape[0]
        # cell indices as floats, tested before any cast (a depth frame's points: one pass each);
        # NaN fails every comparison and ±inf one of them, so they are outside and take the
        # target's height
        with np.errstate(invalid="ignore"):  # inf - inf in the index of a point that is outside
            fi = np.floor((xa - self.origin[0]) / self.cell_m)
            fj = np.floor((ya - self.origin[1]) / self.cell_m)
            ok = (fi >= 0) & (fi < n) & (fj >= 0) & (fj < n)
            flat = np.where(ok, fi * n + fj, 0.0).astype(np.intp)  # row-major cell index (exact in float)
        return np.where(ok, self.ground.ravel().take(flat), self.outside_m)


class GroundMap:
    """Lowest heights seen per cell around the target, and the ground envelope from them."""

    def __init__(self, centre_m: FloatArray, cell_m: float = CELL_M, half_size_m: float = HALF_SIZE_M,
                 window_m: float = WINDOW_M, max_slope: float = MAX_SLOPE) -> None:
        self.centre = np.asarray(centre_m, dtype=float)
        self.cell = cell_m
        self.n = int(round(2.0 * half_size_m / cell_m))
        self.origin = self.centre[:2] - half_size_m
        self._zmin = np.full((self.n, self.n), np.inf)
        r = int(round(window_m / cell_m))
        ii, jj = np.mgrid[-r:r + 1, -r:r + 1]
        dist = np.hypot(ii, jj) * cell_m
        self._footprint = dist <= window_m + 1e-9
        self._cone = -max_slope * dist  # erosion subtracts the structure: min(z + slope · d)
        self._max_slope = max_slope
        self._floor_cache: tuple[FloatArray, tuple[float, float], ReachFloor] | None = None
        self._ground = np.full((self.n, self.n), self.centre[2])
        self._dirty = False
        self._staged: dict[tuple[float, str], FloatArray | None] = {}
        self._lock = threading.Lock()

    def stage(self, stamp_s: float, source: str, points_world: FloatArray) -> None:
        """Hold a frame's points until :meth:`commit` reaches its stamp, as their lowest height per
        cell (found here, on the frame's thread: a commit only takes the minimum of two grids)."""
        minima = self._cell_minima(points_world)
        with self._lock:
            self._staged[(stamp_s, source)] = minima

    def commit(self, upto_s: float) -> None:
        """Fold in every staged frame stamped at or before ``upto_s`` (s, exactly: the caller allows
        for rounding), oldest first."""
        with self._lock:
            due = sorted(k for k in self._staged if k[0] <= upto_s)
            frames = [self._staged.pop(k) for k in due]
        for minima in frames:
            self._fold(minima)
        with self._lock:
            self._refresh()

    def _cells(self, x: FloatArray, y: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        i = np.floor((x - self.origin[0]) / self.cell).astype(np.int64)
        j = np.floor((y - self.origin[1]) / self.cell).astype(np.int64)
        inside = (i >= 0) & (i < self.n) & (j >= 0) & (j < self.n)
        return i, j, inside

    def _cell_minima(self, points_world: FloatArray) -> FloatArray | None:
        """The lowest height (m) of points ``(..., 3)`` in each cell, ``inf`` where none fell,
        as an (n, n) grid; None when no point is finite (NaN where invalid)."""
        p = np.asarray(points_world, dtype=float).reshape(-1, 3)
        p = p[np.all(np.isfinite(p), axis=1)]
        if p.size == 0:
            return None
        i, j, inside = self._cells(p[:, 0], p[:, 1])
        minima = np.full((self.n, self.n), np.inf)
        np.minimum.at(minima, (i[inside], j[inside]), p[inside, 2])
        return minima

    def _fold(self, minima: FloatArray | None) -> None:
        """Lower the per-cell minima to ``minima`` (a :meth:`_cell_minima` grid) where lower."""
        if minima is None:
            return
        np.minimum(self._zmin, minima, out=self._zmin)
        self._dirty = True

    def _refresh(self) -> None:
        if not self._dirty:
            return
        observed = np.isfinite(self._zmin)
        z = np.where(observed, self._zmin, 1e6)
        env = ndimage.grey_erosion(z, footprint=self._footprint, structure=self._cone, mode="nearest")
        self._ground = np.where(env < 1e5, env, self.centre[2])
        self._dirty = False

    def surface(self) -> GroundSurface:
        """The committed estimate as one frozen :class:`GroundSurface` (heights and their lower
        bound from the same commit: a commit replaces the heights' array, never changes it)."""
        return GroundSurface(self.origin, self.cell, self._ground, float(self.centre[2]))

    def reach_floor(self, reach_m: float, clearance_m: float) -> ReachFloor:
        """The floor (m) ``clearance_m`` above the highest ground within ``reach_m`` horizontally.

        A cell's estimate can be below the true ground anywhere in it by the terrain's rise across
        the cell (the lowest point seen, and the cone's slope, :data:`MAX_SLOPE`): at most
        ``max_slope · cell · √2``, added here. The dilation takes every cell whose centre lies
        within ``reach_m + cell · √2`` of a cell's centre (the point and the person anywhere in
        their cells). Cells never observed are taken at the target's ground (an assumption: the
        cameras look where the vehicle flies). The arrays are never changed in place, so the
        snapshot is safe to read on another thread.
        """
        with self._lock:
            self._refresh()
            ground = self._ground
        cached = self._floor_cache
        if cached is not None and cached[0] is ground and cached[1] == (reach_m, clearance_m):
            return cached[2]
        r = int(math.ceil(reach_m / self.cell + math.sqrt(2.0)))
        ii, jj = np.mgrid[-r:r + 1, -r:r + 1]
        footprint = np.hypot(ii, jj) * self.cell <= reach_m + self.cell * math.sqrt(2.0) + 1e-9
        error = self._max_slope * self.cell * math.sqrt(2.0)
        top = ndimage.grey_dilation(ground, footprint=footprint, mode="nearest") + error
        floor = ReachFloor(self.origin.copy(), self.cell, top, float(self.centre[2]) + error, clearance_m)
        self._floor_cache = (ground, (reach_m, clearance_m), floor)
        return floor

    def height(self, x: FloatArray, y: FloatArray) -> FloatArray:
        """Ground height (m) under world points (vectorised over equal shapes), committed points only."""
        return self.surface()(x, y)
