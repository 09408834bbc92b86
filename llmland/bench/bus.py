"""Zenoh round trip of a VehicleState between two processes (JSON encode + validate both ways).

The echo side runs as ``python -m llmland.bench.bus echo <port>``: it decodes each state on
``bench/<id>/ping`` and publishes it back on ``bench/<id>/pong``.
"""

from __future__ import annotations

import subprocess
import sys
import threading
import time

import zenoh
from llmland_schemas import VehicleState, decode, encode
from llmland_schemas.bus import Bus, ZenohSettings

from . import percentiles

PING, PONG = "llmland/bench/ping", "llmland/bench/pong"


def _state(seq: int) -> VehicleState:
    return VehicleState(seq=seq, stamp=seq * 0.02, position_m=(1.0, 2.0, 3.0), velocity_mps=(0.1, 0.2, 0.3),
                        quat_xyzw=(0.0, 0.0, 0.0, 1.0), euler_rpy_rad=(0.0, 0.0, 0.0),
                        body_rates_rps=(0.0, 0.0, 0.0), episode_id="bench")


def echo(port: int) -> None:
    stop = threading.Event()
    with Bus(ZenohSettings(connect=[f"tcp/127.0.0.1:{port}"])) as bus:
        pub = bus.publisher(PONG, express=True)

        def on_ping(_k: str, msg: VehicleState) -> None:
            if msg.seq == 0 and msg.episode_id == "stop":
                stop.set()
                return
            pub.put(encode(msg))

        bus.subscribe(PING, VehicleState, on_ping)
        bus.announce("llmland/bench/alive/echo")
        stop.wait(600)


def run_bus(n: int = 3000, warmup: int = 200) -> dict[str, float]:
    from ..launch import free_port, hub_bus

    port = free_port()
    with hub_bus(port) as bus:
        child = subprocess.Popen([sys.executable, "-m", "llmland.bench.bus", "echo", str(port)])
        try:
            deadline = time.monotonic() + 30
            while not bus.alive("llmland/bench/alive/*", 0.5):
                if time.monotonic() > deadline or child.poll() is not None:
                    raise RuntimeError("echo process did not come up")
            got = threading.Event()
            pub = bus.publisher(PING, express=True)

            def on_pong(sample: zenoh.Sample) -> None:
                decode(VehicleState, sample.payload.to_bytes())
                got.set()

            bus.session.declare_subscriber(PONG, on_pong)
            rtts: list[float] = []
            for i in range(1, warmup + n + 1):
                got.clear()
                t0 = time.perf_counter()
                pub.put(encode(_state(i)))
                if not got.wait(1.0):
                    continue
                if i > warmup:
                    rtts.append((time.perf_counter() - t0) * 1e6)
            pub.put(encode(_state(0).model_copy(update={"episode_id": "stop"})))
        finally:
            try:
                child.wait(5)
            except subprocess.TimeoutExpired:
                child.kill()
    return {**percentiles(rtts, "bus_state_rtt_us"), "bus_samples": len(rtts), "bus_lost": n - len(rtts)}


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "echo":
        echo(int(sys.argv[2]))
