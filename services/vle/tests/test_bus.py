"""Real Zenoh sessions on loopback: the caption queryable, the scene topic, the liveliness token."""

from __future__ import annotations

import socket
import threading
import time
from collections.abc import Iterator

import numpy as np
import pytest
from llmland_schemas import VLE_CAPTION_QUERY, Caption, SceneDescription, Topic, alive, decode, decode_frame, key
from llmland_schemas.bus import Bus, ZenohSettings
from llmland_vle.crops import encode_png
from llmland_vle.service import VleService
from llmland_vle.settings import VleSettings

DRONE = "dvle"


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@pytest.fixture(scope="module")
def buses() -> Iterator[tuple[Bus, Bus, VleService]]:
    endpoint = f"tcp/127.0.0.1:{_free_port()}"
    server = Bus(ZenohSettings(listen=[endpoint], connect=[]))
    client = Bus(ZenohSettings(connect=[endpoint]))
    service = VleService(VleSettings(drone_id=DRONE), server)
    try:
        yield server, client, service
    finally:
        service.close()
        client.close()
        server.close()


def _query(client: Bus, payload: bytes, params: str = "") -> tuple[str, bytes]:
    selector = VLE_CAPTION_QUERY + (f"?{params}" if params else "")
    for _ in range(20):  # the peers may still be connecting
        for reply in client.session.get(selector, payload=payload, timeout=10.0):
            if reply.ok is not None:
                return "ok", reply.ok.payload.to_bytes()
            return "err", reply.err.payload.to_bytes()
        time.sleep(0.25)
    raise AssertionError("no reply from the queryable")


def test_queryable_captions_a_png_and_refuses_garbage(buses: tuple[Bus, Bus, VleService], frames: list[bytes]) -> None:
    _, client, service = buses
    rgb = np.ascontiguousarray(decode_frame(frames[0]).rgb)
    status, body = _query(client, encode_png(rgb))
    assert status == "ok", body
    cap = decode(Caption, body)
    assert cap.backend == "simcap" and cap.text.startswith("an aerial view")
    status, body = _query(client, encode_png(rgb[100:196, 100:196]), "kind=object")
    assert status == "ok" and decode(Caption, body).text
    status, body = _query(client, b"this is not an image")
    assert status == "err" and b"PNG/JPEG" in body
    status, body = _query(client, encode_png(rgb), "kind=poem")
    assert status == "err" and b"kind" in body
    assert service.queries_ok == 2 and service.queries_failed == 2


def test_frames_in_scenes_out_and_alive(buses: tuple[Bus, Bus, VleService], frames: list[bytes]) -> None:
    _, client, service = buses
    got: list[SceneDescription] = []
    arrived = threading.Event()

    def on_scene(_k: str, msg: SceneDescription) -> None:
        got.append(msg)
        arrived.set()

    client.subscribe(key(DRONE, Topic.SCENE), SceneDescription, on_scene)
    deadline = time.monotonic() + 15.0
    while not arrived.is_set() and time.monotonic() < deadline:
        client.publish_bytes(key(DRONE, Topic.CAMERA), b"garbage frame")
        client.publish_bytes(key(DRONE, Topic.CAMERA), frames[1])
        arrived.wait(1.0)
    assert got, "no scene description arrived"
    scene = got[0]
    header = decode_frame(frames[1]).header
    assert scene.drone_id == DRONE and scene.frame_seq == header.seq and scene.stamp == header.stamp
    assert scene.caption.backend == "simcap" and scene.objects and scene.latency_ms > 0.0
    assert all(o.caption.text for o in scene.objects)
    assert service.processor.dropped["malformed"] >= 1
    assert client.alive(alive(DRONE, "vle"), timeout_s=2.0) == {alive(DRONE, "vle")}


def test_oracle_backend_listens_to_truth(frames: list[bytes]) -> None:
    from llmland_schemas import GroundTruth, TruthObject
    from llmland_schemas.depth import blobs_from_frame

    frame = decode_frame(frames[1])
    blob = blobs_from_frame(frame, stride=2, max_range_m=30.0)[0]
    x, y = float(blob.centroid_m[0]), float(blob.centroid_m[1])
    truth = GroundTruth(drone_id="dor", stamp=frame.header.stamp, world="open_field", target_m=(0.0, 0.0, 0.0),
                        objects=[TruthObject(obj_id="person_0", cls="person", position_m=(x, y, 0.85),
                                             velocity_mps=(0.0, 0.8, 0.0), size_m=(0.3, 0.62, 1.7), dynamic=True)])
    endpoint = f"tcp/127.0.0.1:{_free_port()}"
    with Bus(ZenohSettings(listen=[endpoint], connect=[])) as server, Bus(ZenohSettings(connect=[endpoint])) as client:
        service = VleService(VleSettings(drone_id="dor", backend="oracle"), server)
        got: list[SceneDescription] = []
        arrived = threading.Event()

        def on_scene(_k: str, msg: SceneDescription) -> None:
            if msg.objects and msg.objects[0].caption.text != "an unknown object":
                got.append(msg)
                arrived.set()

        client.subscribe(key("dor", Topic.SCENE), SceneDescription, on_scene)
        try:
            deadline = time.monotonic() + 15.0
            while not arrived.is_set() and time.monotonic() < deadline:
                client.publish(key("dor", Topic.TRUTH), truth)
                client.publish_bytes(key("dor", Topic.CAMERA), frames[1])
                arrived.wait(0.5)
        finally:
            service.close()
    assert got, "no oracle scene arrived"
    assert got[0].objects[0].caption.text == "a person walking"
    assert got[0].caption.backend == "oracle" and got[0].caption.text.startswith("an aerial view of a grass field")
