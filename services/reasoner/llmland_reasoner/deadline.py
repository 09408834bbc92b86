"""A cooperative deadline for one extraction, checked between the expensive steps.

:class:`~.extractor.SpecExtractor` answers a caller within ``timeout_s`` by waiting on its one
worker thread with a time limit, but Python cannot stop that thread: the work went on after the
caller had its fallback, and every other caption (every drone's) waited behind it. A long,
ambiguous caption (hundreds of mentions, each scored by the LLM) held the worker for minutes.
The worker now runs each job under :func:`deadline_at`; the loops whose length grows with the
caption call :func:`check`, which raises :class:`DeadlineExceededError` once the caller has stopped
waiting, so the worker is free again within one step (one LLM call, ≈ 0.1 s here).
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar

_DEADLINE: ContextVar[float | None] = ContextVar("llmland_reasoner_deadline", default=None)


class DeadlineExceededError(TimeoutError):
    """The caller of this extraction has stopped waiting (its ``timeout_s`` has passed)."""


@contextmanager
def deadline_at(monotonic_s: float | None) -> Iterator[None]:
    """Run the block under a deadline (``time.monotonic()`` seconds; None: none)."""
    token = _DEADLINE.set(monotonic_s)
    try:
        yield
    finally:
        _DEADLINE.reset(token)


def check() -> None:
    """Raise :class:`DeadlineExceededError` when the current deadline has passed; no-op without one."""
    at = _DEADLINE.get()
    if at is not None and time.monotonic() > at:
        raise DeadlineExceededError("the caller's time limit passed; work abandoned")
