"""The captioner interface every backend implements, and the factory that picks one.

``caption(image)`` captions one (H, W, 3) uint8 RGB image; ``caption_batch(images)``
captions many at once (the backend batches them). ``kind`` says what the image is: a whole
camera frame (``"frame"``) or one obstacle crop (``"object"``); backends that caption every
image the same way (BLIP) ignore it. Every :class:`Caption` names the backend and model
version that produced it and its latency (for a batch: the batch's wall time divided by its
size).

Backends that need simulator truth rather than pixels (``oracle``) also implement
:class:`SceneCaptioner`; the service then hands them the whole frame and its blobs.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Sequence
from typing import TYPE_CHECKING, Literal, Protocol, runtime_checkable

import numpy as np
from llmland_schemas import Caption

if TYPE_CHECKING:
    from llmland_schemas.depth import Blob
    from llmland_schemas.frames import CameraFrame

    from .settings import VleSettings

CaptionKind = Literal["frame", "object"]


class CaptionUnavailableError(RuntimeError):
    """The backend cannot caption this input (e.g. the oracle without simulator truth)."""


class Captioner(Protocol):
    """Image in, caption out."""

    backend: str
    model_version: str

    def caption(self, image_rgb: np.ndarray, kind: CaptionKind = "frame") -> Caption: ...

    def caption_batch(self, images: Sequence[np.ndarray], kind: CaptionKind = "object") -> list[Caption]: ...


class BatchCaptioner:
    """Base of the pixel backends: one lock, batch timing and :class:`Caption` wrapping.

    Subclasses set ``backend`` and ``model_version`` and implement :meth:`_generate`
    (texts for checked, non-empty batches), which runs under the model lock.
    """

    backend: str
    model_version: str

    def __init__(self) -> None:
        self._lock = threading.Lock()

    def _generate(self, images: Sequence[np.ndarray], kind: CaptionKind) -> list[str]:
        raise NotImplementedError

    def caption(self, image_rgb: np.ndarray, kind: CaptionKind = "frame") -> Caption:
        return self.caption_batch([image_rgb], kind=kind)[0]

    def caption_batch(self, images: Sequence[np.ndarray], kind: CaptionKind = "object") -> list[Caption]:
        if not images:
            return []
        t0 = time.perf_counter()
        with self._lock:
            texts = self._generate(images, kind)
        per_ms = (time.perf_counter() - t0) * 1e3 / len(images)
        return [Caption(text=t, backend=self.backend, model=self.model_version, latency_ms=per_ms) for t in texts]


@runtime_checkable
class SceneCaptioner(Protocol):
    """A backend that captions a frame from its blobs and outside knowledge (the oracle)."""

    def caption_scene(self, frame: CameraFrame, blobs: Sequence[Blob]) -> tuple[Caption, list[Caption]]: ...


def make_captioner(settings: VleSettings) -> Captioner:
    """The backend named by ``settings.backend`` (simcap, blip or oracle)."""
    if settings.backend == "simcap":
        from .simcap.backend import SimcapCaptioner

        return SimcapCaptioner(settings.model_path, threads=settings.threads, crop_size=settings.crop_size)
    if settings.backend == "blip":
        from .blip import BlipCaptioner

        if settings.model_path is None:
            raise ValueError("the blip backend needs LLMLAND_VLE_MODEL_PATH (a local BLIP directory)")
        return BlipCaptioner(settings.model_path, threads=settings.threads)
    if settings.backend == "oracle":
        from .oracle import OracleCaptioner

        return OracleCaptioner(noise=settings.oracle_noise, seed=settings.oracle_seed)
    raise ValueError(f"unknown captioner backend {settings.backend!r}")
