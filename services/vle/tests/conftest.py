"""Shared fixtures for the VLE tests: synthetic frames and a fast stub captioner."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pytest
from llmland_schemas import Caption
from llmland_vle.bench import synthetic_frames
from llmland_vle.captioner import CaptionKind


class StubCaptioner:
    """Deterministic captions that say the image size; records what it was asked."""

    backend = "stub"
    model_version = "stub-1"

    def __init__(self) -> None:
        self.calls: list[tuple[str, int]] = []

    def caption(self, image_rgb: np.ndarray, kind: CaptionKind = "frame") -> Caption:
        return self.caption_batch([image_rgb], kind=kind)[0]

    def caption_batch(self, images: Sequence[np.ndarray], kind: CaptionKind = "object") -> list[Caption]:
        self.calls.append((kind, len(images)))
        return [Caption(text=f"a {kind} of {im.shape[1]}x{im.shape[0]}", backend=self.backend,
                        model=self.model_version, latency_ms=0.1) for im in images]


@pytest.fixture
def stub() -> StubCaptioner:
    return StubCaptioner()


@pytest.fixture(scope="session")
def frames() -> list[bytes]:
    return synthetic_frames(3)
