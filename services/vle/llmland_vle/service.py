"""Bus wiring of the VLE service: camera frames in, scene descriptions out, caption queryable.

* subscribes ``llmland/<d>/sim/camera`` — payloads are handed untouched to a
  :class:`LatestFrameWorker` (the Zenoh thread does no work), which decodes, checks and
  captions only the newest frame; frames replaced while it is busy are counted as dropped;
* publishes ``llmland/<d>/vle/scene`` (:class:`SceneDescription`) per captioned frame;
* subscribes ``llmland/<d>/sim/truth`` only with the oracle backend;
* serves the queryable ``llmland/@ground/vle/caption``: query payload = PNG/JPEG bytes, optional
  selector parameter ``kind=frame|object`` (default ``frame``) → reply JSON :class:`Caption`,
  or ``reply_err`` with a message for a bad image; queries run on their own thread;
* declares the liveliness token ``llmland/<d>/alive/vle``.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import zenoh
from llmland_schemas import VLE_CAPTION_QUERY, Topic, alive, encode, key
from llmland_schemas.bus import Bus
from llmland_schemas.codec import MessageError
from llmland_schemas.frames import peek_header

from .backends import make_captioner
from .captioner import Captioner, CaptionUnavailableError, bus_inputs
from .crops import ImageError, load_image
from .pipeline import FrameProcessor, FrameRejectedError
from .settings import VleSettings
from .worker import LatestFrameWorker

log = logging.getLogger(__name__)

#: error replies about the image itself (not the VLE's own failure) start with this
BAD_IMAGE_PREFIX = "bad image: "


def _raw(payload: bytes) -> bytes:
    return payload


class VleService:
    """The running service; :meth:`close` stops the worker threads (the bus is the caller's)."""

    def __init__(self, settings: VleSettings, bus: Bus, captioner: Captioner | None = None) -> None:
        self.settings = settings
        self.bus = bus
        self.captioner = captioner if captioner is not None else make_captioner(settings)
        self.processor = FrameProcessor(self.captioner, settings)
        self.worker: LatestFrameWorker[tuple[bytes, float]] = LatestFrameWorker(self._handle)
        self._queries = ThreadPoolExecutor(max_workers=1, thread_name_prefix="vle-query")
        self.skipped = 0  # frames not meant for perception
        self.queries_ok = 0
        self.queries_failed = 0
        d = settings.drone_id
        self.scene_key = key(d, Topic.SCENE)
        bus.subscribe_parsed(key(d, Topic.CAMERA), _raw, self._on_frame)  # type: ignore[type-var]
        for extra in bus_inputs(self.captioner):  # e.g. the oracle's sim/truth
            bus.subscribe(key(d, extra.topic), extra.message, _drop_key(extra.handle))
        bus.queryable(VLE_CAPTION_QUERY, self._on_query)
        bus.announce(alive(d, "vle"))
        log.info("vle ready (drone %s, backend %s, model %s)", d, self.captioner.backend,
                 self.captioner.model_version)

    # ------------------------------------------------------------------ frames
    def _on_frame(self, _key: str, payload: bytes) -> None:
        try:
            header = peek_header(payload)
        except (MessageError, ValueError) as exc:
            # counted here, not in the worker: a newer frame could replace it there and it
            # would be counted as stale instead of malformed
            self.processor.reject(FrameRejectedError("malformed", f"malformed frame: {exc}"))
            return
        if not header.perceive:  # depth-only frame (lockstep pacing, DESIGN §4)
            self.skipped += 1
            return
        self.worker.submit((payload, time.perf_counter()))

    def _handle(self, item: tuple[bytes, float]) -> None:
        payload, t_arrival = item
        scene = self.processor.process(payload, t_arrival)
        if scene is not None:
            self.bus.publish(self.scene_key, scene)
            log.debug("frame %d: %d objects, %.1f ms", scene.frame_seq, len(scene.objects), scene.latency_ms)

    # ------------------------------------------------------------------ queryable
    def _on_query(self, query: zenoh.Query) -> None:
        self._queries.submit(self._answer, query)

    def _answer(self, query: zenoh.Query) -> None:
        try:
            payload = query.payload.to_bytes() if query.payload is not None else b""
            if len(payload) > self.settings.max_image_bytes:
                raise ImageError(f"image of {len(payload)} bytes exceeds {self.settings.max_image_bytes}")
            kind = query.parameters.get("kind") or "frame"
            if kind not in ("frame", "object"):
                raise ImageError(f"kind must be 'frame' or 'object', got {kind!r}")
            image = load_image(payload)
            cap = self.captioner.caption(image, kind="object" if kind == "object" else "frame")
            query.reply(VLE_CAPTION_QUERY, encode(cap), encoding=zenoh.Encoding.APPLICATION_JSON)
            self.queries_ok += 1
        except ImageError as exc:  # the asker's fault: the reasoner's HTTP API answers 422 with it
            self.queries_failed += 1
            log.warning("caption query refused: %s", exc)
            query.reply_err(f"{BAD_IMAGE_PREFIX}{exc}".encode())
        except CaptionUnavailableError as exc:
            self.queries_failed += 1
            log.warning("caption query refused: %s", exc)
            query.reply_err(str(exc).encode())
        except Exception as exc:
            self.queries_failed += 1
            log.exception("caption query failed")
            query.reply_err(f"captioning failed: {exc}".encode())
        finally:
            query.drop()

    # ------------------------------------------------------------------ lifecycle
    def stats(self) -> dict[str, Any]:
        return {
            "frames": {**self.worker.stats(), "skipped": self.skipped},
            "pipeline": self.processor.stats(),
            "queries": {"ok": self.queries_ok, "failed": self.queries_failed},
        }

    def close(self) -> None:
        self.worker.close()
        self._queries.shutdown(wait=True, cancel_futures=True)


def _drop_key(handle: Callable[[Any], None]) -> Callable[[str, Any], None]:
    """A bus callback ``(key, msg)`` that passes only ``msg`` to ``handle``."""
    return lambda _key, msg: handle(msg)
