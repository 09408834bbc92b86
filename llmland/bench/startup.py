"""Start-up of the four services of one drone: wall time from launch to each liveliness token.

A service declares its token when it can serve: the sim and planner once their bus wiring is up,
the VLE once its captioner is loaded, the reasoner once its models are loaded and its prompt
prefix evaluated (``llmland_reasoner.main``). ``startup_all_s`` is when the last one came up:
what ``llmland land`` waits before it sends the mission. Each run starts a fresh stack on a
fresh bus port (the OS file cache stays warm: after the first run nothing is read from disk).
"""

from __future__ import annotations

import threading
import time
from typing import Any

import zenoh
from llmland_schemas.keys import ALIVE_ANY_DRONE, ALIVE_GROUND

from . import percentiles

#: the services of ``llmland land`` (DESIGN §2), in launch order
SERVICES = ("sim", "planner", "vle", "reasoner")
#: longest wall time (s) a stack may take to come up before the run fails
START_TIMEOUT_S = 240.0
#: how long (s) the token subscriber may lag the liveliness query that saw every service up
TOKEN_EVENT_WAIT_S = 5.0


def _one_start(drone_id: str = "d0") -> dict[str, float]:
    """Launch the four services once; seconds from launch to each token (and to the last)."""
    from ..launch import Stack, alive_key, free_port, hub_bus

    want = {alive_key(n, drone_id): n for n in SERVICES}
    seen: dict[str, float] = {}
    done = threading.Event()
    port = free_port()
    env = {"LLMLAND_REASONER_HTTP_PORT": str(free_port())}
    with hub_bus(port) as bus, Stack(port, drone_id, env=env) as stack:
        t0 = time.perf_counter()

        def on_token(sample: zenoh.Sample) -> None:
            name = want.get(str(sample.key_expr))
            if name is not None and sample.kind == zenoh.SampleKind.PUT and name not in seen:
                seen[name] = time.perf_counter() - t0
                if len(seen) == len(want):
                    done.set()

        subs = [bus.session.liveliness().declare_subscriber(sel, on_token) for sel in (ALIVE_ANY_DRONE, ALIVE_GROUND)]
        try:
            stack.start(SERVICES)
            stack.wait_alive(bus, timeout_s=START_TIMEOUT_S)  # fails on a service that exits meanwhile
            if not done.wait(TOKEN_EVENT_WAIT_S):  # the subscriber's own record of the last token
                raise TimeoutError(f"no liveliness event from {sorted(set(SERVICES) - set(seen))}")
        finally:
            for sub in subs:
                sub.undeclare()
    return {**seen, "all": max(seen.values())}


def run_startup(runs: int = 3) -> dict[str, Any]:
    """``startup_<service>_s_p50/_p95`` and ``startup_all_s_p50/_p95`` over ``runs`` launches."""
    samples: dict[str, list[float]] = {}
    for _ in range(runs):
        for name, seconds in _one_start().items():
            samples.setdefault(name, []).append(seconds)
    figures: dict[str, Any] = {"startup_runs": runs}
    for name, values in samples.items():
        figures.update(percentiles(values, f"startup_{name}_s", digits=2))
    return figures
