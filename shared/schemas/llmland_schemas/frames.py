"""Image/depth frame codec: a typed JSON header followed by raw pixel bytes.

Wire layout (little endian)::

    b"LLMF" | u32 header_len | header JSON (CameraFrameHeader) | rgb bytes | depth bytes

RGB is ``uint8`` (H, W, 3) row-major; depth is ``float32`` (H, W) metric z-depth along the
optical axis, ``inf`` where nothing was hit. Depth may be absent (``depth_encoding`` null).
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

import numpy as np

from .codec import MessageError, decode, encode
from .messages import CameraFrameHeader

MAGIC = b"LLMF"
_PREFIX = struct.Struct("<4sI")
MAX_HEADER_BYTES = 64 * 1024


@dataclass(frozen=True)
class CameraFrame:
    """A decoded frame: header plus pixel arrays."""

    header: CameraFrameHeader
    rgb: np.ndarray  # (H, W, 3) uint8
    depth_m: np.ndarray | None  # (H, W) float32, metres

    @property
    def T_world_camera(self) -> np.ndarray:  # noqa: N802 - conventional name
        """(4, 4) float64 transform from the optical camera frame to the world."""
        return np.asarray(self.header.T_world_camera, dtype=np.float64).reshape(4, 4)


def encode_frame(header: CameraFrameHeader, rgb: np.ndarray, depth_m: np.ndarray | None) -> bytes:
    """Pack a frame. Shapes must match ``header.width``/``height``."""
    h, w = header.height, header.width
    if rgb.shape != (h, w, 3) or rgb.dtype != np.uint8:
        raise ValueError(f"rgb must be uint8 ({h}, {w}, 3), got {rgb.dtype} {rgb.shape}")
    if depth_m is not None and depth_m.shape != (h, w):
        raise ValueError(f"depth must be ({h}, {w}), got {depth_m.shape}")
    if (depth_m is None) != (header.depth_encoding is None):
        raise ValueError("depth array and header.depth_encoding disagree")
    head = encode(header)
    parts = [_PREFIX.pack(MAGIC, len(head)), head, np.ascontiguousarray(rgb).tobytes()]
    if depth_m is not None:
        parts.append(np.ascontiguousarray(depth_m, dtype="<f4").tobytes())
    return b"".join(parts)


def peek_header(payload: bytes | bytearray | memoryview) -> CameraFrameHeader:
    """Only the typed header of a frame (no pixel copy); :class:`MessageError` if malformed."""
    buf = memoryview(payload)
    if len(buf) < _PREFIX.size:
        raise MessageError(f"frame of {len(buf)} bytes is shorter than its prefix")
    magic, head_len = _PREFIX.unpack_from(buf, 0)
    if magic != MAGIC:
        raise MessageError(f"bad frame magic {bytes(magic)!r}")
    if head_len > MAX_HEADER_BYTES or _PREFIX.size + head_len > len(buf):
        raise MessageError(f"bad frame header length {head_len}")
    return decode(CameraFrameHeader, buf[_PREFIX.size : _PREFIX.size + head_len])


def decode_frame(payload: bytes | bytearray | memoryview) -> CameraFrame:
    """Unpack and check a frame; raise :class:`MessageError` on anything malformed."""
    buf = memoryview(bytes(payload))
    if len(buf) < _PREFIX.size:
        raise MessageError(f"frame of {len(buf)} bytes is shorter than its prefix")
    magic, head_len = _PREFIX.unpack_from(buf, 0)
    if magic != MAGIC:
        raise MessageError(f"bad frame magic {bytes(magic)!r}")
    if head_len > MAX_HEADER_BYTES or _PREFIX.size + head_len > len(buf):
        raise MessageError(f"bad frame header length {head_len}")
    start = _PREFIX.size
    header = decode(CameraFrameHeader, buf[start : start + head_len])
    h, w = header.height, header.width
    rgb_len = h * w * 3
    depth_len = h * w * 4 if header.depth_encoding is not None else 0
    body = buf[start + head_len :]
    if len(body) != rgb_len + depth_len:
        raise MessageError(
            f"frame body is {len(body)} bytes, header ({w}x{h}, depth={header.depth_encoding}) "
            f"needs {rgb_len + depth_len}"
        )
    rgb = np.frombuffer(body[:rgb_len], dtype=np.uint8).reshape(h, w, 3)
    depth = None
    if depth_len:
        depth = np.frombuffer(body[rgb_len:], dtype="<f4").reshape(h, w)
        if np.isnan(depth).any():
            raise MessageError("depth contains NaN")
    return CameraFrame(header=header, rgb=rgb, depth_m=depth)
