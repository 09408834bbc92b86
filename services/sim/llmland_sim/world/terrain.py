"""Heightfield ground: the exact height pybullet collides with, and the seeded terrain heights."""

from __future__ import annotations

import math

import numpy as np
from llmland_schemas.arrays import FloatArray

#: Gaussian mounds: how many (inclusive), centres within this fraction of the half-size,
#: heights (m) and widths (m, 1 σ).
MOUND_COUNT = (7, 11)
MOUND_SPREAD = 0.9
MOUND_HEIGHT_RANGE_M = (0.25, 0.8)
MOUND_SIGMA_RANGE_M = (4.0, 9.0)
#: Undulation: wavenumbers (rad/m) along x and y, amplitude (m) around an offset (in amplitudes).
UNDULATION_WAVENUMBER_RANGE = (0.15, 0.35)
UNDULATION_AMPLITUDE_M = 0.06
UNDULATION_OFFSET = 2.0
#: The terrain ramps down to the flat ground over this distance (m) from the grid's edge.
EDGE_RAMP_M = 6.0


class Terrain:
    """Heightfield ground, exactly as pybullet triangulates it.

    ``heights_m[i, j]`` is the height at ``x = (j - (nx-1)/2) * cell_m``,
    ``y = (i - (ny-1)/2) * cell_m``; each cell is split along the diagonal from ``(j+1, i)``
    to ``(j, i+1)``. Outside the grid the ground is flat at ``outside_z_m``.
    """

    def __init__(self, heights_m: FloatArray, cell_m: float, outside_z_m: float) -> None:
        self.heights_m = np.asarray(heights_m, dtype=float)
        self.cell_m = float(cell_m)
        self.outside_z_m = float(outside_z_m)
        ny, nx = self.heights_m.shape
        self.half_x_m = 0.5 * (nx - 1) * self.cell_m
        self.half_y_m = 0.5 * (ny - 1) * self.cell_m

    def height(self, x: float, y: float) -> float:
        """Ground height (m) at world ``(x, y)``."""
        if not (-self.half_x_m <= x <= self.half_x_m and -self.half_y_m <= y <= self.half_y_m):
            return self.outside_z_m
        ny, nx = self.heights_m.shape
        fx = (x + self.half_x_m) / self.cell_m
        fy = (y + self.half_y_m) / self.cell_m
        j = min(int(math.floor(fx)), nx - 2)
        i = min(int(math.floor(fy)), ny - 2)
        u, v = fx - j, fy - i
        h = self.heights_m
        h00, h10, h01, h11 = h[i, j], h[i, j + 1], h[i + 1, j], h[i + 1, j + 1]
        if u + v <= 1.0:
            return float(h00 + (h10 - h00) * u + (h01 - h00) * v)
        return float(h11 + (h01 - h11) * (1.0 - u) + (h10 - h11) * (1.0 - v))


def smoothstep(x: FloatArray) -> FloatArray:
    t = np.clip(x, 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def terrain_heights(
    rng: np.random.Generator, n: int, cell_m: float, target_xy: FloatArray, flat_r_m: tuple[float, float]
) -> FloatArray:
    """Gentle positive terrain (n, n): Gaussian mounds + undulation, flat near the target."""
    xs = (np.arange(n) - (n - 1) / 2.0) * cell_m
    gx, gy = np.meshgrid(xs, xs)
    h = np.zeros_like(gx)
    half = xs[-1]
    for _ in range(int(rng.integers(MOUND_COUNT[0], MOUND_COUNT[1] + 1))):
        c = rng.uniform(-MOUND_SPREAD * half, MOUND_SPREAD * half, 2)
        amp = rng.uniform(*MOUND_HEIGHT_RANGE_M)
        sig = rng.uniform(*MOUND_SIGMA_RANGE_M)
        h += amp * np.exp(-((gx - c[0]) ** 2 + (gy - c[1]) ** 2) / (2.0 * sig**2))
    k = rng.uniform(*UNDULATION_WAVENUMBER_RANGE, 2)
    ph = rng.uniform(0.0, 2.0 * math.pi, 2)
    h += UNDULATION_AMPLITUDE_M * (UNDULATION_OFFSET + np.sin(k[0] * gx + ph[0]) + np.sin(k[1] * gy + ph[1]))
    r = np.hypot(gx - target_xy[0], gy - target_xy[1])
    h *= smoothstep((r - flat_r_m[0]) / (flat_r_m[1] - flat_r_m[0]))
    edge = np.minimum(half - np.abs(gx), half - np.abs(gy))
    h *= smoothstep(edge / EDGE_RAMP_M)
    return np.maximum(h, 0.0)
