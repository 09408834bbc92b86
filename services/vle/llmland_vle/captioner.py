"""The captioner interface every backend implements, and the factory that picks one.

``caption(image)`` captions one (H, W, 3) uint8 RGB image; ``caption_batch(images)``
captions many at once (the backend batches them). ``kind`` says what the image is: a whole
camera frame (``"frame"``) or one obstacle crop (``"object"``); backends that caption every
image the same way (BLIP) ignore it. Every :class:`Caption` names the backend and model
version that produced it and its latency (for a batch: the batch's wall time divided by its
size).

Backends that need simulator truth rather than pixels (``oracle``) also implement
:class:`SceneCaptioner`; the service then hands them the whole frame and its blobs. A backend
that needs bus messages besides the frames lists them in ``bus_inputs()`` (:class:`BusInput`);
the service subscribes them for it without knowing which backend it is. The backends and
their factory live beside this interface (:mod:`.backends`), never in it.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal, Protocol, runtime_checkable

import numpy as np
from llmland_schemas import Caption, Topic
from pydantic import BaseModel

if TYPE_CHECKING:
    from llmland_schemas.depth import Blob
    from llmland_schemas.frames import CameraFrame

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

    def _generate_frame_and_crops(self, frame_rgb: np.ndarray, crops: Sequence[np.ndarray]) -> list[str]:
        """Texts for a frame then its crops (a backend that can decode them together overrides this)."""
        return self._generate([frame_rgb], "frame") + (self._generate(crops, "object") if len(crops) else [])

    def caption(self, image_rgb: np.ndarray, kind: CaptionKind = "frame") -> Caption:
        return self.caption_batch([image_rgb], kind=kind)[0]

    def caption_frame_and_crops(self, frame_rgb: np.ndarray,
                                crops: Sequence[np.ndarray]) -> tuple[Caption, list[Caption]]:
        """The frame's caption (``kind="frame"``) and one per crop (``"object"``), in one model pass
        where the backend allows; ``latency_ms`` of each is the pass's time over the images."""
        caps = self._timed(lambda: self._generate_frame_and_crops(frame_rgb, crops), 1 + len(crops))
        return caps[0], caps[1:]

    def caption_batch(self, images: Sequence[np.ndarray], kind: CaptionKind = "object") -> list[Caption]:
        if not images:
            return []
        return self._timed(lambda: self._generate(images, kind), len(images))

    def _timed(self, generate: Callable[[], list[str]], n_images: int) -> list[Caption]:
        """Run ``generate`` under the model lock; its texts as :class:`Caption` s, each with the
        pass's time over ``n_images``."""
        t0 = time.perf_counter()
        with self._lock:
            texts = generate()
        per_ms = (time.perf_counter() - t0) * 1e3 / n_images
        return [Caption(text=t, backend=self.backend, model=self.model_version, latency_ms=per_ms) for t in texts]


@runtime_checkable
class SceneCaptioner(Protocol):
    """A backend that captions a frame from its blobs and outside knowledge (the oracle)."""

    def caption_scene(self, frame: CameraFrame, blobs: Sequence[Blob]) -> tuple[Caption, list[Caption]]: ...


@dataclass(frozen=True)
class BusInput:
    """A per-drone topic a backend reads, the message type on it, and what to do with each message."""

    topic: Topic
    message: type[BaseModel]
    handle: Callable[[Any], None]


@runtime_checkable
class ReadsBus(Protocol):
    """A backend that needs bus messages besides the camera frames (the oracle: ``sim/truth``)."""

    def bus_inputs(self) -> list[BusInput]: ...


def bus_inputs(captioner: object) -> list[BusInput]:
    """The bus inputs ``captioner`` asks for (none for pixel backends)."""
    return captioner.bus_inputs() if isinstance(captioner, ReadsBus) else []
