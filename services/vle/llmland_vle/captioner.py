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
