"""Frame checks: bad frames are dropped and counted, good ones still captioned."""

from __future__ import annotations

import threading
from typing import Any

import numpy as np
from llmland_schemas import SceneDescription, decode_frame, encode_frame
from llmland_vle.pipeline import FrameProcessor
from llmland_vle.settings import VleSettings
from llmland_vle.worker import LatestFrameWorker


def _bad_frames(good: bytes) -> dict[str, bytes]:
    f = decode_frame(good)
    small = f.header.model_copy(update={"width": 16, "height": 16, "intrinsics": f.header.intrinsics.model_copy(
        update={"width": 16, "height": 16})})
    no_depth = f.header.model_copy(update={"depth_encoding": None})
    lying = f.header.model_copy(update={"width": 200})  # header size disagrees with the body
    body = good[-(384 * 384 * 7):]
    head = encode_frame(lying, np.zeros((384, 200, 3), np.uint8), np.zeros((384, 200), np.float32))
    return {
        "garbage": b"\x00\x01not a frame at all" * 10,
        "truncated": good[: len(good) - 1000],
        "wrong_size": head[: len(head) - 384 * 200 * 7] + body,
        "tiny": encode_frame(small, np.zeros((16, 16, 3), np.uint8), np.ones((16, 16), np.float32)),
        "no_depth": encode_frame(no_depth, f.rgb.copy(), None),
    }


def test_good_frame_gives_a_scene(frames: list[bytes], stub: Any) -> None:
    proc = FrameProcessor(stub, VleSettings(drone_id="d7", max_objects=4))
    header = decode_frame(frames[1]).header
    scene = proc.process(frames[1])
    assert isinstance(scene, SceneDescription)
    assert scene.drone_id == "d7" and scene.stamp == header.stamp and scene.frame_seq == header.seq
    assert scene.caption.text == "a frame of 384x384" and scene.latency_ms > 0.0
    assert 1 <= len(scene.objects) <= 4
    for obj in scene.objects:
        assert obj.caption.text == "a object of 96x96"
        assert obj.bbox_px is not None and obj.size_m[2] > 0.0
    assert stub.calls == [("frame", 1), ("object", len(scene.objects))]


def test_bad_frames_are_dropped_and_counted_then_a_good_one_is_captioned(
    frames: list[bytes], stub: Any
) -> None:
    proc = FrameProcessor(stub, VleSettings())
    bad = _bad_frames(frames[0])
    published: list[SceneDescription] = []
    lock = threading.Lock()

    def handle(payload: bytes) -> None:
        scene = proc.process(payload)
        if scene is not None:
            with lock:
                published.append(scene)

    worker: LatestFrameWorker[bytes] = LatestFrameWorker(handle)
    try:
        for payload in [*bad.values(), frames[2]]:
            worker.submit(payload)
            assert worker.wait_idle(10.0)
    finally:
        worker.close()
    assert proc.stats() == {"captioned": 1, "dropped": {"malformed": 3, "size": 1, "no_depth": 1}}
    assert len(published) == 1 and published[0].frame_seq == decode_frame(frames[2]).header.seq
    assert worker.failed == 0


def test_console_script_dispatch(capsys: Any) -> None:
    from llmland_vle.main import main

    assert main(["--help"]) == 0 and "llmland-vle train" in capsys.readouterr().out
    assert main(["bogus"]) == 2
    from llmland_vle.training.cli import parse_seeds

    assert parse_seeds("1-3,7") == [1, 2, 3, 7]
