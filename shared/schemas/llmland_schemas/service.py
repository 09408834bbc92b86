"""Small pieces every service's ``main`` uses: logging set-up and clean shutdown."""

from __future__ import annotations

import logging
import os
import signal
import threading


def configure_logging(level: str | None = None) -> None:
    """Log to stderr with timestamps; level from ``LLMLAND_LOG_LEVEL`` (default INFO)."""
    logging.basicConfig(
        level=(level or os.environ.get("LLMLAND_LOG_LEVEL", "INFO")).upper(),
        format="%(asctime)s %(levelname).1s %(name)s: %(message)s",
    )


def shutdown_event() -> threading.Event:
    """An event set on SIGTERM or SIGINT, so the main loop can close the bus and exit."""
    stop = threading.Event()

    def _handler(signum: int, _frame: object) -> None:
        logging.getLogger(__name__).info("signal %d: shutting down", signum)
        stop.set()

    signal.signal(signal.SIGTERM, _handler)
    signal.signal(signal.SIGINT, _handler)
    return stop
