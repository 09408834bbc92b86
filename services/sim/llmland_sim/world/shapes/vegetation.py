"""Trees, bushes and rocks: sphere / cylinder compounds, with their heights and footprints."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from llmland_schemas.arrays import VecLike

from .colours import BARK, jitter, shade
from .primitives import Part, create_compound, cylinder, sphere


def create_tree(
    client: int,
    rng: np.random.Generator,
    position_m: VecLike,
    trunk_height_m: float,
    crown_radius_m: float,
    conifer: bool = False,
) -> int:
    """Tree: trunk cylinder plus a crown of spheres (broadleaf) or stacked tiers (conifer).

    ``trunk_height_m`` is measured from the base; the crown starts a little below the trunk
    top. Footprint radius: ``crown_radius_m`` (conifer) or ``1.15 * crown_radius_m``
    (broadleaf, side lobes); total height: :func:`tree_height`.
    """
    r = crown_radius_m
    trunk_r = tree_trunk_radius(r)
    parts: list[Part] = [
        cylinder((0.0, 0.0, trunk_height_m / 2.0), trunk_r, trunk_height_m, jitter(rng, BARK[:3], 0.04))
    ]
    if conifer:
        green = jitter(rng, (0.10, 0.30, 0.14), 0.04)
        tiers = 4
        tier_h = 2.8 * r / tiers
        for k in range(tiers):
            rk = r * (1.0 - 0.22 * k)
            z = trunk_height_m - 0.3 + (k + 0.5) * tier_h * 0.9
            parts.append(cylinder((0.0, 0.0, z), rk, tier_h, shade(green, 1.0 + 0.06 * k)))
        parts.append(sphere((0.0, 0.0, trunk_height_m - 0.3 + tiers * tier_h * 0.9 + 0.1 * r), 0.25 * r, green))
    else:
        green = jitter(rng, (0.22, 0.45, 0.15), 0.05)
        zc = trunk_height_m + 0.75 * r
        parts.append(sphere((0.0, 0.0, zc), r, green))
        for k in range(2):
            ang = float(rng.uniform(0.0, 2.0 * math.pi))
            off = 0.45 * r
            parts.append(
                sphere(
                    (off * math.cos(ang), off * math.sin(ang), zc - (0.15 + 0.1 * k) * r),
                    0.7 * r,
                    shade(green, 0.85 + 0.1 * k),
                )
            )
    return create_compound(client, parts, position_m, 0.0)


def tree_trunk_radius(crown_radius_m: float) -> float:
    """Trunk radius (m) of a :func:`create_tree` tree: grows with the crown, within 0.1–0.35 m."""
    return float(np.clip(0.08 * crown_radius_m + 0.06, 0.1, 0.35))


def tree_height(trunk_height_m: float, crown_radius_m: float, conifer: bool) -> float:
    """Total height (m) of a :func:`create_tree` tree above its base."""
    r = crown_radius_m
    if conifer:
        tier_h = 2.8 * r / 4
        return trunk_height_m - 0.3 + 4 * tier_h * 0.9 + 0.35 * r
    return trunk_height_m + 1.75 * r


def tree_footprint_radius(crown_radius_m: float, conifer: bool) -> float:
    """Horizontal extent (radius, m) of a :func:`create_tree` tree around its base."""
    return crown_radius_m if conifer else 1.15 * crown_radius_m


def create_bush(
    client: int,
    rng: np.random.Generator,
    position_m: VecLike,
    lobes: Sequence[tuple[float, float, float, float]],
) -> int:
    """Bush made of sphere lobes ``(x, y, z, r)`` (m, base frame); lobes may sink into the ground."""
    green = jitter(rng, (0.20, 0.40, 0.13), 0.05)
    parts = [sphere((x, y, z), r, shade(green, 0.85 + 0.1 * k)) for k, (x, y, z, r) in enumerate(lobes)]
    return create_compound(client, parts, position_m, 0.0)


def create_rock(
    client: int,
    rng: np.random.Generator,
    position_m: VecLike,
    lobes: Sequence[tuple[float, float, float, float]],
) -> int:
    """Grey rock made of sphere lobes ``(x, y, z, r)`` (m, base frame), partly buried."""
    grey = jitter(rng, (0.5, 0.49, 0.46), 0.06)
    parts = [sphere((x, y, z), r, shade(grey, 0.9 + 0.1 * k)) for k, (x, y, z, r) in enumerate(lobes)]
    return create_compound(client, parts, position_m, 0.0)
