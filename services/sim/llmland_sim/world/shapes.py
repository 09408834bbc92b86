"""Pybullet body builders for the LLM-Land worlds (people, cars, buildings, vegetation, ...).

Every builder creates **one** pybullet body (so a segmentation pixel maps to exactly one
object) made of primitive parts: a ``createVisualShapeArray`` with one colour per part and,
for obstacles, a ``createCollisionShapeArray``. All bodies have mass 0, i.e. they are static
or kinematic (moved with ``resetBasePositionAndOrientation``); none is articulated, which keeps
``stepSimulation`` cheap.

Frames: every body's base frame sits on the ground at the centre of its footprint (``z`` up,
world frame ENU per ``docs/conventions.md``); local ``+x`` is the object's "forward" (a
person's facing direction, a car's front, a building's door side). ``position_m`` is that
base point and ``yaw_rad`` the rotation about world ``z``. Sizes are in metres.

Colours are drawn from the ``numpy.random.Generator`` passed in, so the same seed gives the
same colours. Flat ground decorations (pad, street, markings) are visual-only: they carry no
collision shape, so they are never obstacles and the drone lands on the ground below them.
"""

from __future__ import annotations

import logging
import math
import os
import shutil
import struct
import tempfile
import zlib
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pybullet as p
from numpy.typing import NDArray

logger = logging.getLogger(__name__)

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]
Rgba = tuple[float, float, float, float]
#: A point / vector given as a sequence or a numpy array.
VecLike = Sequence[float] | NDArray[np.float64]

IDENTITY_QUAT: Quat = (0.0, 0.0, 0.0, 1.0)
#: Most shapes pybullet accepts in one createVisualShapeArray / createCollisionShapeArray.
MAX_SHAPES_PER_ARRAY = 16

#: Person height used by :func:`create_person` by default (m).
PERSON_HEIGHT_M = 1.7
#: How far roof / windows / door of a building stick out of its walls (m).
BUILDING_OVERHANG_M = 0.06
#: How far a vehicle's lights stick out of its nominal length (m, each end).
VEHICLE_OVERHANG_M = 0.03
#: Default car extents (length, width, height) in metres.
CAR_SIZE_M: Vec3 = (4.3, 1.8, 1.5)
#: Default van extents (length, width, height) in metres.
VAN_SIZE_M: Vec3 = (5.0, 1.95, 2.1)

# Heights of the flat ground decorations above the surface they lie on (m). Layers that
# overlap are 1.5 cm apart: EGL on Mesa gives a 16-bit depth buffer (depth step ≈ 1.5 cm at
# 10 m with near = 0.1 m), so thinner layering flickers (z-fighting) there.
LAYER_M = 0.015
STREET_TOP_M = LAYER_M
SIDEWALK_TOP_M = 0.02
MARKING_TOP_M = 2 * LAYER_M
PAD_TOP_M = 2 * LAYER_M

_SKIN: tuple[Vec3, ...] = (
    (0.96, 0.80, 0.69),
    (0.87, 0.67, 0.52),
    (0.72, 0.53, 0.38),
    (0.55, 0.38, 0.26),
    (0.38, 0.26, 0.18),
)
_PANTS: tuple[Vec3, ...] = (
    (0.16, 0.22, 0.40),
    (0.10, 0.10, 0.12),
    (0.55, 0.48, 0.33),
    (0.35, 0.35, 0.37),
    (0.22, 0.30, 0.20),
)
_HAIR: tuple[Vec3, ...] = ((0.1, 0.07, 0.05), (0.35, 0.22, 0.1), (0.75, 0.6, 0.3), (0.5, 0.5, 0.5))
_CAR: tuple[Vec3, ...] = (
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
_BUILDING: tuple[Vec3, ...] = (
    (0.78, 0.72, 0.62),
    (0.70, 0.42, 0.32),
    (0.62, 0.64, 0.66),
    (0.85, 0.82, 0.74),
    (0.55, 0.50, 0.45),
    (0.80, 0.62, 0.45),
)
_PAD: tuple[Vec3, ...] = ((0.15, 0.15, 0.17), (0.90, 0.45, 0.08), (0.08, 0.28, 0.70), (0.70, 0.08, 0.08))

_GLASS: Rgba = (0.12, 0.16, 0.22, 1.0)
_TYRE: Rgba = (0.06, 0.06, 0.06, 1.0)
_WHITE: Rgba = (0.95, 0.95, 0.95, 1.0)
_ASPHALT: Rgba = (0.20, 0.20, 0.22, 1.0)
_SIDEWALK: Rgba = (0.62, 0.61, 0.58, 1.0)
_BARK: Rgba = (0.36, 0.25, 0.15, 1.0)


def _rgba(rgb: VecLike, alpha: float = 1.0) -> Rgba:
    return (float(rgb[0]), float(rgb[1]), float(rgb[2]), alpha)


def _jitter(rng: np.random.Generator, rgb: VecLike, amount: float = 0.06) -> Rgba:
    """Colour ``rgb`` with each channel shifted by ``U(-amount, amount)`` (clipped to [0, 1])."""
    c = np.clip(np.asarray(rgb, dtype=float) + rng.uniform(-amount, amount, 3), 0.0, 1.0)
    return _rgba(c)


def _pick(rng: np.random.Generator, palette: Sequence[Vec3], amount: float = 0.05) -> Rgba:
    return _jitter(rng, palette[int(rng.integers(len(palette)))], amount)


def _shade(c: Rgba, factor: float) -> Rgba:
    return (min(c[0] * factor, 1.0), min(c[1] * factor, 1.0), min(c[2] * factor, 1.0), c[3])


def _quat_yaw(yaw_rad: float) -> Quat:
    return (0.0, 0.0, math.sin(yaw_rad / 2.0), math.cos(yaw_rad / 2.0))


def _quat_axis(axis: Vec3, angle_rad: float) -> Quat:
    s = math.sin(angle_rad / 2.0)
    return (axis[0] * s, axis[1] * s, axis[2] * s, math.cos(angle_rad / 2.0))


_Y_AXIS_CYL: Quat = _quat_axis((1.0, 0.0, 0.0), math.pi / 2.0)  # cylinder axis z -> y


@dataclass(frozen=True)
class Part:
    """One primitive of a compound body, in the body's base frame (m).

    ``geom`` is a ``pybullet.GEOM_*`` constant: boxes use ``half_extents``, spheres ``radius``,
    cylinders and capsules ``radius`` and ``length`` (the cylindrical part, along local z).
    """

    geom: int
    pos: Vec3
    rgba: Rgba
    half_extents: Vec3 = (0.0, 0.0, 0.0)
    radius: float = 0.0
    length: float = 0.0
    quat: Quat = IDENTITY_QUAT
    collide: bool = True


def box(pos: Vec3, half: Vec3, rgba: Rgba, quat: Quat = IDENTITY_QUAT, collide: bool = True) -> Part:
    """A box part centred at ``pos`` with half extents ``half`` (m)."""
    return Part(p.GEOM_BOX, pos, rgba, half_extents=half, quat=quat, collide=collide)


def sphere(pos: Vec3, radius: float, rgba: Rgba, collide: bool = True) -> Part:
    """A sphere part centred at ``pos`` (m)."""
    return Part(p.GEOM_SPHERE, pos, rgba, radius=radius, collide=collide)


def cylinder(
    pos: Vec3, radius: float, length: float, rgba: Rgba, quat: Quat = IDENTITY_QUAT, collide: bool = True
) -> Part:
    """A cylinder part (axis = local z rotated by ``quat``) centred at ``pos`` (m)."""
    return Part(p.GEOM_CYLINDER, pos, rgba, radius=radius, length=length, quat=quat, collide=collide)


def capsule(pos: Vec3, radius: float, length: float, rgba: Rgba, collide: bool = True) -> Part:
    """A vertical capsule part; total height is ``length + 2 * radius`` (m)."""
    return Part(p.GEOM_CAPSULE, pos, rgba, radius=radius, length=length, collide=collide)


def create_compound(
    client: int,
    parts: Sequence[Part],
    position_m: VecLike,
    yaw_rad: float = 0.0,
    collision_parts: Sequence[Part] | None = None,
) -> int:
    """Create one mass-0 body from ``parts`` and return its pybullet body id.

    Args:
        client: pybullet physics client id.
        parts: visual parts (each with its own colour), in the base frame.
        position_m: base position (3,) in the world frame.
        yaw_rad: base rotation about world z.
        collision_parts: collision geometry; defaults to the parts with ``collide=True``.
            An empty selection makes the body visual-only (never an obstacle).
    """
    if not parts:
        raise ValueError("a compound body needs at least one part")

    def arrays(ps: Sequence[Part]) -> dict[str, list]:  # type: ignore[type-arg]
        return {
            "shapeTypes": [q.geom for q in ps],
            "halfExtents": [list(q.half_extents) for q in ps],
            "radii": [q.radius for q in ps],
            "lengths": [q.length for q in ps],
        }

    def visual_array(ps: Sequence[Part]) -> int:
        vid = p.createVisualShapeArray(
            **arrays(ps),
            rgbaColors=[list(q.rgba) for q in ps],
            visualFramePositions=[list(q.pos) for q in ps],
            visualFrameOrientations=[list(q.quat) for q in ps],
            physicsClientId=client,
        )
        if vid < 0:
            raise RuntimeError("pybullet failed to create a compound visual shape")
        return int(vid)

    # pybullet holds at most MAX_SHAPES_PER_ARRAY shapes per array (more overflow a fixed
    # buffer): extra visual parts go to fixed, mass-0 links of the same body.
    n = MAX_SHAPES_PER_ARRAY
    chunks = [visual_array(parts[k : k + n]) for k in range(0, len(parts), n)]
    cparts = [q for q in parts if q.collide] if collision_parts is None else list(collision_parts)
    if len(cparts) > n:
        raise ValueError(f"at most {n} collision parts per body")
    col = -1
    if cparts:
        col = p.createCollisionShapeArray(
            **arrays(cparts),
            collisionFramePositions=[list(q.pos) for q in cparts],
            collisionFrameOrientations=[list(q.quat) for q in cparts],
            physicsClientId=client,
        )
        if col < 0:
            raise RuntimeError("pybullet failed to create a compound collision shape")
    links = chunks[1:]
    zero3 = [0.0, 0.0, 0.0]
    body = p.createMultiBody(
        baseMass=0.0,
        baseCollisionShapeIndex=col,
        baseVisualShapeIndex=chunks[0],
        basePosition=[float(v) for v in position_m],
        baseOrientation=list(_quat_yaw(yaw_rad)),
        linkMasses=[0.0] * len(links),
        linkCollisionShapeIndices=[-1] * len(links),
        linkVisualShapeIndices=links,
        linkPositions=[zero3] * len(links),
        linkOrientations=[list(IDENTITY_QUAT)] * len(links),
        linkInertialFramePositions=[zero3] * len(links),
        linkInertialFrameOrientations=[list(IDENTITY_QUAT)] * len(links),
        linkParentIndices=[0] * len(links),
        linkJointTypes=[p.JOINT_FIXED] * len(links),
        linkJointAxis=[[0.0, 0.0, 1.0]] * len(links),
        physicsClientId=client,
    )
    return int(body)


# --------------------------------------------------------------------------- textures / ground


def _png_bytes(img: NDArray[np.uint8]) -> bytes:
    """Encode an RGB image (H, W, 3) uint8 as PNG (no external imaging dependency)."""
    h, w, _ = img.shape
    raw = b"".join(b"\x00" + img[r].tobytes() for r in range(h))

    def chunk(tag: bytes, data: bytes) -> bytes:
        crc = zlib.crc32(tag + data) & 0xFFFFFFFF
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", crc)

    header = struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b"")


def grass_image(rng: np.random.Generator, size_px: int = 128) -> NDArray[np.uint8]:
    """Tileable grass texture (size_px, size_px, 3) uint8: seeded green with blotches and grain."""
    base = np.array([0.30, 0.50, 0.19]) + rng.uniform(-0.04, 0.04, 3)
    freq = np.fft.fftfreq(size_px)
    f2 = freq[:, None] ** 2 + freq[None, :] ** 2
    low = np.real(np.fft.ifft2(np.fft.fft2(rng.standard_normal((size_px, size_px))) * np.exp(-f2 / 0.004)))
    low /= max(float(np.abs(low).max()), 1e-9)
    grain = rng.standard_normal((size_px, size_px))
    shade = 1.0 + 0.12 * low + 0.06 * grain
    img = np.clip(base[None, None, :] * shade[..., None] * 255.0, 0, 255)
    img[..., 0] = np.clip(img[..., 0] + 10.0 * low, 0, 255)  # drier (yellower) patches
    return img.astype(np.uint8)


def _vertex_normals(vertices: NDArray[np.float64], faces: NDArray[np.int64]) -> NDArray[np.float64]:
    """Area-weighted unit vertex normals (N, 3) of a triangle mesh."""
    v = np.asarray(vertices, dtype=float)
    f = np.asarray(faces, dtype=np.int64)
    fn = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    n = np.zeros_like(v)
    for k in range(3):
        np.add.at(n, f[:, k], fn)
    norm = np.linalg.norm(n, axis=1, keepdims=True)
    return np.where(norm > 0, n / np.maximum(norm, 1e-12), np.array([0.0, 0.0, 1.0]))


def create_textured_mesh_body(
    client: int,
    vertices_m: NDArray[np.float64],
    uvs: NDArray[np.float64],
    faces: NDArray[np.int64],
    texture_rgb: NDArray[np.uint8],
    collision_shape: int,
    base_position_m: VecLike,
) -> int:
    """Mass-0 body with a textured triangle-mesh visual; returns the body id.

    The mesh and its texture are written as a temporary OBJ/MTL/PNG triple that is deleted
    once the body exists (renderers read the files when the body is created). Going through a
    material file, instead of ``changeVisualShape(textureUniqueId=...)``, is what makes the
    texture show with the EGL renderer as well.

    Args:
        vertices_m: (N, 3) vertex positions in the body frame.
        uvs: (N, 2) texture coordinates (the texture repeats outside [0, 1]).
        faces: (M, 3) vertex indices (0-based, counter-clockwise seen from outside).
        texture_rgb: (H, W, 3) uint8 texture image.
        collision_shape: collision shape id of the body (-1 for none).
        base_position_m: (3,) base position in the world.
    """
    tmpdir = tempfile.mkdtemp(prefix="llmland_mesh_")
    try:
        with open(os.path.join(tmpdir, "tex.png"), "wb") as fh:
            fh.write(_png_bytes(texture_rgb))
        with open(os.path.join(tmpdir, "mesh.mtl"), "w") as fh:
            fh.write("newmtl m\nKa 1 1 1\nKd 1 1 1\nKs 0 0 0\nmap_Kd tex.png\n")
        lines = ["mtllib mesh.mtl", "o mesh"]
        lines += [f"v {x:.5f} {y:.5f} {z:.5f}" for x, y, z in vertices_m]
        lines += [f"vt {u:.5f} {v:.5f}" for u, v in uvs]
        lines += [f"vn {x:.5f} {y:.5f} {z:.5f}" for x, y, z in _vertex_normals(vertices_m, faces)]
        lines.append("usemtl m")
        lines += [f"f {a + 1}/{a + 1}/{a + 1} {b + 1}/{b + 1}/{b + 1} {c + 1}/{c + 1}/{c + 1}" for a, b, c in faces]
        obj = os.path.join(tmpdir, "mesh.obj")
        with open(obj, "w") as fh:
            fh.write("\n".join(lines) + "\n")
        vis = int(p.createVisualShape(p.GEOM_MESH, fileName=obj, physicsClientId=client))
        if vis < 0:
            raise RuntimeError("pybullet failed to create a textured mesh visual")
        body = int(
            p.createMultiBody(0.0, collision_shape, vis, [float(v) for v in base_position_m], physicsClientId=client)
        )
    finally:
        shutil.rmtree(tmpdir, ignore_errors=True)
    return body


#: Size of one grass texture tile on the ground (m).
GRASS_TILE_M = 4.0


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


# --------------------------------------------------------------------------- people / vehicles


def create_person(
    client: int,
    rng: np.random.Generator,
    position_m: VecLike = (0.0, 0.0, 0.0),
    yaw_rad: float = 0.0,
    height_m: float = PERSON_HEIGHT_M,
) -> int:
    """Humanoid silhouette (legs, torso, arms, neck, head, hair) facing local +x.

    Extents ≈ 0.3 (x) × 0.62 (y) × ``height_m`` (z); base at the feet. Collision is one capsule
    of radius 0.25 m spanning the full height (kinematic, mass 0).
    """
    s = height_m / PERSON_HEIGHT_M
    skin = _pick(rng, _SKIN, 0.03)
    shirt = _jitter(rng, rng.uniform(0.1, 0.9, 3), 0.0)
    pants = _pick(rng, _PANTS, 0.04)
    hair = _pick(rng, _HAIR, 0.03)
    parts = [
        capsule((0.0, 0.1 * s, 0.44 * s), 0.075 * s, 0.72 * s, pants, collide=False),
        capsule((0.0, -0.1 * s, 0.44 * s), 0.075 * s, 0.72 * s, pants, collide=False),
        box((0.0, 0.0, 0.92 * s), (0.11 * s, 0.18 * s, 0.07 * s), pants, collide=False),
        box((0.0, 0.0, 1.18 * s), (0.12 * s, 0.19 * s, 0.25 * s), shirt, collide=False),
        capsule((0.0, 0.255 * s, 1.13 * s), 0.055 * s, 0.46 * s, shirt, collide=False),
        capsule((0.0, -0.255 * s, 1.13 * s), 0.055 * s, 0.46 * s, shirt, collide=False),
        cylinder((0.0, 0.0, 1.47 * s), 0.05 * s, 0.08 * s, skin, collide=False),
        sphere((0.0, 0.0, 1.585 * s), 0.11 * s, skin, collide=False),
        sphere((-0.02 * s, 0.0, 1.61 * s), 0.1 * s, hair, collide=False),
    ]
    coll = [capsule((0.0, 0.0, 0.5 * height_m), 0.25 * s, height_m - 0.5 * s, skin)]
    return create_compound(client, parts, position_m, yaw_rad, collision_parts=coll)


def create_car(
    client: int,
    rng: np.random.Generator,
    position_m: VecLike,
    yaw_rad: float = 0.0,
    kind: str = "car",
) -> int:
    """Car (4.3×1.8×1.5 m) or van (5.0×1.95×2.1 m): body, glass cabin, roof, wheels, lights.

    Local +x is the front (headlights). Collision: body and cabin boxes.
    """
    paint = _pick(rng, _CAR, 0.04)
    parts: list[Part] = []
    if kind == "car":
        length, width, height = CAR_SIZE_M
        body_top, body_len = 0.95, length
        cabin_len, cabin_x = 2.3, -0.25
    elif kind == "van":
        length, width, height = VAN_SIZE_M
        body_top, body_len = 1.05, length
        cabin_len, cabin_x = 3.9, -0.45
    else:
        raise ValueError(f"unknown vehicle kind {kind!r}")
    clearance, wheel_r = 0.28, 0.33
    hl, hw = body_len / 2.0, width / 2.0
    parts.append(box((0.0, 0.0, 0.5 * (clearance + body_top)), (hl, hw, 0.5 * (body_top - clearance)), paint))
    roof_t = 0.06
    cab_h = height - body_top - roof_t
    parts.append(box((cabin_x, 0.0, body_top + cab_h / 2.0), (cabin_len / 2.0, hw - 0.08, cab_h / 2.0), _GLASS))
    parts.append(box((cabin_x, 0.0, height - roof_t / 2.0), (cabin_len / 2.0 + 0.02, hw - 0.03, roof_t / 2.0), paint))
    if kind == "van":  # rear body panels (under the roof) so the van is not a glass box
        parts.append(
            box(
                (cabin_x - 0.6, 0.0, body_top + cab_h / 2.0 - 0.01),
                (cabin_len / 2.0 - 0.6, hw - 0.05, cab_h / 2.0 - 0.01),
                paint,
                collide=False,
            )
        )
    wx = hl - 0.8
    for sx in (-1.0, 1.0):
        for sy in (-1.0, 1.0):
            parts.append(
                cylinder((sx * wx, sy * (hw - 0.12), wheel_r), wheel_r, 0.24, _TYRE, quat=_Y_AXIS_CYL, collide=False)
            )
    light_z = body_top - 0.2
    for sy in (-1.0, 1.0):
        parts.append(
            box((hl + 0.01, sy * (hw - 0.25), light_z), (0.02, 0.14, 0.06), (1.0, 0.97, 0.8, 1.0), collide=False)
        )
        parts.append(
            box((-hl - 0.01, sy * (hw - 0.25), light_z), (0.02, 0.14, 0.06), (0.8, 0.05, 0.05, 1.0), collide=False)
        )
    coll = [parts[0], parts[1]]
    return create_compound(client, parts, position_m, yaw_rad, collision_parts=coll)


# --------------------------------------------------------------------------- static obstacles


def create_building(
    client: int,
    rng: np.random.Generator,
    position_m: VecLike,
    size_m: Vec3,
    yaw_rad: float = 0.0,
) -> int:
    """Block building ``size_m = (x, y, z)`` with roof slab, window bands and a door on +x.

    Roof, windows and door stick out up to :data:`BUILDING_OVERHANG_M` beyond the walls; the
    roof slab adds 0.2 m of height.
    """
    sx, sy, sz = size_m
    wall = _pick(rng, _BUILDING, 0.05)
    roof = _shade(wall, 0.6)
    parts: list[Part] = [box((0.0, 0.0, sz / 2.0), (sx / 2.0, sy / 2.0, sz / 2.0), wall)]
    parts.append(box((0.0, 0.0, sz + 0.1), (sx / 2.0 + 0.05, sy / 2.0 + 0.05, 0.1), roof))
    floor_h = float(rng.uniform(2.9, 3.4))
    n_floors = max(1, int(sz / floor_h))
    for k in range(n_floors):
        zc = (k + 0.55) * floor_h
        if zc + 0.6 > sz - 0.3:
            break
        if k == 0:
            continue  # ground floor: door only
        parts.append(box((sx / 2.0 + 0.02, 0.0, zc), (0.02, sy / 2.0 - 0.6, 0.6), _GLASS, collide=False))
        parts.append(box((-sx / 2.0 - 0.02, 0.0, zc), (0.02, sy / 2.0 - 0.6, 0.6), _GLASS, collide=False))
        parts.append(box((0.0, sy / 2.0 + 0.02, zc), (sx / 2.0 - 0.6, 0.02, 0.6), _GLASS, collide=False))
        parts.append(box((0.0, -sy / 2.0 - 0.02, zc), (sx / 2.0 - 0.6, 0.02, 0.6), _GLASS, collide=False))
    parts.append(box((sx / 2.0 + 0.03, 0.0, 1.1), (0.03, 0.8, 1.1), (0.25, 0.18, 0.12, 1.0), collide=False))
    coll = [parts[0], parts[1]]
    return create_compound(client, parts, position_m, yaw_rad, collision_parts=coll)


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
    trunk_r = float(np.clip(0.08 * r + 0.06, 0.1, 0.35))
    parts: list[Part] = [
        cylinder((0.0, 0.0, trunk_height_m / 2.0), trunk_r, trunk_height_m, _jitter(rng, _BARK[:3], 0.04))
    ]
    if conifer:
        green = _jitter(rng, (0.10, 0.30, 0.14), 0.04)
        tiers = 4
        tier_h = 2.8 * r / tiers
        for k in range(tiers):
            rk = r * (1.0 - 0.22 * k)
            z = trunk_height_m - 0.3 + (k + 0.5) * tier_h * 0.9
            parts.append(cylinder((0.0, 0.0, z), rk, tier_h, _shade(green, 1.0 + 0.06 * k)))
        parts.append(sphere((0.0, 0.0, trunk_height_m - 0.3 + tiers * tier_h * 0.9 + 0.1 * r), 0.25 * r, green))
    else:
        green = _jitter(rng, (0.22, 0.45, 0.15), 0.05)
        zc = trunk_height_m + 0.75 * r
        parts.append(sphere((0.0, 0.0, zc), r, green))
        for k in range(2):
            ang = float(rng.uniform(0.0, 2.0 * math.pi))
            off = 0.45 * r
            parts.append(
                sphere(
                    (off * math.cos(ang), off * math.sin(ang), zc - (0.15 + 0.1 * k) * r),
                    0.7 * r,
                    _shade(green, 0.85 + 0.1 * k),
                )
            )
    return create_compound(client, parts, position_m, 0.0)


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
    green = _jitter(rng, (0.20, 0.40, 0.13), 0.05)
    parts = [sphere((x, y, z), r, _shade(green, 0.85 + 0.1 * k)) for k, (x, y, z, r) in enumerate(lobes)]
    return create_compound(client, parts, position_m, 0.0)


def create_shed(
    client: int,
    rng: np.random.Generator,
    position_m: VecLike,
    size_m: Vec3,
    yaw_rad: float = 0.0,
) -> int:
    """Garden shed: walls ``size_m = (x, y, wall height)``, gable roof (ridge along x), door on +x.

    Roof overhang 0.2 m (x) and 0.25 m (y), pitch 25°; see :func:`shed_height`.
    """
    sx, sy, hw = size_m
    wall = _jitter(rng, [(0.55, 0.35, 0.2), (0.6, 0.15, 0.12), (0.5, 0.52, 0.5)][int(rng.integers(3))], 0.05)
    roof = _jitter(rng, (0.22, 0.2, 0.2), 0.04)
    pitch = math.radians(25.0)
    ov_y = 0.25
    run = sy / 2.0 + ov_y
    plate_w = run / math.cos(pitch)
    ridge_z = hw + (sy / 2.0) * math.tan(pitch)
    parts: list[Part] = [box((0.0, 0.0, hw / 2.0), (sx / 2.0, sy / 2.0, hw / 2.0), wall)]
    # gable end fill (a box up to the ridge, narrower so it stays under the roof plates)
    gable_h = ridge_z - hw
    parts.append(box((0.0, 0.0, hw + gable_h / 2.0 - 0.05), (sx / 2.0, sy / 4.0, gable_h / 2.0), wall))
    for sgn in (-1.0, 1.0):
        yc = sgn * run / 2.0
        zc = ridge_z - (run / 2.0) * math.tan(pitch) + 0.05
        parts.append(
            box(
                (0.0, yc, zc),
                (sx / 2.0 + 0.2, plate_w / 2.0, 0.05),
                roof,
                quat=_quat_axis((1.0, 0.0, 0.0), -sgn * pitch),
            )
        )
    parts.append(box((sx / 2.0 + 0.02, 0.0, 0.95), (0.02, 0.45, 0.95), (0.15, 0.1, 0.07, 1.0), collide=False))
    return create_compound(client, parts, position_m, yaw_rad)


def shed_height(size_m: Vec3) -> float:
    """Total height (m) of a :func:`create_shed` shed (ridge top)."""
    return size_m[2] + (size_m[1] / 2.0) * math.tan(math.radians(25.0)) + 0.1


def create_rock(
    client: int,
    rng: np.random.Generator,
    position_m: VecLike,
    lobes: Sequence[tuple[float, float, float, float]],
) -> int:
    """Grey rock made of sphere lobes ``(x, y, z, r)`` (m, base frame), partly buried."""
    grey = _jitter(rng, (0.5, 0.49, 0.46), 0.06)
    parts = [sphere((x, y, z), r, _shade(grey, 0.9 + 0.1 * k)) for k, (x, y, z, r) in enumerate(lobes)]
    return create_compound(client, parts, position_m, 0.0)


def create_crate(
    client: int,
    rng: np.random.Generator,
    position_m: VecLike,
    size_m: Vec3,
    yaw_rad: float = 0.0,
) -> int:
    """Box / crate ``size_m = (x, y, z)`` standing on the ground, wood or painted."""
    sx, sy, sz = size_m
    colour = _jitter(
        rng, [(0.6, 0.45, 0.25), (0.25, 0.4, 0.6), (0.7, 0.65, 0.55), (0.5, 0.2, 0.15)][int(rng.integers(4))]
    )
    parts = [
        box((0.0, 0.0, sz / 2.0), (sx / 2.0, sy / 2.0, sz / 2.0), colour),
        box((0.0, 0.0, sz + 0.01), (sx / 2.0 - 0.05, sy / 2.0 - 0.05, 0.01), _shade(colour, 0.75), collide=False),
    ]
    return create_compound(client, parts, position_m, yaw_rad, collision_parts=[parts[0]])


# --------------------------------------------------------------------------- flat decorations


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
    base = _pick(rng, _PAD, 0.03)
    mark: Rgba = _WHITE if rng.uniform() < 0.6 else (0.98, 0.85, 0.1, 1.0)
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


def solid_image(rng: np.random.Generator, rgb: VecLike, grain: float = 0.04, size_px: int = 32) -> NDArray[np.uint8]:
    """Tileable texture (size_px, size_px, 3) uint8 of colour ``rgb`` (0–1) with a fine grain."""
    shade = 1.0 + grain * rng.standard_normal((size_px, size_px))
    img = np.clip(np.asarray(rgb, dtype=float)[None, None, :3] * shade[..., None] * 255.0, 0, 255)
    return img.astype(np.uint8)


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

    bodies = [create_flat_rects(client, rng, [rect(0.0, 0.0, length / 2.0, hw)], _ASPHALT, STREET_TOP_M)]
    sw = [rect(0.0, s * (hw + sidewalk_width_m / 2.0), length / 2.0, sidewalk_width_m / 2.0) for s in (-1.0, 1.0)]
    bodies.append(create_flat_rects(client, rng, sw, _SIDEWALK, SIDEWALK_TOP_M))
    lines = [rect(0.0, s * (hw - 0.2), length / 2.0, 0.06) for s in (-1.0, 1.0)]
    dash, gap = 3.0, 3.0
    n_dash = int(length // (dash + gap))
    start = -0.5 * n_dash * (dash + gap) + 0.5 * (dash + gap)
    lines += [rect(start + k * (dash + gap), 0.0, dash / 2.0, 0.06) for k in range(n_dash)]
    bodies.append(create_flat_rects(client, rng, lines, _WHITE, MARKING_TOP_M))
    return bodies
