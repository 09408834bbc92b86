"""Start LLM-Land services as separate processes on one Zenoh bus, and stop them cleanly.

The CLI process opens the bus hub: a peer session listening on a loopback endpoint that
every child connects to (peer mode, multicast off — DESIGN §3). Children run as their
own process groups and get SIGTERM, then SIGKILL after a grace period.
"""

from __future__ import annotations

import logging
import os
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from llmland_schemas import alive
from llmland_schemas.bus import Bus, ZenohSettings

log = logging.getLogger(__name__)

#: service name → python module run with ``python -m``
SERVICE_MODULES: dict[str, str] = {
    "sim": "llmland_sim.main",
    "pilot": "llmland_sim.refpilot",
    "planner": "llmland_planner.main",
    "vle": "llmland_vle.main",
    "reasoner": "llmland_reasoner.main",
}


#: services that serve every drone announce themselves under this id (the ground station)
SHARED_SERVICES = {"reasoner"}
SHARED_DRONE = "ground"


def free_port() -> int:
    """A currently free TCP port on 127.0.0.1."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def hub_bus(port: int) -> Bus:
    """The CLI's own session: it listens and the children connect to it."""
    return Bus(ZenohSettings(mode="peer", listen=[f"tcp/127.0.0.1:{port}"], connect=[]))


class Stack:
    """A set of service processes for one drone, all connected to ``tcp/127.0.0.1:<port>``."""

    def __init__(self, port: int, drone_id: str = "d0", env: dict[str, str] | None = None,
                 log_level: str = "WARNING", log_dir: Path | None = None) -> None:
        self.port = port
        self.log_dir = log_dir
        self.drone_id = drone_id
        self.extra_env = env or {}
        self.log_level = log_level
        self.procs: dict[str, subprocess.Popen[bytes]] = {}
        self._files: list[Any] = []

    def env_for(self, name: str) -> dict[str, str]:
        env = dict(os.environ)
        env.update({
            "ZENOH_MODE": "peer",
            "ZENOH_CONNECT": f"tcp/127.0.0.1:{self.port}",
            "ZENOH_LISTEN": "",
            "LLMLAND_LOG_LEVEL": self.log_level,
        })
        prefix = {"pilot": "REFPILOT"}.get(name, name.upper())
        env[f"LLMLAND_{prefix}_DRONE_ID"] = self.drone_id
        env.update(self.extra_env)
        return env

    def start(self, names: Iterable[str]) -> None:
        for name in names:
            cmd = [sys.executable, "-m", SERVICE_MODULES[name]]
            # Children log to stderr (or a file each); stdout stays clean for the CLI's JSON.
            out: Any = sys.stderr.fileno()
            if self.log_dir is not None:
                self.log_dir.mkdir(parents=True, exist_ok=True)
                out = open(self.log_dir / f"{name}.log", "ab")  # noqa: SIM115 - closed in stop()
                self._files.append(out)
            self.procs[name] = subprocess.Popen(
                cmd, env=self.env_for(name), stdout=out, stderr=out if self.log_dir else None,
                start_new_session=True,
            )
            log.info("started %s (pid %d)", name, self.procs[name].pid)

    def wait_alive(self, bus: Bus, timeout_s: float = 60.0) -> None:
        """Block until every started service has declared its liveliness token."""
        want = {alive(SHARED_DRONE if n in SHARED_SERVICES else self.drone_id, n) for n in self.procs}
        deadline = time.monotonic() + timeout_s
        while True:
            found = bus.alive("llmland/*/alive/*", timeout_s=0.5)
            if want <= found:
                return
            for name, proc in self.procs.items():
                if proc.poll() is not None:
                    raise RuntimeError(f"service {name} exited with code {proc.returncode} during start-up")
            if time.monotonic() > deadline:
                raise TimeoutError(f"services not ready after {timeout_s} s: {sorted(want - found)}")
            time.sleep(0.1)

    def stop(self, grace_s: float = 5.0) -> None:
        for proc in self.procs.values():
            if proc.poll() is None:
                os.killpg(proc.pid, signal.SIGTERM)
        deadline = time.monotonic() + grace_s
        for name, proc in self.procs.items():
            try:
                proc.wait(max(0.1, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                log.warning("%s did not stop within %.0f s: killing", name, grace_s)
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait()
        self.procs.clear()
        for f in self._files:
            f.close()
        self._files.clear()

    def __enter__(self) -> Stack:
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()
