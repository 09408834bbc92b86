"""Oracle backend: truth-matched captions and a respected, seeded noise rate."""

from __future__ import annotations

import numpy as np
import pytest
from llmland_schemas import GroundTruth, TruthObject, decode_frame
from llmland_schemas.depth import Blob
from llmland_vle.captioner import CaptionUnavailableError
from llmland_vle.captions import caption_class
from llmland_vle.oracle import OracleCaptioner


def _truth(episode: str = "ep") -> GroundTruth:
    return GroundTruth(
        stamp=0.0, world="urban", target_m=(0.0, 0.0, 0.0), episode_id=episode,
        objects=[
            TruthObject(obj_id="person_0", cls="person", position_m=(3.0, 1.0, 0.85), velocity_mps=(1.0, 0.0, 0.0),
                        size_m=(0.3, 0.62, 1.7), dynamic=True, is_person=True),
            TruthObject(obj_id="vehicle_0", cls="vehicle", position_m=(8.0, -3.0, 0.75), size_m=(4.36, 1.8, 1.5)),
            TruthObject(obj_id="pad_0", cls="pad", position_m=(0.0, 0.0, 0.01), size_m=(2.0, 2.0, 0.03)),
        ],
    )


def _blob(i: int, xyz: tuple[float, float, float]) -> Blob:
    c = np.asarray(xyz, dtype=float)
    return Blob(blob_id=i, centroid_m=c, mean_m=c, lo_m=c - 0.3, hi_m=c + 0.3, size_m=np.full(3, 0.6), n_points=50,
                bbox_px=(10, 10, 40, 60), footprint_radius_m=0.3)


BLOBS = [_blob(0, (3.1, 1.1, 0.8)), _blob(1, (7.5, -2.6, 0.7)), _blob(2, (-9.0, 9.0, 0.5))]


def test_noise_free_captions_follow_the_truth(frames: list[bytes]) -> None:
    oracle = OracleCaptioner(noise=0.0)
    frame = decode_frame(frames[0])
    scene, objs = oracle.caption_scene(frame, BLOBS)
    assert scene.text == "an aerial view" and [o.text for o in objs] == ["an unknown object"] * 3  # no truth yet
    oracle.on_truth(_truth())
    scene, objs = oracle.caption_scene(frame, BLOBS)
    assert [o.text for o in objs] == ["a person walking", "a car parked", "an unknown object"]
    assert scene.text == "an aerial view of a street with a person and a car"
    assert all(o.backend == "oracle" for o in objs)
    with pytest.raises(CaptionUnavailableError):
        oracle.caption(frame.rgb)


@pytest.mark.parametrize("rate", [0.1, 0.3, 0.7])
def test_noise_rate_is_respected_and_seeded(frames: list[bytes], rate: float) -> None:
    frame = decode_frame(frames[0])
    clean = OracleCaptioner(noise=0.0)
    clean.on_truth(_truth())
    ref_scene, ref_objs = clean.caption_scene(frame, BLOBS[:2])
    runs = []
    for _ in range(2):
        oracle = OracleCaptioner(noise=rate, seed=42)
        oracle.on_truth(_truth())
        texts = []
        for _ in range(600):
            scene, objs = oracle.caption_scene(frame, BLOBS[:2])
            texts += [scene.text] + [o.text for o in objs]
        runs.append(texts)
    assert runs[0] == runs[1]  # same seed, same errors
    ref = ([ref_scene.text] + [o.text for o in ref_objs]) * 600
    changed = np.mean([a != b for a, b in zip(runs[0], ref, strict=True)])
    assert abs(changed - rate) < 0.04
    wrong_class = np.mean([caption_class(a) != caption_class(b) for a, b in zip(runs[0][1::3], ref[1::3],
                                                                                 strict=True)])
    assert 0.0 < wrong_class <= rate + 0.04  # omissions and wrong words change the class, synonyms do not
