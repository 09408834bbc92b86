"""Reasoner figures: per-mode caption→spec latency (cold and warm cache) and peak RSS, from the
caption test set (one process per mode); and, with 10 drones publishing scenes (a frame
caption and two crop captions each) at 2 Hz to one reasoner process over Zenoh, specs/s and
scene→spec latency per drone and overall, for two caption streams (:func:`_scene_captions`).
"""

from __future__ import annotations

import json
import subprocess
import sys
import threading
import time
from typing import Any

from llmland_reasoner.evaluation import load_cases
from llmland_schemas import Caption, SafetySpecMessage, SceneDescription, SceneObject, Topic, any_drone, key
from llmland_schemas.bus import Bus

from ..launch import Stack, free_port, hub_bus
from . import percentiles


def _per_mode(modes: list[str]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for mode in modes:
        cmd = [sys.executable, "-m", "llmland_reasoner.evaluation", "--mode", mode, "--json"]
        rep = json.loads(subprocess.run(cmd, check=True, capture_output=True, text=True).stdout)
        rep = rep.get(mode, rep)
        out[f"reasoner_{mode}_accuracy"] = rep["acc_both"]
        out[f"reasoner_{mode}_cold_ms_p50"] = rep["latency_cold_ms"]["p50"]
        out[f"reasoner_{mode}_cold_ms_p95"] = rep["latency_cold_ms"]["p95"]
        out[f"reasoner_{mode}_warm_ms_p50"] = rep["latency_warm_ms"]["p50"]
        out[f"reasoner_{mode}_warm_ms_p95"] = rep["latency_warm_ms"]["p95"]
        out[f"reasoner_{mode}_peak_rss_mb"] = rep["peak_rss_mb"]
    return out


#: Drones and scene rate of the fleet benchmark (the issue: ten drones at 2 Hz).
FLEET_DRONES = 10
FLEET_RATE_HZ = 2.0
#: Crops per scene (each with its caption), besides the frame caption.
CROPS_PER_SCENE = 2
#: After the last scene, how long specs are still awaited (s).
DRAIN_S = 3.0
#: ``flight`` stream: captions a drone's view holds at a time, how many frames each view
#: is held, and how often a new caption enters a drone's view (frames).
WORLD_CAPTIONS = 4
HOLD_FRAMES = 4
NOVEL_EVERY_FRAMES = 10


def _scene_captions(stream: str, pool: list[str], drone: int, seq: int, drones: int) -> list[str]:
    """The frame caption and the crops' captions of one scene.

    ``novel`` (the issue's stress stream): consecutive captions of the pool, a different
    window for every drone and frame, so the first lap of the pool is all new captions
    (about ``drones`` new captions a frame). ``flight``: each drone sees its own few obstacles
    (:data:`WORLD_CAPTIONS` captions) from frame to frame, the view shifting every
    :data:`HOLD_FRAMES` frames, and one new caption entering every :data:`NOVEL_EVERY_FRAMES`
    frames (2 new captions/s over 10 drones at 2 Hz), the drones out of step by a frame each."""
    n = 1 + CROPS_PER_SCENE
    if stream == "novel":
        return [pool[(seq * drones + drone + i) % len(pool)] for i in range(n)]
    frame = seq + drone  # drones are not in step: each changes its view at its own frames
    base = drone * 37 + frame // NOVEL_EVERY_FRAMES  # the drone's world slides by one caption
    view = frame // HOLD_FRAMES
    return [pool[(base + (view + i) % WORLD_CAPTIONS) % len(pool)] for i in range(n)]


class _FleetReplies:
    """The specs answering one fleet run's scenes (``episode_id`` = the run's epoch)."""

    def __init__(self, epoch: str) -> None:
        self.epoch = epoch
        self.sent: dict[tuple[str, int], float] = {}
        self.got: dict[str, list[tuple[int, float, float]]] = {}  # drone → (seq, received at, latency ms)
        self.fallbacks = 0
        self.lock = threading.Lock()
        self.measure_from = float("inf")

    def on_spec(self, _k: str, msg: SafetySpecMessage) -> None:
        now = time.perf_counter()
        if msg.episode_id != self.epoch:
            return
        with self.lock:
            t0 = self.sent.get((msg.drone_id, msg.seq))
            if t0 is None or t0 < self.measure_from:
                return
            self.got.setdefault(msg.drone_id, []).append((msg.seq, now, (now - t0) * 1e3))
            self.fallbacks += sum(s.source == "fallback" for s in [msg.scene, *[o.spec for o in msg.objects]])

    def summary(self, p: str, offered: dict[str, int], seconds: float, t_end: float) -> dict[str, Any]:
        """The figures, keys prefixed ``p`` (see :func:`_fleet`)."""
        with self.lock:
            lat = [ms for v in self.got.values() for _, _, ms in v]
            in_window = sum(1 for v in self.got.values() for _, t, _ in v if t <= t_end)
            per_drone = {}
            for drone in sorted(offered, key=lambda x: int(x[1:])):
                mine = [ms for _, _, ms in self.got.get(drone, [])]
                per_drone[drone] = {"offered": offered[drone], "served": len(mine),
                                    "superseded": offered[drone] - len(mine),
                                    **(percentiles(mine, "scene_to_spec_ms") if mine else {})}
            out: dict[str, Any] = {
                f"{p}_scenes_offered": sum(offered.values()),
                f"{p}_scenes_offered_per_s": round(sum(offered.values()) / seconds, 2),
                f"{p}_scenes_served": len(lat), f"{p}_scenes_superseded": sum(offered.values()) - len(lat),
                f"{p}_specs_per_s": round(in_window / seconds, 2),
                f"{p}_drones_served": sum(1 for v in per_drone.values() if v["served"]),
                f"{p}_fallback_specs": self.fallbacks,
                f"{p}_per_drone": per_drone,
            }
        if lat:
            out.update(percentiles(lat, f"{p}_scene_to_spec_ms"))
        return out


def _fleet_scene(stream: str, pool: list[str], d: int, seq: int, drones: int, rate_hz: float,
                 epoch: str) -> SceneDescription:
    c = _scene_captions(stream, pool, d, seq, drones)
    return SceneDescription(
        drone_id=f"d{d}", stamp=seq / rate_hz, seq=seq, episode_id=epoch,
        caption=Caption(text=c[0], backend="bench"),
        objects=[SceneObject(obj_id=f"b{i}", caption=Caption(text=c[i], backend="bench"),
                             centroid_m=(float(i), 0.0, 0.5), size_m=(0.5, 0.5, 1.0))
                 for i in range(1, len(c))],
    )


def _fleet(bus: Bus, stream: str, pool: list[str], drones: int = FLEET_DRONES, rate_hz: float = FLEET_RATE_HZ,
           seconds: float = 15.0, warmup_s: float = 0.0) -> dict[str, Any]:
    """Scenes from ``drones`` drones at ``rate_hz`` to the running reasoner for ``warmup_s``
    (not measured) and then ``seconds`` (measured): specs/s, scene→spec latency per drone and
    overall, scenes offered / served / superseded (offered, never answered: a newer scene of
    the same drone was answered instead) and fallback specs among those served."""
    replies = _FleetReplies(f"{stream}-{time.time_ns()}")
    bus.subscribe(any_drone(Topic.SPEC), SafetySpecMessage, replies.on_spec)
    time.sleep(0.5)
    t_start = time.perf_counter()
    replies.measure_from = t_start + warmup_s
    offered: dict[str, int] = {}
    seq = 0
    while time.perf_counter() - t_start < warmup_s + seconds:
        for d in range(drones):
            scene = _fleet_scene(stream, pool, d, seq, drones, rate_hz, replies.epoch)
            now = time.perf_counter()
            with replies.lock:
                replies.sent[(scene.drone_id, seq)] = now
            if now >= replies.measure_from:
                offered[scene.drone_id] = offered.get(scene.drone_id, 0) + 1
            bus.publish(key(scene.drone_id, Topic.SCENE), scene)
        seq += 1
        time.sleep(max(0.0, t_start + seq / rate_hz - time.perf_counter()))
    t_end = time.perf_counter()
    time.sleep(DRAIN_S)
    p = f"reasoner_fleet_{stream}"
    return {f"{p}_drones": drones, f"{p}_warmup_s": warmup_s, f"{p}_seconds": seconds,
            **replies.summary(p, offered, seconds, t_end)}


def run_fleet(seconds: float = 15.0, flight_warmup_s: float = 20.0) -> dict[str, Any]:
    """One reasoner process; the ``novel`` stream from a cold cache (eval captions), then the
    ``flight`` stream after a warm-up (public captions, none of which the first stream used)."""
    port = free_port()
    figures: dict[str, Any] = {}
    with hub_bus(port) as bus, Stack(port, "d0") as stack:
        stack.start(["reasoner"])
        stack.wait_alive(bus, timeout_s=180)
        time.sleep(1.0)
        figures.update(_fleet(bus, "novel", [c.caption for c in load_cases("eval")], seconds=seconds))
        figures.update(_fleet(bus, "flight", [c.caption for c in load_cases("public")], seconds=seconds,
                              warmup_s=flight_warmup_s))
    return figures


def run_reasoner(quick: bool = False) -> dict[str, Any]:
    figures = _per_mode(["rag"] if quick else ["rag", "llm", "retrieval"])
    figures.update(run_fleet(seconds=5.0 if quick else 15.0, flight_warmup_s=5.0 if quick else 20.0))
    return figures
