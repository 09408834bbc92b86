"""Seeded colours: palettes (RGB, 0–1) and the jitter / pick / shade helpers.

Colours are drawn from the ``numpy.random.Generator`` passed in, so the same seed gives the
same colours.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from llmland_schemas.arrays import VecLike

from .primitives import Rgba, Vec3

SKIN: tuple[Vec3, ...] = (
    (0.96, 0.80, 0.69),
    (0.87, 0.67, 0.52),
    (0.72, 0.53, 0.38),
    (0.55, 0.38, 0.26),
    (0.38, 0.26, 0.18),
)
PANTS: tuple[Vec3, ...] = (
    (0.16, 0.22, 0.40),
    (0.10, 0.10, 0.12),
    (0.55, 0.48, 0.33),
    (0.35, 0.35, 0.37),
    (0.22, 0.30, 0.20),
)
HAIR: tuple[Vec3, ...] = ((0.1, 0.07, 0.05), (0.35, 0.22, 0.1), (0.75, 0.6, 0.3), (0.5, 0.5, 0.5))
CAR: tuple[Vec3, ...] = (
    (0.80, 0.10, 0.10),
    (0.10, 0.25, 0.70),
    (0.92, 0.92, 0.92),
    (0.08, 0.08, 0.09),
    (0.55, 0.57, 0.60),
    (0.10, 0.45, 0.20),
    (0.95, 0.75, 0.10),
    (0.45, 0.12, 0.40),
    (0.25, 0.45, 0.75),
)
BUILDING: tuple[Vec3, ...] = (
    (0.78, 0.72, 0.62),
    (0.70, 0.42, 0.32),
    (0.62, 0.64, 0.66),
    (0.85, 0.82, 0.74),
    (0.55, 0.50, 0.45),
    (0.80, 0.62, 0.45),
)
PAD: tuple[Vec3, ...] = ((0.15, 0.15, 0.17), (0.90, 0.45, 0.08), (0.08, 0.28, 0.70), (0.70, 0.08, 0.08))

GLASS: Rgba = (0.12, 0.16, 0.22, 1.0)
TYRE: Rgba = (0.06, 0.06, 0.06, 1.0)
WHITE: Rgba = (0.95, 0.95, 0.95, 1.0)
ASPHALT: Rgba = (0.20, 0.20, 0.22, 1.0)
SIDEWALK: Rgba = (0.62, 0.61, 0.58, 1.0)
BARK: Rgba = (0.36, 0.25, 0.15, 1.0)


def rgba(rgb: VecLike, alpha: float = 1.0) -> Rgba:
    return (float(rgb[0]), float(rgb[1]), float(rgb[2]), alpha)


def jitter(rng: np.random.Generator, rgb: VecLike, amount: float = 0.06) -> Rgba:
    """Colour ``rgb`` with each channel shifted by ``U(-amount, amount)`` (clipped to [0, 1])."""
    c = np.clip(np.asarray(rgb, dtype=float) + rng.uniform(-amount, amount, 3), 0.0, 1.0)
    return rgba(c)


def pick(rng: np.random.Generator, palette: Sequence[Vec3], amount: float = 0.05) -> Rgba:
    return jitter(rng, palette[int(rng.integers(len(palette)))], amount)


def shade(c: Rgba, factor: float) -> Rgba:
    return (min(c[0] * factor, 1.0), min(c[1] * factor, 1.0), min(c[2] * factor, 1.0), c[3])
