"""`llmland-router`: clients on different sessions meet only through the Python router."""

from __future__ import annotations

import subprocess
import sys
import threading
import time

import pytest
from llmland_schemas import Topic, VehicleState, key
from llmland_schemas.bus import Bus, ZenohSettings

from llmland.launch import free_port

pytestmark = pytest.mark.integration


def test_two_clients_talk_through_the_router() -> None:
    port = free_port()
    router = subprocess.Popen([sys.executable, "-m", "llmland_schemas.router", "--listen", f"tcp/127.0.0.1:{port}"])
    try:
        client = ZenohSettings(mode="client", connect=[f"tcp/127.0.0.1:{port}"])
        deadline = time.monotonic() + 20
        a = b = None
        while a is None:
            try:
                a = Bus(client)
            except Exception:  # router not listening yet
                if time.monotonic() > deadline:
                    raise
                time.sleep(0.2)
        b = Bus(client)
        got = threading.Event()
        k = key("d1", Topic.STATE)
        a.subscribe(k, VehicleState, lambda _k, m: got.set())
        msg = VehicleState(drone_id="d1", position_m=(0, 0, 1), velocity_mps=(0, 0, 0), quat_xyzw=(0, 0, 0, 1),
                           euler_rpy_rad=(0, 0, 0), body_rates_rps=(0, 0, 0))
        for _ in range(50):
            b.publish(k, msg)
            if got.wait(0.2):
                break
        assert got.is_set()
        b.close()
        a.close()
    finally:
        router.terminate()
        assert router.wait(10) == 0
