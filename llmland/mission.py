"""``llmland mission``: send one MissionGoal to a running stack and wait for its EpisodeResult.

Joins the bus in client mode (``--connect``, default the ``llmland up`` hub on
``tcp/127.0.0.1:7447``; ``ZENOH_TLS_*`` for a ``tls/`` router, docs/network.md), checks that the
drone's services are alive, then reuses :class:`~llmland.episodes.EpisodeRunner` (the mission is
re-sent until the sim starts it) and :func:`~llmland.stacks.make_mission`.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass

import zenoh
from llmland_schemas import EpisodeResult, MissionGoal
from llmland_schemas.bus import DEFAULT_ENDPOINT, Bus, ZenohSettings
from llmland_schemas.keys import ALIVE_ANY_DRONE, ALIVE_GROUND, validate_drone_id

from .episodes import EpisodeRunner
from .launch import alive_key
from .stacks import StackConfig, make_mission

log = logging.getLogger(__name__)

#: how long to wait for the drone's services to show up before giving up (s)
ALIVE_TIMEOUT_S = 10.0
#: while waiting for a result: how often (s, wall) to ask whether the drone's sim is still alive
SIM_CHECK_S = 2.0
#: how long (s) one such liveliness query may take
SIM_QUERY_S = 1.0
#: how many such queries in a row must find no sim before the mission is given up
SIM_MISSES = 2


class MissionError(RuntimeError):
    """The stack is not there or cannot fly this mission (a message for the user)."""

    #: the command's exit status: 2 before the mission flew (no stack, a wrong drone or method)
    exit_code = 2


class MissionLostError(MissionError):
    """The mission was sent but no result will come (the drone's sim is gone, the wall limit passed)."""

    exit_code = 1


@dataclass(frozen=True)
class MissionRequest:
    world: str
    seed: int
    method: str = "llm-land"
    drone_id: str = "d0"
    timeout_s: float = 90.0
    clock: str = "lockstep"
    n_pedestrians: int | None = None
    wall_timeout_s: float | None = None


def client_settings(connect: list[str]) -> ZenohSettings:
    """Client-mode settings for ``connect`` (empty: ``ZENOH_CONNECT``, else the ``llmland up`` hub; TLS files
    and the rest from ``ZENOH_*``)."""
    settings = ZenohSettings()
    return settings.model_copy(update={"mode": "client", "connect": connect or settings.connect or [DEFAULT_ENDPOINT],
                                       "listen": []})


def open_client(settings: ZenohSettings) -> Bus:
    try:
        return Bus(settings)
    except zenoh.ZError as exc:
        raise MissionError(f"cannot reach the bus at {', '.join(settings.connect)} ({exc}): is `llmland up` (or a "
                           "router) running there? A tls/ endpoint needs ZENOH_TLS_ROOT_CA, _CERTIFICATE and "
                           "_PRIVATE_KEY") from None


def wait_for_services(bus: Bus, cfg: StackConfig, drone_id: str, timeout_s: float = ALIVE_TIMEOUT_S) -> None:
    """Raise :class:`MissionError` unless every service ``cfg``'s method needs is alive."""
    want = {alive_key(n, drone_id) for n in cfg.services()}
    deadline = time.monotonic() + timeout_s
    found: set[str] = set()
    while time.monotonic() < deadline:
        found = bus.alive(ALIVE_ANY_DRONE, timeout_s=0.5) | bus.alive(ALIVE_GROUND, timeout_s=0.5)
        if want <= found:
            return
        time.sleep(0.2)
    drones = sorted({k.split("/")[1] for k in found if not k.split("/")[1].startswith("@")})
    raise MissionError(f"method {cfg.method} on drone {drone_id} needs {sorted(want - found)} alive; "
                       f"alive: {sorted(found) or 'nothing'} (drones seen: {', '.join(drones) or 'none'})")


def build_mission(req: MissionRequest) -> tuple[StackConfig, MissionGoal]:
    cfg = StackConfig(method=req.method, specs="pipeline")
    mission = make_mission(cfg, world=req.world, seed=req.seed, timeout_s=req.timeout_s,
                           drone_id=validate_drone_id(req.drone_id), clock=req.clock,
                           n_pedestrians=req.n_pedestrians)
    return cfg, mission


def send_mission(req: MissionRequest, connect: list[str]) -> EpisodeResult:
    """Fly ``req`` on the running stack at ``connect``; the EpisodeResult."""
    cfg, mission = build_mission(req)
    settings = client_settings(connect)
    with open_client(settings) as bus:
        wait_for_services(bus, cfg, req.drone_id)
        log.info("sending mission %s to drone %s via %s", mission.episode_id, req.drone_id,
                 ", ".join(settings.connect))
        runner = EpisodeRunner(bus, req.drone_id)
        try:
            return runner.run(mission, req.wall_timeout_s, watch=SimWatch(bus, runner, req.drone_id, mission))
        except TimeoutError as exc:
            raise MissionLostError(str(exc)) from None
        except KeyboardInterrupt:  # Ctrl-C: the episode is not left flying (or queued) for no one
            runner.stop(mission)
            log.warning("interrupted: asked drone %s to stop episode %s", req.drone_id, mission.episode_id)
            raise


class SimWatch:
    """Called while a mission waits (:meth:`EpisodeRunner.run`'s ``watch``): ends the wait with a
    :class:`MissionError` once the drone's sim is gone (its stack stopped or crashed: no result
    will come; the wait was up to 30 min), and says once when the drone is busy with another
    episode (the mission waits its turn)."""

    def __init__(self, bus: Bus, runner: EpisodeRunner, drone_id: str, mission: MissionGoal) -> None:
        self.bus, self.runner, self.drone_id, self.mission = bus, runner, drone_id, mission
        self._misses = 0
        self._checked_at = time.monotonic()
        self._told_busy = False

    def __call__(self) -> None:
        busy = self.runner.busy_with()
        if busy is not None and not self._told_busy:
            self._told_busy = True
            log.info("drone %s is flying episode %s: this mission waits until it ends", self.drone_id, busy)
        if time.monotonic() - self._checked_at < SIM_CHECK_S:
            return
        self._checked_at = time.monotonic()
        try:
            up = bool(self.bus.alive(alive_key("sim", self.drone_id), SIM_QUERY_S))
        except zenoh.ZError:  # the session to the hub is broken: no result can reach us either
            up = False
        self._misses = 0 if up else self._misses + 1
        if self._misses >= SIM_MISSES:  # one slow query is no death
            self.runner.stop(self.mission)  # in case it lives after all: not flown for no one
            raise MissionLostError(f"drone {self.drone_id}'s sim is gone (its stack stopped or crashed): no result "
                               "will come")
