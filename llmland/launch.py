"""Start LLM-Land services as separate processes on one Zenoh bus, and stop them cleanly.

The CLI process opens the bus hub: a peer session listening on a loopback endpoint that
every child connects to (peer mode, multicast off — DESIGN §3). Every child listens on
``tcp/127.0.0.1:0`` only, so the peers gossip loopback locators and no socket of a stack leaves
the machine (docs/network.md); outside tools join the hub in client mode. Children run as their
own process groups and get SIGTERM, then SIGKILL after a grace period.

Services that serve every drone (the reasoner) announce themselves under the shared
``llmland/@ground/alive/<service>``; per-drone services under ``llmland/<d>/alive/<service>``.
"""

from __future__ import annotations

import logging
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from collections import Counter
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import zenoh
from llmland_schemas import Topic, alive, any_drone, drone_of
from llmland_schemas.bus import LOOPBACK_LISTEN, Bus, ZenohSettings
from llmland_schemas.keys import ALIVE_ANY_DRONE, ALIVE_GROUND, SHARED_SERVICES, ground_alive, validate_drone_id
from llmland_schemas.service import LAUNCHER_PID_ENV

log = logging.getLogger(__name__)

#: service name → python module run with ``python -m``
SERVICE_MODULES: dict[str, str] = {
    "sim": "llmland_sim.main",
    "pilot": "llmland_sim.refpilot",
    "planner": "llmland_planner.main",
    "vle": "llmland_vle.main",
    "reasoner": "llmland_reasoner.main",
}


#: per-drone services ``llmland up --drones N`` starts for each drone (plus the shared ones once)
DRONE_SERVICES = ("sim", "planner", "vle")
#: the hub and every child bind this address only
LOOPBACK_HOST = "127.0.0.1"


def free_port() -> int:
    """A currently free TCP port on 127.0.0.1."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind((LOOPBACK_HOST, 0))
        return int(s.getsockname()[1])


class StartupError(RuntimeError):
    """A stack could not start: a service exited or was not ready in time, or the hub's port is
    taken (a message for the user, not a traceback)."""


def hub_bus(port: int) -> Bus:
    """The CLI's own session: it listens (on loopback) and the children connect to it.
    :class:`StartupError` when it cannot listen there (the port is taken: another stack?)."""
    try:
        return Bus(ZenohSettings(mode="peer", listen=[hub_endpoint(port)], connect=[]))
    except zenoh.ZError as exc:
        raise StartupError(f"cannot listen on {hub_endpoint(port)} ({exc}): another stack on this port? "
                           "Give another one with --port") from None


def hub_endpoint(port: int) -> str:
    return f"tcp/{LOOPBACK_HOST}:{port}"


def alive_key(name: str, drone_id: str) -> str:
    """The liveliness key service ``name`` of drone ``drone_id`` declares."""
    return ground_alive(name) if name in SHARED_SERVICES else alive(drone_id, name)


#: the signals a user stops the CLI with (Ctrl-C, ``kill``)
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)


def raise_keyboard_interrupt(_signum: int, _frame: object) -> None:
    """Signal handler: SIGTERM unwinds like Ctrl-C, so every context manager stops what it started."""
    raise KeyboardInterrupt


@contextmanager
def stop_signals_deferred() -> Iterator[None]:
    """Hold Ctrl-C and SIGTERM while services are being stopped, and deliver them afterwards.

    A stop that a second signal interrupts leaves every service it had not yet reached running,
    orphaned (seen with ``timeout … llmland land`` and ``pkill -f``, which signal both ``timeout``,
    which forwards it, and the CLI). Signals reach only the main thread in CPython, so elsewhere
    this does nothing. Each held signal is raised once on exit, through the handler that was in
    place before (``KeyboardInterrupt`` for the CLI's).
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    held: list[int] = []

    def hold(signum: int, _frame: object) -> None:
        log.warning("signal %d while stopping services: delivered once they are stopped", signum)
        held.append(signum)

    previous = {s: signal.signal(s, hold) for s in STOP_SIGNALS}
    try:
        yield
    finally:
        for stop_signal, handler in previous.items():
            signal.signal(stop_signal, handler if handler is not None else signal.SIG_DFL)
        for signum in dict.fromkeys(held):
            signal.raise_signal(signum)


class Stack:
    """A set of service processes for one drone, all connected to ``tcp/127.0.0.1:<port>``."""

    def __init__(self, port: int, drone_id: str = "d0", env: dict[str, str] | None = None,
                 log_level: str = "WARNING", log_dir: Path | None = None) -> None:
        self.port = port
        self.log_dir = log_dir
        self.drone_id = validate_drone_id(drone_id)
        self.extra_env = env or {}
        self.log_level = log_level
        self.procs: dict[str, subprocess.Popen[bytes]] = {}
        self._stop_lock = threading.Lock()
        self._stopped = threading.Event()
        self._files: list[Any] = []

    def env_for(self, name: str) -> dict[str, str]:
        env = dict(os.environ)
        env.update({
            "ZENOH_MODE": "peer",
            "ZENOH_CONNECT": hub_endpoint(self.port),
            "ZENOH_LISTEN": LOOPBACK_LISTEN,
            "LLMLAND_LOG_LEVEL": self.log_level,
            LAUNCHER_PID_ENV: str(os.getpid()),  # the service stops if this process dies
        })
        prefix = {"pilot": "REFPILOT"}.get(name, name.upper())
        env[f"LLMLAND_{prefix}_DRONE_ID"] = self.drone_id
        env.update(self.extra_env)
        return env

    def start(self, names: Iterable[str]) -> None:
        self._stopped.clear()
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

    def wait_alive(self, bus: Bus, timeout_s: float = 60.0, interrupted: threading.Event | None = None) -> None:
        """Block until every started service has declared its liveliness token (``interrupted``:
        see :meth:`Fleet.wait_alive`)."""
        want = {alive_key(n, self.drone_id) for n in self.procs}
        shared = any(n in SHARED_SERVICES for n in self.procs)
        deadline = time.monotonic() + timeout_s
        while True:
            if interrupted is not None and interrupted.is_set():
                raise KeyboardInterrupt  # Ctrl-C or SIGTERM: the services stop on the way out, exit 130
            if self._stopped.is_set():
                raise StartupError("stack stopped during start-up")
            found = bus.alive(ALIVE_ANY_DRONE, timeout_s=0.5)
            if shared:
                found |= bus.alive(ALIVE_GROUND, timeout_s=0.5)
            if want <= found:
                return
            for name, proc in self.procs.items():
                if proc.poll() is not None:
                    raise StartupError(f"service {name} exited with code {proc.returncode} during start-up "
                                       "(its log says why)")
            if time.monotonic() > deadline:
                raise StartupError(f"services not ready after {timeout_s:.0f} s: {sorted(want - found)}")
            time.sleep(0.1)

    def stop(self, grace_s: float = 5.0) -> None:
        """SIGTERM every service's process group, SIGKILL after ``grace_s``. Safe to call from
        several threads at once (an interrupted experiment stops stacks its jobs are closing).
        Ctrl-C and SIGTERM wait until every service is stopped (:func:`stop_signals_deferred`)."""
        with stop_signals_deferred():
            self._stop(grace_s)

    def _stop(self, grace_s: float) -> None:
        with self._stop_lock:
            self._stopped.set()
            procs, files = dict(self.procs), list(self._files)
            self.procs.clear()
            self._files.clear()
        for proc in procs.values():
            if proc.poll() is None:
                os.killpg(proc.pid, signal.SIGTERM)
        deadline = time.monotonic() + grace_s
        for name, proc in procs.items():
            try:
                proc.wait(max(0.1, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                log.warning("%s did not stop within %.0f s: killing", name, grace_s)
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait()
        for f in files:
            f.close()

    def __enter__(self) -> Stack:
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()


def drone_ids(n: int) -> list[str]:
    """The ids ``llmland up --drones N`` gives its drones: d0 … d{N-1}."""
    if n < 1:
        raise ValueError(f"--drones must be at least 1, got {n}")
    return [f"d{i}" for i in range(n)]


class Fleet:
    """Several drones' stacks and the shared services (started once) on one hub port.

    ``log_dir``: the shared services log to ``log_dir/<service>.log``, each drone's to
    ``log_dir/<drone>/<service>.log``.
    """

    def __init__(self, port: int, drones: list[str], env: dict[str, str] | None = None,
                 log_level: str = "WARNING", log_dir: Path | None = None) -> None:
        if not drones or len(set(drones)) != len(drones):
            raise ValueError(f"a fleet needs distinct drone ids, got {drones}")
        self.shared = Stack(port, drones[0], env=env, log_level=log_level, log_dir=log_dir)
        self.drones = {d: Stack(port, d, env=env, log_level=log_level, log_dir=log_dir / d if log_dir else None)
                       for d in drones}

    @property
    def stacks(self) -> list[Stack]:
        return [self.shared, *self.drones.values()]

    def start(self, services: Iterable[str]) -> None:
        names = list(services)
        self.shared.start([n for n in names if n in SHARED_SERVICES])
        for st in self.drones.values():
            st.start([n for n in names if n not in SHARED_SERVICES])

    def procs(self) -> dict[str, subprocess.Popen[bytes]]:
        """Every process, named ``<service>`` (shared) or ``<drone>/<service>``."""
        out = dict(self.shared.procs)
        for d, st in self.drones.items():
            out.update({f"{d}/{n}": p for n, p in st.procs.items()})
        return out

    def wait_alive(self, bus: Bus, timeout_s: float = 60.0, interrupted: threading.Event | None = None) -> None:
        """Every stack's :meth:`Stack.wait_alive`; ``interrupted`` set (Ctrl-C, SIGTERM to ``up``)
        ends the wait at once with ``KeyboardInterrupt`` (it waited until every service was up)."""
        deadline = time.monotonic() + timeout_s
        for st in self.stacks:
            if st.procs:
                st.wait_alive(bus, timeout_s=max(1.0, deadline - time.monotonic()), interrupted=interrupted)

    def stop(self, grace_s: float = 5.0) -> None:
        with stop_signals_deferred():
            for proc in self.procs().values():  # every process at once, then wait for each
                if proc.poll() is None:
                    os.killpg(proc.pid, signal.SIGTERM)
            for st in reversed(self.stacks):
                st.stop(grace_s)

    def __enter__(self) -> Fleet:
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()


class SpecsServed:
    """Counts the specs the shared reasoner publishes, per drone (``llmland up`` logs them)."""

    def __init__(self, bus: Bus) -> None:
        self._counts: Counter[str] = Counter()
        self._lock = threading.Lock()
        bus.subscribe_parsed(any_drone(Topic.SPEC), len, self._on_spec)

    def _on_spec(self, k: str, _size: int) -> None:
        with self._lock:
            self._counts[drone_of(k)] += 1

    def counts(self) -> dict[str, int]:
        with self._lock:
            return dict(sorted(self._counts.items()))
