"""Textures and textured meshes: seeded grass / grain images written as PNG, OBJ meshes."""

from __future__ import annotations

import os
import shutil
import struct
import tempfile
import zlib

import numpy as np
import pybullet as p
from llmland_schemas.arrays import VecLike
from numpy.typing import NDArray

#: Size of one grass texture tile on the ground (m).
GRASS_TILE_M = 4.0


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


def solid_image(rng: np.random.Generator, rgb: VecLike, grain: float = 0.04, size_px: int = 32) -> NDArray[np.uint8]:
    """Tileable texture (size_px, size_px, 3) uint8 of colour ``rgb`` (0–1) with a fine grain."""
    shade = 1.0 + grain * rng.standard_normal((size_px, size_px))
    img = np.clip(np.asarray(rgb, dtype=float)[None, None, :3] * shade[..., None] * 255.0, 0, 255)
    return img.astype(np.uint8)
