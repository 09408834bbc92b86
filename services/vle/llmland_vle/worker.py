"""Keep only the newest item: a worker thread handles the latest one; stale ones are dropped.

Camera frames arrive faster than a slow captioner can handle them. :meth:`submit` never
blocks: it replaces the pending item (counting the replaced one in ``dropped``) and wakes the
worker, which always takes the newest item when it becomes free.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from typing import Generic, TypeVar

log = logging.getLogger(__name__)
T = TypeVar("T")


class LatestFrameWorker(Generic[T]):
    """One worker thread running ``handle(item)`` on the newest submitted item."""

    def __init__(self, handle: Callable[[T], object], name: str = "vle-latest-frame") -> None:
        self._handle = handle
        self._cond = threading.Condition()
        self._pending: T | None = None
        self._busy = False
        self._stop = False
        self.offered = 0  # items submitted
        self.dropped = 0  # replaced before the worker took them
        self.processed = 0  # handled (including those whose handler raised)
        self.failed = 0  # handler raised
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._thread.start()

    def submit(self, item: T) -> None:
        """Offer an item; a pending older one is dropped and counted."""
        with self._cond:
            self.offered += 1
            if self._pending is not None:
                self.dropped += 1
            self._pending = item
            self._cond.notify_all()

    def _run(self) -> None:
        while True:
            with self._cond:
                while self._pending is None and not self._stop:
                    self._cond.wait()
                if self._stop:
                    return
                item, self._pending = self._pending, None
                self._busy = True
            try:
                self._handle(item)  # type: ignore[arg-type]
            except Exception:
                self.failed += 1
                log.exception("frame handler failed")
            finally:
                with self._cond:
                    self._busy = False
                    self.processed += 1
                    self._cond.notify_all()

    def wait_idle(self, timeout_s: float = 5.0) -> bool:
        """Block until nothing is pending or running; False on timeout."""
        deadline = time.monotonic() + timeout_s
        with self._cond:
            while self._pending is not None or self._busy:
                left = deadline - time.monotonic()
                if left <= 0:
                    return False
                self._cond.wait(left)
            return True

    def stats(self) -> dict[str, int]:
        with self._cond:
            return {"offered": self.offered, "dropped": self.dropped, "processed": self.processed,
                    "failed": self.failed}

    def close(self, timeout_s: float = 5.0) -> None:
        """Stop the thread (a pending item is discarded, a running one finishes)."""
        with self._cond:
            self._stop = True
            self._cond.notify_all()
        self._thread.join(timeout_s)
        if self._thread.is_alive():
            log.warning("worker thread did not stop within %.1f s", timeout_s)
