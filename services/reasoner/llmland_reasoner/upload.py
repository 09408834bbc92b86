"""Checks on client bodies before anything decodes them: image size from the header, JSON text.

Image dimensions are read from the file header, before Pillow sees the pixels: PNG from its
IHDR chunk (PNG spec, ISO/IEC 15948 §11.2.2: width and height are the first two 4-byte
big-endian fields of the first chunk), JPEG from its first start-of-frame segment (ITU-T
T.81 §B.2.2: SOF0-SOF15 except DHT C4, JPG C8 and DAC CC; height then width, 2 bytes each).
An image over the pixel limit is refused with 413 whatever its byte size (a decompression
bomb is small on the wire); Pillow's own ``DecompressionBombError`` is caught as a second line.
"""

from __future__ import annotations

import io
import json
import struct

from fastapi import HTTPException
from PIL import Image

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
JPEG_MAGIC = b"\xff\xd8\xff"
#: The largest image accepted, in pixels (a 4096 x 4096 frame; the VLE resizes to 384 x 384 anyway).
MAX_PIXELS = 4096 * 4096
_JPEG_SOF = frozenset(range(0xC0, 0xD0)) - {0xC4, 0xC8, 0xCC}
_JPEG_STANDALONE = frozenset({0x01, *range(0xD0, 0xD8)})


def image_size(data: bytes) -> tuple[int, int] | None:
    """(width, height) from a PNG or JPEG header; None when the header does not say."""
    if data.startswith(PNG_MAGIC):
        if len(data) >= 24 and data[12:16] == b"IHDR":
            width, height = struct.unpack(">II", data[16:24])
            return int(width), int(height)
        return None
    if data.startswith(JPEG_MAGIC):
        return _jpeg_size(data)
    return None


def _jpeg_size(data: bytes) -> tuple[int, int] | None:
    pos = 2
    while pos + 4 <= len(data):
        if data[pos] != 0xFF:
            return None
        marker = data[pos + 1]
        if marker == 0xFF:  # fill byte
            pos += 1
            continue
        if marker in _JPEG_STANDALONE:
            pos += 2
            continue
        (length,) = struct.unpack(">H", data[pos + 2 : pos + 4])
        if marker in _JPEG_SOF:
            if pos + 9 > len(data):
                return None
            height, width = struct.unpack(">HH", data[pos + 5 : pos + 9])
            return int(width), int(height)
        if length < 2:
            return None
        pos += 2 + length
    return None


class CaptionRefusedError(ValueError):
    """The VLE answered that it cannot caption an image (too small, not decodable): the upload's
    fault (a 4xx with the VLE's message), not a missing VLE (503)."""


class CaptionFailedError(RuntimeError):
    """The VLE answered with its own failure (its model failed, no captions configured): a 502."""


def check_image(data: bytes, max_bytes: int, max_pixels: int = MAX_PIXELS) -> None:
    """Raise the right 4xx for an upload that is empty, too big, not PNG/JPEG or corrupt."""
    if not data:
        raise HTTPException(400, "empty upload: send a PNG or JPEG image in the 'image' field")
    if len(data) > max_bytes:
        # the upload is read only up to one byte past the limit: its whole size is not known here
        raise HTTPException(413, f"image larger than the limit of {max_bytes} bytes")
    if not (data.startswith(PNG_MAGIC) or data.startswith(JPEG_MAGIC)):
        raise HTTPException(415, "not a PNG or JPEG image")
    size = image_size(data)
    if size is not None and size[0] * size[1] > max_pixels:
        raise HTTPException(413, f"image of {size[0]}x{size[1]} pixels is too large (limit {max_pixels} pixels)")
    try:
        with Image.open(io.BytesIO(data)) as img:
            if img.width * img.height > max_pixels:
                raise HTTPException(413, f"image of {img.width}x{img.height} pixels is too large")
            img.verify()
    except HTTPException:
        raise
    except Image.DecompressionBombError as exc:
        raise HTTPException(413, f"image too large: {exc}") from None
    except Exception as exc:  # noqa: BLE001 - a corrupt file raises whatever the decoder meets
        # (IndexError for a PNG without image data, struct.error, EOFError, …): all are the upload's fault
        raise HTTPException(400, f"corrupt image: {type(exc).__name__}: {exc}") from None


def json_body_problem(body: bytes) -> str | None:
    """Why a JSON request body cannot be read as text (None when it can)."""
    try:
        text = body.decode("utf-8")
    except UnicodeDecodeError as exc:
        return f"the body is not UTF-8 text (byte {exc.start})"
    try:
        value = json.loads(text)
    except (ValueError, RecursionError) as exc:  # ValueError: also an integer of > 4300 digits
        return f"the body is not valid JSON: {exc}"
    try:
        json.dumps(value, ensure_ascii=False).encode("utf-8")
    except UnicodeEncodeError:
        return "the body holds a lone UTF-16 surrogate (e.g. \\ud800): not Unicode text"
    except (ValueError, RecursionError) as exc:
        return f"the body is not valid JSON: {exc}"
    return None
