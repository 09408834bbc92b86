"""The blip backend loads a local directory and captions through the real transformers code."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from llmland_vle.backends import make_captioner
from llmland_vle.blip import build_tiny_blip
from llmland_vle.settings import VleSettings


@pytest.fixture(scope="module")
def tiny_blip(tmp_path_factory: pytest.TempPathFactory) -> Path:
    pytest.importorskip("transformers")
    return build_tiny_blip(tmp_path_factory.mktemp("tiny_blip"))


def test_tiny_blip_captions_through_the_factory(tiny_blip: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("HF_HUB_OFFLINE", "1")
    cap = make_captioner(VleSettings(backend="blip", model_path=tiny_blip))
    assert cap.backend == "blip" and cap.model_version.startswith("blip:")
    rng = np.random.default_rng(0)
    frame = rng.integers(0, 255, (240, 320, 3), dtype=np.uint8)
    crops = [rng.integers(0, 255, (96, 96, 3), dtype=np.uint8) for _ in range(2)]
    one = cap.caption(frame)
    assert isinstance(one.text, str) and one.text and one.backend == "blip" and one.latency_ms > 0.0
    many = cap.caption_batch(crops, kind="object")
    assert len(many) == 2 and all(c.text for c in many)
    again = cap.caption(frame)
    assert again.text == one.text  # greedy decoding is deterministic


def test_blip_needs_a_local_directory(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="MODEL_PATH"):
        make_captioner(VleSettings(backend="blip"))
    with pytest.raises(FileNotFoundError):
        make_captioner(VleSettings(backend="blip", model_path=tmp_path / "missing"))
