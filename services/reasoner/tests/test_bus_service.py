"""Reasoner bus service over real Zenoh sessions (a fake engine: this tests the bus logic)."""

from __future__ import annotations

import socket
import threading
import time

from llmland_reasoner.bus_service import ReasonerBusService
from llmland_schemas import (
    REASONER_SPEC_QUERY,
    Caption,
    SafetySpec,
    SafetySpecMessage,
    SceneDescription,
    SceneObject,
    Topic,
    any_drone,
    decode,
    key,
)
from llmland_schemas.bus import Bus, ZenohSettings


class SlowEngine:
    def __init__(self) -> None:
        self.seen: list[str] = []

    def extract(self, caption: str, mode: str | None = None) -> SafetySpec:
        self.seen.append(caption)
        time.sleep(0.02)
        return SafetySpec(is_dynamic="walk" in caption, z_min=3.0, buffer_m=3.0, label="x", caption=caption,
                          source="rag")


def _port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _scene(drone: str, seq: int) -> SceneDescription:
    return SceneDescription(drone_id=drone, stamp=seq * 0.2, seq=seq, latency_ms=40.0, episode_id="e",
                            caption=Caption(text=f"{drone} frame {seq}", backend="t"),
                            objects=[SceneObject(obj_id="b0", caption=Caption(text="a man walking", backend="t"),
                                                 centroid_m=(1.0, 2.0, 0.8), size_m=(0.5, 0.5, 1.7))])


def test_specs_for_every_drone_newest_scene_wins_and_query() -> None:
    port = _port()
    with Bus(ZenohSettings(listen=[f"tcp/127.0.0.1:{port}"], connect=[])) as server, \
         Bus(ZenohSettings(connect=[f"tcp/127.0.0.1:{port}"])) as client:
        engine = SlowEngine()
        service = ReasonerBusService(engine, server)  # type: ignore[arg-type]
        got: dict[str, list[SafetySpecMessage]] = {}
        lock = threading.Lock()

        def on_spec(k: str, m: SafetySpecMessage) -> None:
            with lock:
                got.setdefault(m.drone_id, []).append(m)

        client.subscribe(any_drone(Topic.SPEC), SafetySpecMessage, on_spec)
        time.sleep(0.5)
        for seq in range(5):  # a burst: older scenes of a drone are superseded
            for d in ("d0", "d1", "d2"):
                client.publish(key(d, Topic.SCENE), _scene(d, seq))
        client.publish_bytes(key("d0", Topic.SCENE), b"garbage")
        client.publish(key("d0", Topic.SCENE).replace("/d0/", "/bad!id/"), _scene("d0", 5))  # no drone's key
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline:
            with lock:
                if all(any(m.seq == 4 for m in got.get(d, [])) for d in ("d0", "d1", "d2")):
                    break
            time.sleep(0.05)
        with lock:
            assert set(got) == {"d0", "d1", "d2"}
            for msgs in got.values():
                assert msgs[-1].seq == 4 and msgs[-1].stamp == 0.8
                last = msgs[-1]
                assert last.latency_ms >= 40.0 and last.objects[0].spec.is_dynamic
                assert last.objects[0].centroid_m == (1.0, 2.0, 0.8)
        assert service.stats["scenes_superseded"] > 0  # newest scene per drone wins
        assert server.dropped[key("d0", Topic.SCENE)] == 1

        replies = list(client.session.get(REASONER_SPEC_QUERY, payload=b"a man walking a dog", timeout=5))
        assert replies and replies[0].ok is not None
        assert decode(SafetySpec, replies[0].ok.payload.to_bytes()).is_dynamic
        assert service.stats["scenes_bad_key"] == 1  # counted and dropped, not a handler traceback
        for bad in (b"", b'{"caption": null}', b'{"caption": {"a": 1}}'):  # null was reasoned as "None"
            replies = list(client.session.get(REASONER_SPEC_QUERY, payload=bad, timeout=5))
            assert replies and replies[0].err is not None, bad
        service.close()
