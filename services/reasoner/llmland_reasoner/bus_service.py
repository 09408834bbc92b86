"""The reasoner on the bus: scenes in from every drone, per-object specs out.

Subscribes ``llmland/*/vle/scene`` (one reasoner serves many drones). Each drone keeps only
its newest pending scene (older ones are dropped and counted); a worker serves the drones
round-robin so a busy drone cannot starve the others. Publishes ``llmland/<d>/reasoner/spec``
stamped with the frame's stamp and the measured latency (captioning + reasoning), so the
planner applies it when it would really have arrived. Queryable ``llmland/reasoner/spec``:
a caption (UTF-8 text or ``{"caption": ...}``) → SafetySpec JSON.
"""

from __future__ import annotations

import json
import logging
import threading
import time
from collections import Counter, OrderedDict

import zenoh
from llmland_schemas import (
    REASONER_SPEC_QUERY,
    VLE_CAPTION_QUERY,
    Caption,
    MessageError,
    ObjectSpec,
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

log = logging.getLogger(__name__)


class ReasonerBusService:
    """Fair, newest-scene-wins reasoning for any number of drones."""

    def __init__(self, engine: ReasonerEngine, bus: Bus) -> None:
        self.engine = engine
        self.bus = bus
        self._cond = threading.Condition()
        self._pending: OrderedDict[str, SceneDescription] = OrderedDict()
        self.stats: Counter[str] = Counter()
        self._stop = threading.Event()
        bus.subscribe(any_drone(Topic.SCENE), SceneDescription, self._on_scene)
        bus.queryable(REASONER_SPEC_QUERY, self._on_query)
        self._worker = threading.Thread(target=self._run, name="reasoner-bus", daemon=True)
        self._worker.start()

    def _on_scene(self, k: str, scene: SceneDescription) -> None:
        drone = drone_of(k)
        with self._cond:
            if drone in self._pending:
                self.stats["scenes_replaced"] += 1
            self._pending[drone] = scene
            self._cond.notify()

    def _next(self) -> tuple[str, SceneDescription] | None:
        with self._cond:
            while not self._pending and not self._stop.is_set():
                self._cond.wait(0.2)
            if self._stop.is_set():
                return None
            return self._pending.popitem(last=False)  # oldest-waiting drone first: round robin

    def _run(self) -> None:
        while (item := self._next()) is not None:
            drone, scene = item
            try:
                self.bus.publish(key(drone, Topic.SPEC), self.reason(drone, scene))
                self.stats["specs_published"] += 1
            except Exception:  # keep serving the other drones
                log.exception("reasoning failed for drone %s", drone)

    def reason(self, drone: str, scene: SceneDescription) -> SafetySpecMessage:
        t0 = time.perf_counter()
        scene_spec = self.engine.extract(scene.caption.text)
        objects = [
            ObjectSpec(obj_id=o.obj_id, centroid_m=o.centroid_m, size_m=o.size_m,
                       spec=self.engine.extract(o.caption.text))
            for o in scene.objects
        ]
        reason_ms = (time.perf_counter() - t0) * 1e3
        return SafetySpecMessage(
            drone_id=drone, stamp=scene.stamp, seq=scene.seq, frame_seq=scene.frame_seq,
            scene=scene_spec, objects=objects, latency_ms=scene.latency_ms + reason_ms,
            episode_id=scene.episode_id,
        )

    def _on_query(self, query: zenoh.Query) -> None:
        raw = query.payload.to_bytes() if query.payload is not None else b""
        text = raw.decode("utf-8", errors="replace").strip()
        if text.startswith("{"):
            try:
                text = str(json.loads(text).get("caption", ""))
            except (ValueError, AttributeError):
                text = ""
        if not text:
            query.reply_err(b"send a caption as UTF-8 text or {\"caption\": \"...\"}")
            return
        query.reply(REASONER_SPEC_QUERY, encode(self.engine.extract(text)))

    def close(self) -> None:
        self._stop.set()
        self._worker.join(timeout=5)


def caption_via_vle(bus: Bus, timeout_s: float = 10.0):  # type: ignore[no-untyped-def]
    """A function image bytes → Caption | None, asking the VLE queryable over Zenoh."""

    def caption(image: bytes) -> Caption | None:
        for reply in bus.session.get(VLE_CAPTION_QUERY, payload=image, timeout=timeout_s):
            if reply.ok is None:
                log.warning("VLE replied with an error: %s", reply.err.payload.to_bytes()[:200] if reply.err else "")
                continue
            try:
                return decode(Caption, reply.ok.payload.to_bytes())
            except MessageError as exc:
                log.warning("bad caption reply: %s", exc)
        return None

    return caption
