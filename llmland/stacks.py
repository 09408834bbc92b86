"""Which services fly a method, and one running stack of them on its own bus.

A *stack* is one drone's service processes (sim + planner, plus VLE + reasoner when specs come
from the real pipeline) connected to a hub session that this process opens on its own loopback
port. Experiments run several stacks side by side (``--jobs``), one port each.
"""

from __future__ import annotations

import logging
import os
import signal
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import psutil
from llmland_schemas import SEMANTIC_METHODS, EpisodeResult, MissionGoal, Topic, VehicleState, key
from llmland_schemas.bus import Bus

from .episodes import EpisodeRunner, new_episode_id
from .launch import Stack, free_port, hub_bus
from .oracle_specs import OracleSpecPublisher

log = logging.getLogger(__name__)

SpecSource = Literal["pipeline", "oracle", "none"]
#: methods whose planner uses semantic specs
#: the reasoner mode that serves each semantic method (DESIGN §5)
REASONER_MODE = {"llm": "llm", "llm-land": "rag"}
#: latency model for specs given from ground truth: a fast reasoner, reproducible
ORACLE_LATENCY_MODEL = "fixed:50"


@dataclass(frozen=True)
class StackConfig:
    """What a stack runs: the method, where its specs come from, and which LLM."""

    method: str
    specs: SpecSource = "pipeline"
    llm_model_path: str | None = None

    @property
    def perception(self) -> SpecSource:
        return self.specs if self.method in SEMANTIC_METHODS else "none"

    def services(self) -> list[str]:
        names = ["sim", "pilot" if self.method == "reference" else "planner"]
        if self.perception == "pipeline":
            names += ["vle", "reasoner"]
        return names

    def env(self) -> dict[str, str]:
        # a run flies the KB as shipped, not the entries someone added through the API on this machine
        env = {"LLMLAND_REASONER_HTTP_PORT": str(free_port()), "LLMLAND_REASONER_KB_ADDITIONS": "false"}
        if self.method in REASONER_MODE:
            env["LLMLAND_REASONER_MODE"] = REASONER_MODE[self.method]
        if self.llm_model_path:
            env["LLMLAND_REASONER_LLM_MODEL_PATH"] = self.llm_model_path
        return env

    def default_latency_model(self) -> str:
        return ORACLE_LATENCY_MODEL if self.perception == "oracle" else "measured"


def make_mission(cfg: StackConfig, *, world: str, seed: int, timeout_s: float, drone_id: str = "d0",
                 clock: str = "lockstep", n_pedestrians: int | None = None, latency_model: str | None = None,
                 rrd: str | None = None, scenario: str | None = None) -> MissionGoal:
    """The MissionGoal for one episode of ``cfg``'s method."""
    return MissionGoal(
        drone_id=drone_id,
        episode_id=new_episode_id(world, seed, cfg.method),
        world=world,  # type: ignore[arg-type]
        seed=seed,
        method=cfg.method,  # type: ignore[arg-type]
        clock=clock,  # type: ignore[arg-type]
        timeout_s=timeout_s,
        n_pedestrians=n_pedestrians,
        rrd_path=rrd,
        perception=cfg.perception,
        latency_model=latency_model or cfg.default_latency_model(),
        scenario=scenario,
    )


@dataclass
class RunningStack:
    """A started stack: its processes, the hub bus and an episode runner on it."""

    config: StackConfig
    stack: Stack
    bus: Bus
    runner: EpisodeRunner
    #: per killed service, the newest state stamp (sim s) seen once it was dead (:meth:`kill_at`)
    killed_at_s: dict[str, float] = field(default_factory=dict)
    #: services killed on purpose (fault runs), and those whose exit :meth:`watch` has reported
    faulted: set[str] = field(default_factory=set)
    _reported: set[str] = field(default_factory=set)

    def run(self, mission: MissionGoal, wall_timeout_s: float | None = None) -> EpisodeResult:
        """Fly ``mission`` on this stack (:meth:`EpisodeRunner.run`), watching its processes; a fault
        run's result names the services killed so far (``services_killed_at_s``)."""
        result = self.runner.run(mission, wall_timeout_s, watch=self.watch)
        if self.killed_at_s:
            killed = {name: round(t_s, 3) for name, t_s in self.killed_at_s.items()}  # sums of steps: to the ms
            result = result.model_copy(update={"services_killed_at_s": killed})
        return result

    def watch(self) -> None:
        """Raise RuntimeError once the simulator has exited (no result can come: the wait would last
        its whole wall limit); log, once each, any other service that exited unasked (the episode
        goes on without it, as the fault runs measure)."""
        for name, proc in self.stack.procs.items():
            code = proc.poll()
            if code is None or name in self._reported:
                continue
            if name == "sim":
                why = "was killed for a fault run" if name in self.faulted else f"exited with code {code}"
                raise RuntimeError(f"the sim {why}: the episode has no result (its log: --service-log-level INFO)")
            self._reported.add(name)
            if name not in self.faulted:
                log.error("service %s exited with code %s: the episode goes on without it", name, code)

    def peak_rss_mb(self, service: str) -> float | None:
        """Peak resident memory (MB) of a service process and its children (e.g. the LLM worker)."""
        proc = self.stack.procs.get(service)
        if proc is None or proc.poll() is not None:
            return None
        total = 0.0
        try:
            root = psutil.Process(proc.pid)
            for p in [root, *root.children(recursive=True)]:
                total += _peak_rss_kb(p.pid) / 1024.0
        except psutil.Error:
            return None
        return round(total, 1)

    def kill(self, service: str) -> None:
        """Kill one service (fault runs): SIGKILL to its process group."""
        proc = self.stack.procs[service]
        self.faulted.add(service)
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait(timeout=10)
        log.warning("killed %s (pid %d) for a fault run", service, proc.pid)

    def kill_at(self, service: str, sim_time_s: float) -> None:
        """Fault run: kill ``service`` once the next episode reaches ``sim_time_s``.

        Once it is dead, ``killed_at_s[service]`` holds the newest state stamp (sim s) seen here:
        under load the kill lands later than asked, and fault checks measure from when it did.
        """
        if service not in self.stack.procs:
            raise ValueError(f"no {service} in this stack ({', '.join(self.stack.procs)})")
        fired = threading.Event()
        newest = [0.0]

        def kill_now() -> None:
            self.kill(service)
            self.killed_at_s[service] = newest[0]

        def on_state(_k: str, st: VehicleState) -> None:
            newest[0] = max(newest[0], st.stamp)
            if st.stamp >= sim_time_s and not fired.is_set():
                fired.set()
                threading.Thread(target=kill_now, daemon=True).start()

        self.bus.subscribe(key(self.runner.drone_id, Topic.STATE), VehicleState, on_state)


def _peak_rss_kb(pid: int) -> float:
    """``VmHWM`` (peak resident set) of a process, from /proc (kB)."""
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return float(line.split()[1])
    return 0.0


@contextmanager
def open_stack(cfg: StackConfig, *, drone_id: str = "d0", port: int = 0, log_level: str = "WARNING",
               log_dir: Path | None = None, start_timeout_s: float = 120.0,
               env: dict[str, str] | None = None,
               on_start: Callable[[Stack], None] | None = None) -> Iterator[RunningStack]:
    """Start ``cfg``'s services on a fresh loopback hub; stop them all on exit.

    ``env``: extra environment for the services (settings such as ``LLMLAND_SIM_...``).
    ``on_start(stack)``: called once the processes exist, before they are up, so that another
    thread can stop a stack that is still starting (``stack.stop()`` is thread-safe; the wait for
    the services then fails with RuntimeError).
    """
    port = port or free_port()
    with hub_bus(port) as bus, Stack(port, drone_id, env={**cfg.env(), **(env or {})}, log_level=log_level,
                                     log_dir=log_dir) as stack:
        stack.start(cfg.services())
        if on_start is not None:
            on_start(stack)
        if cfg.perception == "oracle":
            OracleSpecPublisher(bus, drone_id)
        stack.wait_alive(bus, timeout_s=start_timeout_s)
        yield RunningStack(cfg, stack, bus, EpisodeRunner(bus, drone_id))
