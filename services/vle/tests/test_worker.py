"""The latest-frame worker keeps only the newest item and counts the stale ones."""

from __future__ import annotations

import threading

from llmland_vle.worker import LatestFrameWorker


def test_stale_items_are_dropped_and_counted() -> None:
    gate = threading.Event()
    started = threading.Event()
    seen: list[int] = []

    def handle(item: int) -> None:
        seen.append(item)
        started.set()
        gate.wait(5.0)

    w: LatestFrameWorker[int] = LatestFrameWorker(handle)
    try:
        w.submit(1)
        assert started.wait(5.0)  # the worker is busy with item 1
        for k in (2, 3, 4):  # arrive while busy: 2 and 3 go stale
            w.submit(k)
        gate.set()
        assert w.wait_idle(5.0)
        assert seen == [1, 4]
        assert w.stats() == {"offered": 4, "dropped": 2, "processed": 2, "failed": 0}
    finally:
        gate.set()
        w.close()


def test_handler_errors_are_counted_and_the_worker_goes_on() -> None:
    seen: list[int] = []

    def handle(item: int) -> None:
        if item == 0:
            raise RuntimeError("boom")
        seen.append(item)

    w: LatestFrameWorker[int] = LatestFrameWorker(handle)
    try:
        w.submit(0)
        assert w.wait_idle(5.0)
        w.submit(5)
        assert w.wait_idle(5.0)
        assert seen == [5]
        assert w.failed == 1 and w.processed == 2
    finally:
        w.close()
