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


class MissionError(RuntimeError):
    """The stack is not there or cannot fly this mission (a message for the user)."""


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
        try:
            return EpisodeRunner(bus, req.drone_id).run(mission, req.wall_timeout_s)
        except TimeoutError as exc:
            raise MissionError(str(exc)) from None
