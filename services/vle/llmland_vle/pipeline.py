"""One camera frame in, one :class:`SceneDescription` out (no bus in here).

Steps: decode and check the frame (a malformed, truncated, wrongly sized or depth-less
frame is logged, counted by reason and dropped); find the obstacle blobs in its depth image
(``blobs_from_frame``, the planner's parameters); caption the whole frame and a square crop
around each blob's pixel box (the largest ``max_objects`` blobs); package the result.
"""

from __future__ import annotations

import logging
import threading
import time
from collections import Counter

from llmland_schemas import Caption, MessageError, SceneDescription, SceneObject
from llmland_schemas.depth import Blob, blobs_from_frame
from llmland_schemas.frames import CameraFrame, decode_frame

from .captioner import BatchCaptioner, Captioner, SceneCaptioner
from .crops import crop_square
from .settings import VleSettings

log = logging.getLogger(__name__)


class FrameRejectedError(ValueError):
    """A frame the service will not caption; ``reason`` is the counter key."""

    def __init__(self, reason: str, message: str) -> None:
        super().__init__(message)
        self.reason = reason


class FrameProcessor:
    """Captions frames with one backend; counts what it captioned and what it dropped."""

    def __init__(self, captioner: Captioner, settings: VleSettings) -> None:
        self.captioner = captioner
        self.settings = settings
        self.captioned = 0
        self.dropped: Counter[str] = Counter()
        self._seq = 0
        self._lock = threading.Lock()

    def check(self, payload: bytes) -> CameraFrame:
        """Decode and validate a frame; raise :class:`FrameRejectedError` with the reason."""
        try:
            frame = decode_frame(payload)
        except (MessageError, ValueError) as exc:
            raise FrameRejectedError("malformed", f"malformed frame: {exc}") from None
        h, w = frame.header.height, frame.header.width
        s = self.settings
        if not (s.min_frame_px <= w <= s.max_frame_px and s.min_frame_px <= h <= s.max_frame_px):
            raise FrameRejectedError("size", f"frame of {w}x{h} px outside {s.min_frame_px}..{s.max_frame_px} px")
        if frame.depth_m is None:
            raise FrameRejectedError("no_depth", "frame has no depth image")
        return frame

    def blobs(self, frame: CameraFrame) -> list[Blob]:
        blobs = blobs_from_frame(frame, stride=self.settings.blob_stride, max_range_m=self.settings.max_range_m)
        return blobs[: self.settings.max_objects]

    def process(self, payload: bytes, t_arrival: float | None = None) -> SceneDescription | None:
        """Caption one frame; None (and a counted drop) if it is rejected.

        ``latency_ms`` is the wall time from ``t_arrival`` (``time.perf_counter()`` when the
        frame arrived; default: now) until the description is ready.
        """
        t0 = time.perf_counter() if t_arrival is None else t_arrival
        try:
            frame = self.check(payload)
        except FrameRejectedError as exc:
            self.reject(exc)
            return None
        return self.describe(frame, t0)

    def reject(self, exc: FrameRejectedError) -> None:
        """Count and log one dropped frame under ``exc.reason`` (thread-safe)."""
        with self._lock:
            self.dropped[exc.reason] += 1
            n = self.dropped[exc.reason]
        log.warning("dropped frame (%s, %d so far): %s", exc.reason, n, exc)

    def describe(self, frame: CameraFrame, t0: float) -> SceneDescription:
        blobs = self.blobs(frame)
        scene_cap, obj_caps = self.caption(frame, blobs)
        objects = [
            SceneObject(
                obj_id=f"blob_{b.blob_id}",
                caption=cap,
                centroid_m=(float(b.centroid_m[0]), float(b.centroid_m[1]), float(b.centroid_m[2])),
                size_m=(float(b.size_m[0]), float(b.size_m[1]), float(b.size_m[2])),
                bbox_px=b.bbox_px,
            )
            for b, cap in zip(blobs, obj_caps, strict=True)
        ]
        h = frame.header
        with self._lock:
            self._seq += 1
            self.captioned += 1
            seq = self._seq
        return SceneDescription(
            drone_id=self.settings.drone_id,
            stamp=h.stamp,
            seq=seq,
            frame_seq=h.seq,
            caption=scene_cap,
            objects=objects,
            latency_ms=(time.perf_counter() - t0) * 1e3,
            episode_id=h.episode_id,
        )

    def caption(self, frame: CameraFrame, blobs: list[Blob]) -> tuple[Caption, list[Caption]]:
        """Frame caption and one caption per blob, from whichever backend is configured."""
        cap = self.captioner
        if isinstance(cap, SceneCaptioner):
            return cap.caption_scene(frame, blobs)
        crops = [crop_square(frame.rgb, b.bbox_px, self.settings.crop_size) for b in blobs]
        if isinstance(cap, BatchCaptioner):
            return cap.caption_frame_and_crops(frame.rgb, crops)
        return cap.caption(frame.rgb, kind="frame"), cap.caption_batch(crops, kind="object")

    def stats(self) -> dict[str, object]:
        with self._lock:
            return {"captioned": self.captioned, "dropped": dict(self.dropped)}
