"""A certificate that no path exists: start and goal separated in plan view by walls.

The kinodynamic search (:mod:`.search`) gives up only at its expansion budget, so a search
that cannot succeed costs the whole budget (seconds of wall time at the largest one, which the
lockstep sim waits for). Some of those can be told at once. A *wall* is an unsafe box that
spans every altitude a path may take: its bottom at or below the path floor ``z_floor_m`` and
its top at or above the workspace's ceiling. Outside the clearance balls around start and goal
(where region checks are waived, :class:`.search._Checker`) no path point can lie over a wall's
footprint, so if the walls' footprints cut the plane between the start ball and the goal ball,
the search cannot succeed.

The test is conservative (it may miss a separation, never invent one): on a plan-view grid of
``grid_res_m`` cells a cell is blocked only when it lies wholly inside one wall's closed
footprint, cells meeting a clearance disc are free, a ring of free cells around the grid stands
for everything outside it, and free cells connect 8-ways. Any continuous path outside the balls
and off the walls visits a chain of 8-adjacent cells, each holding one of its points, so none
blocked: separated cells imply no path. Obstacles that block only together (two boxes stacked
into a wall) are not counted, which only weakens the test.
"""

from __future__ import annotations

import numpy as np
from llmland_schemas.arrays import FloatArray
from scipy import ndimage

from .regions import UnsafeRegion, boxes_array, mark_cell_ranges

#: 8-connectivity of the plan-view grid
_EIGHT_WAYS = np.ones((3, 3), dtype=bool)


def separated(start_m: FloatArray, goal_m: FloatArray, regions: list[UnsafeRegion], *, z_floor_m: float,
              z_ceiling_m: float, clearance_radius_m: float, grid_res_m: float, margin_m: float) -> bool:
    """True when walls (boxes spanning ``[z_floor_m, z_ceiling_m]``) separate ``start_m`` from
    ``goal_m`` (each ``(3,)``, m) in plan view outside the clearance discs of
    ``clearance_radius_m`` about them; the grid spans both points ± ``margin_m`` (m)."""
    lo, hi = boxes_array(regions)
    walls = (lo[:, 2] <= z_floor_m) & (hi[:, 2] >= z_ceiling_m)
    if not np.any(walls):
        return False
    lo, hi = lo[walls, :2], hi[walls, :2]
    start, goal = np.asarray(start_m, dtype=float)[:2], np.asarray(goal_m, dtype=float)[:2]
    origin = np.minimum(start, goal) - margin_m
    shape = np.ceil((np.maximum(start, goal) + margin_m - origin) / grid_res_m).astype(int)
    nx, ny = int(shape[0]), int(shape[1])
    blocked = np.zeros((nx, ny), dtype=bool)
    # cell (i, j) is [origin + (i, j) * res, origin + (i + 1, j + 1) * res]: wholly inside a footprint
    first = np.ceil((lo - origin) / grid_res_m).astype(int)
    last = np.floor((hi - origin) / grid_res_m).astype(int) - 1
    mark_cell_ranges(blocked, first, last)
    corner_x = origin[0] + grid_res_m * np.arange(nx)
    corner_y = origin[1] + grid_res_m * np.arange(ny)
    for c in (start, goal):  # cells meeting a clearance disc are free
        dx = np.maximum(0.0, np.maximum(corner_x - c[0], c[0] - (corner_x + grid_res_m)))
        dy = np.maximum(0.0, np.maximum(corner_y - c[1], c[1] - (corner_y + grid_res_m)))
        blocked &= np.hypot(dx[:, None], dy[None, :]) > clearance_radius_m
    free = np.pad(~blocked, 1, constant_values=True)  # the outside, connected all round
    labels, _ = ndimage.label(free, structure=_EIGHT_WAYS)
    si, sj = np.floor((start - origin) / grid_res_m).astype(int) + 1
    gi, gj = np.floor((goal - origin) / grid_res_m).astype(int) + 1
    return bool(labels[si, sj] != labels[gi, gj])
