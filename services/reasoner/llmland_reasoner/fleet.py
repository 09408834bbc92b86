"""A fair, newest-wins queue of scenes from many drones (one reasoner, a fleet of drones).

Each drone has one slot holding its newest pending scene: a newer scene replaces the older
one, which is counted as superseded (a spec for a frame the drone has already left behind is
worth less than one for the frame it sees now). Drones are served in the order they started
waiting, and a replaced scene keeps its drone's place in line, so a drone publishing fast
cannot push a slow one back: after a drone is served it waits behind every drone that was
already waiting (round robin). :meth:`FairSceneQueue.take` hands out several drones' scenes
at once (a batch), front of the line first, within a cost budget (the cold captions the
batch would have to compute).
"""

from __future__ import annotations

import threading
import time
from collections import Counter, OrderedDict
from collections.abc import Callable
from dataclasses import dataclass
from typing import Generic, TypeVar

T = TypeVar("T")


@dataclass(frozen=True)
class Pending(Generic[T]):
    """A drone's newest scene and when it arrived (``time.perf_counter()`` seconds)."""

    drone: str
    item: T
    received_s: float


class FairSceneQueue(Generic[T]):
    """One slot per drone (newest wins), drones served round robin; thread-safe."""

    def __init__(self) -> None:
        self._cond = threading.Condition()
        self._slots: OrderedDict[str, Pending[T]] = OrderedDict()
        self.offered: Counter[str] = Counter()
        self.superseded: Counter[str] = Counter()
        self.taken: Counter[str] = Counter()
        self._closed = False

    def put(self, drone: str, item: T, received_s: float | None = None) -> bool:
        """Queue ``item`` as ``drone``'s newest scene; True when it superseded a pending one."""
        now = time.perf_counter() if received_s is None else received_s
        with self._cond:
            self.offered[drone] += 1
            replaced = drone in self._slots
            if replaced:
                self.superseded[drone] += 1
            self._slots[drone] = Pending(drone, item, now)  # an existing key keeps its place in line
            self._cond.notify()
            return replaced

    def drop(self, drone: str) -> bool:
        """Forget ``drone``'s pending scene (a newer one was served another way); counted as
        superseded. True when there was one."""
        with self._cond:
            if self._slots.pop(drone, None) is None:
                return False
            self.superseded[drone] += 1
            return True

    def take(self, max_items: int, timeout_s: float, cost: Callable[[T], int] | None = None,
             budget: int = 0) -> list[Pending[T]]:
        """Up to ``max_items`` drones' scenes from the front of the line (at least one when any
        is pending within ``timeout_s``); with ``cost``, stop before the summed cost would pass
        ``budget`` (the first item is always taken). Empty on timeout or after :meth:`close`."""
        deadline = time.monotonic() + timeout_s
        with self._cond:
            while not self._slots and not self._closed:
                left = deadline - time.monotonic()
                if left <= 0:
                    return []
                self._cond.wait(left)
            out: list[Pending[T]] = []
            spent = 0
            while self._slots and len(out) < max_items and not self._closed:
                drone, pending = next(iter(self._slots.items()))
                c = cost(pending.item) if cost is not None else 0
                if out and cost is not None and spent + c > budget:
                    break
                spent += c
                del self._slots[drone]
                self.taken[drone] += 1
                out.append(pending)
            return out

    def take_ready(self, ready: Callable[[T], bool]) -> list[Pending[T]]:
        """Every pending scene for which ``ready`` holds (no model work left: its captions were
        computed while it waited), front of the line first; does not wait."""
        with self._cond:
            out = [p for p in self._slots.values() if ready(p.item)]
            for p in out:
                del self._slots[p.drone]
                self.taken[p.drone] += 1
            return out

    def pending(self) -> list[str]:
        """The drones waiting, front of the line first."""
        with self._cond:
            return list(self._slots)

    def close(self) -> None:
        with self._cond:
            self._closed = True
            self._cond.notify_all()
