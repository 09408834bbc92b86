"""Commands from the planner, matched to control ticks by the state ``seq`` they echo."""

from __future__ import annotations

import threading
import time

from llmland_schemas import ControlCommand


class CommandMailbox:
    """Commands from the planner, matched to ticks by ``state_seq``."""

    def __init__(self) -> None:
        self._cond = threading.Condition()
        self._by_seq: dict[int, ControlCommand] = {}
        self._latest: ControlCommand | None = None

    def put(self, cmd: ControlCommand) -> None:
        with self._cond:
            self._by_seq[cmd.state_seq] = cmd
            if self._latest is None or cmd.state_seq >= self._latest.state_seq:
                self._latest = cmd
            if len(self._by_seq) > 256:
                for s in sorted(self._by_seq)[:-128]:
                    del self._by_seq[s]
            self._cond.notify_all()

    def wait_for(self, seq: int, timeout_s: float) -> ControlCommand | None:
        """The command echoing ``seq``, waiting at most ``timeout_s`` (lockstep)."""
        deadline = time.monotonic() + timeout_s
        with self._cond:
            while seq not in self._by_seq:
                left = deadline - time.monotonic()
                if left <= 0:
                    return None
                self._cond.wait(left)
            return self._by_seq.pop(seq)

    def take_latest(self) -> ControlCommand | None:
        """The newest command not yet applied (realtime)."""
        with self._cond:
            cmd, self._latest = self._latest, None
            return cmd

    def clear(self) -> None:
        with self._cond:
            self._by_seq.clear()
            self._latest = None
