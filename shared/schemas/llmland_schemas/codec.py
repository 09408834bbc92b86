"""JSON codec for bus messages: bytes in, validated pydantic models out."""

from __future__ import annotations

from typing import TypeVar

from pydantic import BaseModel, ValidationError

M = TypeVar("M", bound=BaseModel)

#: Payloads larger than this are refused before parsing (bytes).
MAX_JSON_BYTES = 4 * 1024 * 1024


class MessageError(ValueError):
    """A payload that is not a valid message of the expected type."""


def encode(msg: BaseModel) -> bytes:
    """Serialise a message to compact UTF-8 JSON."""
    return msg.model_dump_json().encode()


def decode(model: type[M], payload: bytes | bytearray | memoryview) -> M:
    """Parse and validate ``payload`` as ``model``; raise :class:`MessageError` if not."""
    data = bytes(payload)
    if len(data) > MAX_JSON_BYTES:
        raise MessageError(f"{model.__name__}: payload of {len(data)} bytes exceeds {MAX_JSON_BYTES}")
    try:
        return model.model_validate_json(data)
    except ValidationError as exc:
        first = exc.errors()[0]
        where = ".".join(str(x) for x in first.get("loc", ())) or "<root>"
        raise MessageError(
            f"{model.__name__}: {exc.error_count()} error(s), first at {where}: {first.get('msg')}"
        ) from None
