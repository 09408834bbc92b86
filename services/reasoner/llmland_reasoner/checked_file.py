"""Cache files that carry their own SHA-256: written atomically, rejected when damaged.

Used for what the reasoner keeps between runs to start faster (the LLM's evaluated prompt
prefixes, WordNet's lemma index): a file is ``sha256(data) ‖ data``, written to a temporary
name and renamed into place (a concurrent reader sees the old file or the new one, never half
of one), and read back only when the digest matches (a truncated or damaged file reads as
absent, so the caller recomputes it).
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

DIGEST_BYTES = 32


class DamagedFileError(Exception):
    """The file exists but its content does not match its digest."""


def read_checked(path: Path) -> bytes | None:
    """The data written by :func:`write_checked`; None when there is no readable file.
    Raises :class:`DamagedFileError` when the file's digest does not match its content."""
    try:
        raw = path.read_bytes()
    except OSError:
        return None
    digest, data = raw[:DIGEST_BYTES], raw[DIGEST_BYTES:]
    if hashlib.sha256(data).digest() != digest:
        raise DamagedFileError(str(path))
    return data


def write_checked(path: Path, data: bytes) -> None:
    """Write ``data`` with its digest, atomically; creates the folder. Raises OSError (nothing
    is left behind) when the folder cannot be written."""
    tmp = path.with_name(f"{path.name}.tmp{os.getpid()}")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp.write_bytes(hashlib.sha256(data).digest() + data)
        os.replace(tmp, path)
    except OSError:
        remove(tmp)
        raise


def remove(path: Path) -> None:
    """Delete a file if it is there and ours to delete; never raises."""
    try:
        path.unlink(missing_ok=True)
    except OSError:  # not ours to remove, or the folder is not one: nothing to clean
        pass
