"""Ground and flat decorations: grass ground, heightfield terrain, streets, flat rectangles, the pad.

Flat ground decorations (pad, street, markings) are visual-only: they carry no collision
shape, so they are never obstacles and the drone lands on the ground below them.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import pybullet as p
from llmland_schemas.arrays import VecLike
from numpy.typing import NDArray

from .colours import ASPHALT, PAD, SIDEWALK, WHITE, pick
from .primitives import Rgba, box, create_compound, cylinder
from .textures import GRASS_TILE_M, create_textured_mesh_body, grass_image, solid_image

# Heights of the flat ground decorations above the surface they lie on (m). Layers that
# overlap are 1.5 cm apart: EGL on Mesa gives a 16-bit depth buffer (depth step ≈ 1.5 cm at
# 10 m with near = 0.1 m), so thinner layering flickers (z-fighting) there.
LAYER_M = 0.015
STREET_TOP_M = LAYER_M
SIDEWALK_TOP_M = 0.02
MARKING_TOP_M = 2 * LAYER_M
PAD_TOP_M = 2 * LAYER_M


def create_ground(client: int, rng: np.random.Generator, z_m: float = 0.0, half_size_m: float = 100.0) -> int:
    """Flat grass ground: a large box whose top face is the plane ``z = z_m``.

    Collision: box of ``2 * half_size_m`` square, 10 m thick. Visual: one textured quad with
    a seeded grass texture repeating every :data:`GRASS_TILE_M`. Returns the body id.
    """
    h = half_size_m
    thick = 5.0
    n = max(1, int(math.ceil(2.0 * h / 20.0)))  # 20 m tiles: cheaper for the TinyRenderer
    xs = np.linspace(-h, h, n + 1)
    gx, gy = np.meshgrid(xs, xs)
    verts = np.stack([gx.ravel(), gy.ravel(), np.full(gx.size, thick)], axis=1)
    uvs = (verts[:, :2] + h) / GRASS_TILE_M
    ii, jj = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    v00 = (ii * (n + 1) + jj).ravel()
    faces = np.concatenate([np.stack([v00, v00 + 1, v00 + n + 1], 1), np.stack([v00 + 1, v00 + n + 2, v00 + n + 1], 1)])
    col = p.createCollisionShape(p.GEOM_BOX, halfExtents=[h, h, thick], physicsClientId=client)
    return create_textured_mesh_body(client, verts, uvs, faces, grass_image(rng), col, (0.0, 0.0, z_m - thick))


def create_heightfield(client: int, rng: np.random.Generator, heights_m: NDArray[np.float64], cell_m: float) -> int:
    """Grass-textured heightfield terrain centred on the world origin.

    Args:
        heights_m: (ny, nx) ground heights; ``heights_m[i, j]`` is the height at
            ``x = (j - (nx-1)/2) * cell_m``, ``y = (i - (ny-1)/2) * cell_m``.
        cell_m: grid spacing.

    Pybullet centres a heightfield on the middle of its height range, so the base is placed at
    ``(min + max) / 2`` to keep the heights absolute. Each cell is split into two triangles
    along the diagonal from ``(j+1, i)`` to ``(j, i+1)`` (see ``Terrain.height`` in worlds);
    the visual mesh uses exactly the same triangles, so what is rendered is what collides.
    """
    ny, nx = heights_m.shape
    shape = p.createCollisionShape(
        p.GEOM_HEIGHTFIELD,
        meshScale=[cell_m, cell_m, 1.0],
        heightfieldData=[float(v) for v in heights_m.ravel()],
        numHeightfieldRows=ny,
        numHeightfieldColumns=nx,
        physicsClientId=client,
    )
    z0 = 0.5 * (float(heights_m.min()) + float(heights_m.max()))
    xs = (np.arange(nx) - (nx - 1) / 2.0) * cell_m
    ys = (np.arange(ny) - (ny - 1) / 2.0) * cell_m
    gx, gy = np.meshgrid(xs, ys)
    verts = np.stack([gx.ravel(), gy.ravel(), heights_m.ravel() - z0], axis=1)
    uvs = (verts[:, :2] - verts[:, :2].min(axis=0)) / GRASS_TILE_M
    ii, jj = np.meshgrid(np.arange(ny - 1), np.arange(nx - 1), indexing="ij")
    v00 = (ii * nx + jj).ravel()
    v10 = v00 + 1  # +x
    v01 = v00 + nx  # +y
    v11 = v01 + 1
    faces = np.concatenate([np.stack([v00, v10, v01], 1), np.stack([v10, v11, v01], 1)])
    return create_textured_mesh_body(client, verts, uvs, faces, grass_image(rng), shape, (0.0, 0.0, z0))


def create_flat_rects(
    client: int,
    rng: np.random.Generator,
    rects: Sequence[tuple[float, float, float, float, float]],
    rgba: Rgba,
    top_z_m: float,
    tile_m: float = 5.0,
) -> int:
    """One visual-only body of flat, upward-facing rectangles ``(cx, cy, half_x, half_y, yaw)``.

    Used for asphalt, sidewalks, lane markings and parking lines (m, rad); the surface lies
    at ``z = top_z_m``. Built as a tessellated mesh (tiles ≤ ``tile_m``) with a grainy
    texture of colour ``rgba``: thin boxes this long make the TinyRenderer very slow.
    """
    verts: list[tuple[float, float, float]] = []
    faces: list[tuple[int, int, int]] = []
    for cx, cy, hx, hy, yaw in rects:
        nx = max(1, int(math.ceil(2.0 * hx / tile_m)))
        ny = max(1, int(math.ceil(2.0 * hy / tile_m)))
        ux = np.array([math.cos(yaw), math.sin(yaw)])
        uy = np.array([-ux[1], ux[0]])
        base = len(verts)
        for i in range(ny + 1):
            for j in range(nx + 1):
                q = np.array([cx, cy]) + (-hx + 2.0 * hx * j / nx) * ux + (-hy + 2.0 * hy * i / ny) * uy
                verts.append((float(q[0]), float(q[1]), top_z_m))
        for i in range(ny):
            for j in range(nx):
                k = base + i * (nx + 1) + j
                faces += [(k, k + 1, k + nx + 1), (k + 1, k + nx + 2, k + nx + 1)]
    v = np.asarray(verts, dtype=float)
    return create_textured_mesh_body(
        client, v, v[:, :2] / GRASS_TILE_M, np.asarray(faces, dtype=np.int64), solid_image(rng, rgba), -1, (0, 0, 0)
    )


def create_street(
    client: int,
    rng: np.random.Generator,
    start_xy: VecLike,
    end_xy: VecLike,
    width_m: float = 7.0,
    sidewalk_width_m: float = 2.5,
) -> list[int]:
    """Straight two-lane street from ``start_xy`` to ``end_xy`` (centre line), flat, visual-only.

    Dark asphalt strip of ``width_m``, white edge lines, a dashed centre line and light grey
    sidewalks of ``sidewalk_width_m`` on both sides. Returns the created body ids.
    """
    a = np.asarray(start_xy, dtype=float)
    b = np.asarray(end_xy, dtype=float)
    d = b - a
    length = float(np.linalg.norm(d))
    if length <= 0.0:
        raise ValueError("street needs two distinct end points")
    u = d / length
    n = np.array([-u[1], u[0]])
    yaw = math.atan2(u[1], u[0])
    mid = 0.5 * (a + b)
    hw = width_m / 2.0

    def rect(along: float, across: float, half_l: float, half_w: float) -> tuple[float, float, float, float, float]:
        c = mid + along * u + across * n
        return (float(c[0]), float(c[1]), half_l, half_w, yaw)

    bodies = [create_flat_rects(client, rng, [rect(0.0, 0.0, length / 2.0, hw)], ASPHALT, STREET_TOP_M)]
    sw = [rect(0.0, s * (hw + sidewalk_width_m / 2.0), length / 2.0, sidewalk_width_m / 2.0) for s in (-1.0, 1.0)]
    bodies.append(create_flat_rects(client, rng, sw, SIDEWALK, SIDEWALK_TOP_M))
    lines = [rect(0.0, s * (hw - 0.2), length / 2.0, 0.06) for s in (-1.0, 1.0)]
    dash, gap = 3.0, 3.0
    n_dash = int(length // (dash + gap))
    start = -0.5 * n_dash * (dash + gap) + 0.5 * (dash + gap)
    lines += [rect(start + k * (dash + gap), 0.0, dash / 2.0, 0.06) for k in range(n_dash)]
    bodies.append(create_flat_rects(client, rng, lines, WHITE, MARKING_TOP_M))
    return bodies


def create_landing_pad(
    client: int,
    rng: np.random.Generator,
    position_m: VecLike,
    radius_m: float = 1.0,
    marker: str = "H",
    yaw_rad: float = 0.0,
) -> int:
    """Landing pad: flat coloured disc with an "H" or a cross (white or yellow) on top.

    Disc: radius ``radius_m``, 1.5 cm thick; marks another 1.5 cm (total :data:`PAD_TOP_M`).

    Visual-only (no collision shape): it is never an obstacle. ``position_m`` is the ground
    point under the pad centre.
    """
    base = pick(rng, PAD, 0.03)
    mark: Rgba = WHITE if rng.uniform() < 0.6 else (0.98, 0.85, 0.1, 1.0)
    r = radius_m
    t = LAYER_M
    parts = [cylinder((0.0, 0.0, t / 2.0), r, t, base, collide=False)]
    zt = 1.5 * t  # marks: a slab from t to 2t on top of the disc
    if marker == "H":
        parts += [
            box((0.0, 0.28 * r, zt), (0.42 * r, 0.07 * r, t / 2.0), mark, collide=False),
            box((0.0, -0.28 * r, zt), (0.42 * r, 0.07 * r, t / 2.0), mark, collide=False),
            box((0.0, 0.0, zt), (0.06 * r, 0.22 * r, t / 2.0), mark, collide=False),
        ]
    elif marker == "cross":
        parts += [
            box((0.0, 0.0, zt), (0.55 * r, 0.08 * r, t / 2.0), mark, collide=False),
            box((0.0, 0.0, zt), (0.08 * r, 0.55 * r, t / 2.0), mark, collide=False),
        ]
    else:
        raise ValueError(f"unknown pad marker {marker!r}")
    return create_compound(client, parts, position_m, yaw_rad, collision_parts=[])
