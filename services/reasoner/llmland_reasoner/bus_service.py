"""The reasoner on the bus: scenes in from every drone, per-object specs out.

Subscribes ``llmland/*/vle/scene`` (one reasoner serves many drones). A scene whose captions
are all cached is answered on arrival; otherwise each drone keeps only its newest pending scene
(older ones are dropped and counted) and a worker serves the drones round robin, several
drones' scenes in one batch, so a busy drone cannot starve the others (``fleet.py``).
Publishes ``llmland/<d>/reasoner/spec`` stamped with the frame's stamp and the measured
latency (captioning + the wait and reasoning since the scene arrived), so the
planner applies it when it would really have arrived. Queryable ``llmland/@ground/reasoner/spec``:
a caption (UTF-8 text or ``{"caption": ...}``) → SafetySpec JSON.
"""

from __future__ import annotations

import json
import logging
import threading
import time
from collections import Counter
from collections.abc import Callable

import zenoh
from llmland_schemas import (
    REASONER_SPEC_QUERY,
    VLE_CAPTION_QUERY,
    Caption,
    MessageError,
    ObjectSpec,
    SafetySpec,
    SafetySpecMessage,
    SceneDescription,
    Topic,
    any_drone,
    decode,
    drone_of,
    encode,
    key,
)
from llmland_schemas.bus import Bus

from .engine import ReasonerEngine
from .fleet import FairSceneQueue, Pending
from .upload import CaptionFailedError, CaptionRefusedError

log = logging.getLogger(__name__)

#: the VLE's error replies about the image itself start with this (llmland_vle.service)
BAD_IMAGE_PREFIX = "bad image: "


#: Most drones whose scenes one batch serves.
MAX_BATCH_DRONES = 10
#: Most distinct captions a batch computes (not in the cache): the LLM's work does not get
#: cheaper per caption in a batch on a CPU, so small batches keep the wait short; a caption
#: several drones' scenes share is computed once (a scene needing more is served alone).
COLD_CAPTIONS_PER_BATCH = 6
#: How long the worker waits for a scene before checking for shutdown (s).
POLL_S = 0.2
#: How often the per-drone counters are logged (s).
STATS_LOG_S = 10.0


class ReasonerBusService:
    """Fair, newest-scene-wins reasoning for any number of drones.

    A scene whose captions are all in the spec cache is answered on arrival (no model work);
    the others wait in a :class:`~.fleet.FairSceneQueue` (one slot per drone, newest wins,
    round robin) and are served in batches across drones (``engine.extract_many``: each
    distinct caption once, the model work batched). A spec is never published for a scene
    older than one already answered for that drone.
    """

    def __init__(self, engine: ReasonerEngine, bus: Bus) -> None:
        self.engine = engine
        self.bus = bus
        self.queue: FairSceneQueue[SceneDescription] = FairSceneQueue()
        self.stats: Counter[str] = Counter()
        self.offered: Counter[str] = Counter()  # per drone: scenes received
        self.published: Counter[str] = Counter()  # per drone: specs published
        self._lock = threading.Lock()
        self._newest_published: dict[str, float] = {}
        self._stop = threading.Event()
        bus.subscribe(any_drone(Topic.SCENE), SceneDescription, self._on_scene)
        bus.queryable(REASONER_SPEC_QUERY, self._on_query)
        self._worker = threading.Thread(target=self._run, name="reasoner-bus", daemon=True)
        self._worker.start()

    def _on_scene(self, k: str, scene: SceneDescription) -> None:
        try:
            drone, now = drone_of(k), time.perf_counter()
        except ValueError as exc:  # a key no drone may have (``llmland/bad!id/vle/scene``): malformed
            self._count("scenes_bad_key")
            log.warning("dropped a scene on %s (%d so far): %s", k, self.stats["scenes_bad_key"], exc)
            return
        with self._lock:
            self.stats["scenes_offered"] += 1
            self.offered[drone] += 1
        specs = self._cached(scene)
        if specs is None:
            if self.queue.put(drone, scene, now):
                self._count("scenes_superseded")
            return
        if self.queue.drop(drone):  # this newer scene answers for the pending older one
            self._count("scenes_superseded")
        self._count("specs_from_cache")
        self._publish(drone, scene, specs, now)

    def _cached(self, scene: SceneDescription) -> list[SafetySpec] | None:
        lookup = getattr(self.engine, "cached_specs", None)
        if not callable(lookup):
            return None
        try:
            hits = lookup(_captions(scene))
        except Exception:  # a cache lookup must never lose a scene: the worker serves it
            log.exception("spec cache lookup failed")
            return None
        return list(hits) if hits is not None else None

    def _cold_counter(self) -> Callable[[SceneDescription], int]:
        """For one batch: how many captions each next scene adds to what the batch computes
        (not cached, not already in the batch)."""
        lookup = getattr(self.engine, "cached_specs", None)
        seen: set[str] = set()

        def cold(scene: SceneDescription) -> int:
            new = [c for c in dict.fromkeys(_captions(scene)) if c not in seen]
            seen.update(new)
            return len(new) if not callable(lookup) else sum(lookup([c]) is None for c in new)

        return cold

    def _run(self) -> None:
        last_log = time.monotonic()
        while not self._stop.is_set():
            for p in self.queue.take_ready(lambda scene: self._cached(scene) is not None):
                self._serve_cached(p)  # computed while it waited: never behind the next batch
            batch = self.queue.take(MAX_BATCH_DRONES, POLL_S, cost=self._cold_counter(),
                                    budget=COLD_CAPTIONS_PER_BATCH)
            if batch:
                self._serve(batch)
            if time.monotonic() - last_log >= STATS_LOG_S:
                last_log = time.monotonic()
                with self._lock:
                    served, offered = dict(self.published), dict(self.offered)
                log.info("specs published per drone %s (scenes offered %s; %s)", served, offered, dict(self.stats))

    def _serve_cached(self, p: Pending[SceneDescription]) -> bool:
        specs = self._cached(p.item)
        if specs is None:
            return False
        self._count("specs_from_cache")
        self._publish(p.drone, p.item, specs, p.received_s)
        return True

    def _serve(self, batch: list[Pending[SceneDescription]]) -> None:
        batch = [p for p in batch if not self._serve_cached(p)]  # cached ones first, not after the batch
        if not batch:
            return
        captions = [c for p in batch for c in _captions(p.item)]
        try:
            many = getattr(self.engine, "extract_many", None)
            specs = list(many(captions)) if callable(many) else [self.engine.extract(c) for c in captions]
            if len(specs) != len(captions):
                raise RuntimeError(f"{len(specs)} specs for {len(captions)} captions")
        except Exception as exc:  # the engine never should; if it does, every drone gets the fallback
            log.exception("batch of %d scenes failed", len(batch))
            specs = [SafetySpec.conservative(c, reason=f"{type(exc).__name__}: {exc}") for c in captions]
        self._count("batches")
        at = 0
        for p in batch:
            n = len(_captions(p.item))
            self._publish(p.drone, p.item, specs[at : at + n], p.received_s)
            at += n

    def _publish(self, drone: str, scene: SceneDescription, specs: list[SafetySpec], received_s: float) -> None:
        with self._lock:
            if self._newest_published.get(drone, -1.0) > received_s:
                self.stats["scenes_superseded"] += 1  # a newer scene of this drone was answered first
                return
            self._newest_published[drone] = received_s
        try:
            self.bus.publish(key(drone, Topic.SPEC), self.message(drone, scene, specs, received_s))
        except Exception:  # keep serving the other drones
            log.exception("publishing the spec failed for drone %s", drone)
            return
        with self._lock:
            self.stats["specs_published"] += 1
            self.published[drone] += 1

    def message(self, drone: str, scene: SceneDescription, specs: list[SafetySpec],
                received_s: float) -> SafetySpecMessage:
        """The spec message of a scene: the frame caption's spec, then one per object; latency
        = captioning + the wait and reasoning since the scene arrived."""
        reason_ms = (time.perf_counter() - received_s) * 1e3
        objects = [ObjectSpec(obj_id=o.obj_id, centroid_m=o.centroid_m, size_m=o.size_m, spec=spec)
                   for o, spec in zip(scene.objects, specs[1:], strict=True)]
        return SafetySpecMessage(
            drone_id=drone, stamp=scene.stamp, seq=scene.seq, frame_seq=scene.frame_seq,
            scene=specs[0], objects=objects, latency_ms=scene.latency_ms + reason_ms,
            episode_id=scene.episode_id,
        )

    def reason(self, drone: str, scene: SceneDescription) -> SafetySpecMessage:
        """One scene, now, outside the queue."""
        t0 = time.perf_counter()
        many = getattr(self.engine, "extract_many", None)
        captions = _captions(scene)
        specs = list(many(captions)) if callable(many) else [self.engine.extract(c) for c in captions]
        return self.message(drone, scene, specs, t0)

    def _count(self, name: str) -> None:
        with self._lock:
            self.stats[name] += 1

    def _on_query(self, query: zenoh.Query) -> None:
        raw = query.payload.to_bytes() if query.payload is not None else b""
        text = raw.decode("utf-8", errors="replace").strip()
        if text.startswith("{"):
            try:
                caption = json.loads(text).get("caption", "")
            except (ValueError, AttributeError, RecursionError):
                caption = ""
            text = caption if isinstance(caption, str) else ""  # null or an object is no caption
        if not text:
            query.reply_err(b"send a caption as UTF-8 text or {\"caption\": \"...\"}")
            return
        query.reply(REASONER_SPEC_QUERY, encode(self.engine.extract(text)))

    def close(self) -> None:
        self._stop.set()
        self.queue.close()
        self._worker.join(timeout=5)


def _captions(scene: SceneDescription) -> list[str]:
    """The frame caption, then each object's."""
    return [scene.caption.text, *[o.caption.text for o in scene.objects]]


def caption_via_vle(bus: Bus, timeout_s: float = 10.0):  # type: ignore[no-untyped-def]
    """A function image bytes → Caption | None, asking the VLE queryable over Zenoh."""

    def caption(image: bytes) -> Caption | None:
        refused: str | None = None
        for reply in bus.session.get(VLE_CAPTION_QUERY, payload=image, timeout=timeout_s):
            if reply.ok is None:
                refused = reply.err.payload.to_bytes()[:500].decode("utf-8", "replace") if reply.err else "error"
                log.warning("VLE replied with an error: %s", refused)
                continue
            try:
                return decode(Caption, reply.ok.payload.to_bytes())
            except MessageError as exc:
                log.warning("bad caption reply: %s", exc)
        if refused is not None:
            if refused.startswith(BAD_IMAGE_PREFIX):  # the image's fault (a 4xx)
                raise CaptionRefusedError(refused.removeprefix(BAD_IMAGE_PREFIX))
            raise CaptionFailedError(refused)  # the VLE's own (a 502)
        return None

    return caption
