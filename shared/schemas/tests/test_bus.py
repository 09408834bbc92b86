"""Real Zenoh sessions on loopback (two sessions in one process: unit level)."""

import threading

import pytest
import zenoh
from llmland_schemas import Topic, VehicleState, key
from llmland_schemas.bus import Bus, ZenohSettings, make_config


def _free_port():
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_settings_from_environment(monkeypatch):
    monkeypatch.setenv("ZENOH_MODE", "client")
    monkeypatch.setenv("ZENOH_CONNECT", "tcp/10.0.0.1:7447, tcp/10.0.0.2:7447")
    monkeypatch.setenv("ZENOH_LISTEN", "")
    s = ZenohSettings()
    assert s.mode == "client"
    assert s.connect == ["tcp/10.0.0.1:7447", "tcp/10.0.0.2:7447"]
    assert s.listen == []
    conf = make_config(s)
    assert '"client"' in conf.get_json("mode")


def test_default_is_loopback_peer_without_multicast():
    s = ZenohSettings()
    assert s.mode == "peer" and s.connect == ["tcp/127.0.0.1:7447"] and not s.multicast_scouting
    conf = make_config(s)
    assert conf.get_json("scouting/multicast/enabled") == "false"


@pytest.fixture()
def pair():
    port = _free_port()
    a = Bus(ZenohSettings(listen=[f"tcp/127.0.0.1:{port}"], connect=[]))
    b = Bus(ZenohSettings(connect=[f"tcp/127.0.0.1:{port}"]))
    yield a, b
    b.close()
    a.close()


def test_garbage_is_counted_and_dropped_and_valid_messages_still_arrive(pair):
    a, b = pair
    got: list[VehicleState] = []
    ev = threading.Event()
    k = key("d0", Topic.STATE)

    def on_state(_k: str, m: VehicleState) -> None:
        got.append(m)
        ev.set()

    a.subscribe(k, VehicleState, on_state)
    import time

    time.sleep(0.3)
    b.publish_bytes(k, b"\x00\xffgarbage")
    b.publish_bytes(k, b'{"seq": -1}')
    b.publish(k, VehicleState(seq=9, position_m=(0, 0, 0), velocity_mps=(0, 0, 0), quat_xyzw=(0, 0, 0, 1),
                              euler_rpy_rad=(0, 0, 0), body_rates_rps=(0, 0, 0)))
    assert ev.wait(5)
    assert [m.seq for m in got] == [9]
    assert a.dropped[k] == 2 and a.received[k] == 3


def test_liveliness(pair):
    a, b = pair
    b.announce("llmland/d0/alive/test")
    import time

    deadline = time.monotonic() + 5
    while time.monotonic() < deadline:
        if a.alive("llmland/d0/alive/*", 0.5) == {"llmland/d0/alive/test"}:
            return
    pytest.fail("liveliness token not seen")


def test_a_slow_subscriber_gets_every_blocking_frame(pair):
    """Zenoh drops a put that finds its queue full (CongestionControl.DROP, its default): a lockstep
    frame lost that way left the sim waiting 15 s for a spec that never came, and the episode
    marked degraded. Lockstep frames and every JSON message block instead; live frames may drop."""
    import time

    a, b = pair
    got: list[int] = []

    def slow(_k: str, payload: bytes) -> None:
        time.sleep(0.03)  # a consumer slower than the producer (a loaded machine)
        got.append(len(payload))

    k = key("d0", Topic.CAMERA)
    a.subscribe_parsed(k, lambda x: x, slow)
    time.sleep(0.5)
    n = 60
    for _ in range(n):
        b.publish_bytes(k, bytes(1_200_000), block=True)  # with block=False about half are dropped
    deadline = time.monotonic() + 10.0
    while len(got) < n and time.monotonic() < deadline:
        time.sleep(0.1)
    time.sleep(0.3)
    assert len(got) == n
    assert b.publisher(k).congestion_control == zenoh.CongestionControl.BLOCK  # JSON publishers block
