"""Square crops around pixel boxes and image resizing: one code path for training and run time.

Boxes are ``(u0, v0, u1, v1)`` in pixels with ``u1``/``v1`` exclusive (``rgb[v0:v1, u0:u1]``),
as in :class:`llmland_schemas.depth.Blob`. A crop is the box's bounding square grown by a
context margin; parts outside the image are filled with the nearest edge pixels, so an
object at the border keeps its look.
"""

from __future__ import annotations

import io

import numpy as np
from numpy.typing import NDArray
from PIL import Image

Box = tuple[int, int, int, int]
Uint8Image = NDArray[np.uint8]

#: Context added on every side of a box, as a fraction of its longer side.
CROP_MARGIN = 0.15
#: Smallest crop side in source pixels (tiny boxes get some context).
MIN_CROP_PX = 24
#: Images larger than this (pixels a side) or smaller than 8 px are refused by :func:`load_image`.
MAX_IMAGE_SIDE_PX = 4096


class ImageError(ValueError):
    """Bytes that are not a usable image."""


def square_box(box: Box, margin: float = CROP_MARGIN, min_side_px: int = MIN_CROP_PX) -> Box:
    """The square (may extend past the image) centred on ``box``, grown by ``margin``."""
    u0, v0, u1, v1 = box
    w, h = max(u1 - u0, 1), max(v1 - v0, 1)
    side = max(int(round(max(w, h) * (1.0 + 2.0 * margin))), min_side_px)
    cu, cv = (u0 + u1) / 2.0, (v0 + v1) / 2.0
    su, sv = int(round(cu - side / 2.0)), int(round(cv - side / 2.0))
    return su, sv, su + side, sv + side


def crop_square(image: Uint8Image, box: Box, size: int, margin: float = CROP_MARGIN) -> Uint8Image:
    """(size, size, 3) uint8 crop of ``image`` (H, W, 3) around ``box``; edges replicated."""
    h, w = image.shape[:2]
    su, sv, eu, ev = square_box(box, margin)
    rows = np.clip(np.arange(sv, ev), 0, h - 1)
    cols = np.clip(np.arange(su, eu), 0, w - 1)
    if 0 <= su and eu <= w and 0 <= sv and ev <= h:
        patch = image[sv:ev, su:eu]
    else:
        patch = image[rows[:, None], cols[None, :]]
    return resize(np.ascontiguousarray(patch), size)


def resize(image: Uint8Image, size: int) -> Uint8Image:
    """Bilinear resize of an (H, W, 3) uint8 image to (size, size, 3)."""
    if image.shape[0] == size and image.shape[1] == size:
        return image
    pil = Image.fromarray(image)
    return np.asarray(pil.convert("RGB").resize((size, size), Image.Resampling.BILINEAR), dtype=np.uint8)


def load_image(data: bytes, max_side_px: int = MAX_IMAGE_SIDE_PX) -> Uint8Image:
    """Decode PNG/JPEG bytes to (H, W, 3) uint8 RGB; raise :class:`ImageError` if not an image."""
    if not data:
        raise ImageError("empty image payload")
    try:
        with Image.open(io.BytesIO(data)) as img:
            if img.format not in ("PNG", "JPEG"):
                raise ImageError(f"unsupported image format {img.format!r} (send PNG or JPEG)")
            w, h = img.size
            if not (8 <= w <= max_side_px and 8 <= h <= max_side_px):
                raise ImageError(f"image of {w}x{h} px is outside 8..{max_side_px} px a side")
            rgb = np.asarray(img.convert("RGB"), dtype=np.uint8)
    except ImageError:
        raise
    except Exception as exc:  # PIL raises many types for corrupt data
        raise ImageError(f"not a decodable PNG/JPEG image: {exc}") from None
    return rgb


def encode_png(image: Uint8Image) -> bytes:
    """PNG bytes of an (H, W, 3) uint8 image."""
    buf = io.BytesIO()
    Image.fromarray(image).save(buf, format="PNG")
    return buf.getvalue()


def check_rgb(image: NDArray[np.generic]) -> Uint8Image:
    """Validate an (H, W, 3) uint8 image array; raise :class:`ImageError` otherwise."""
    arr = np.asarray(image)
    if arr.dtype != np.uint8 or arr.ndim != 3 or arr.shape[2] != 3 or min(arr.shape[:2]) < 1:
        raise ImageError(f"expected an (H, W, 3) uint8 image, got {arr.dtype} {arr.shape}")
    return arr.astype(np.uint8, copy=False)
