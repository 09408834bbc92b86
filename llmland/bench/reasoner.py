"""Reasoner figures: per-mode caption→spec latency (cold and warm cache) and peak RSS, from the
caption test set (one process per mode); and spec throughput with 10 drones publishing
scenes at 2 Hz to one reasoner process over Zenoh.
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


def _fleet(drones: int = 10, rate_hz: float = 2.0, seconds: float = 15.0) -> dict[str, Any]:
    """Scenes from ``drones`` drones at ``rate_hz`` (2 crops each, captions from the test set)."""
    captions = [c.caption for c in load_cases("eval")]
    port = free_port()
    received: list[tuple[float, str]] = []
    lat_ms: list[float] = []
    sent: dict[tuple[str, int], float] = {}
    lock = threading.Lock()
    with hub_bus(port) as bus, Stack(port, "d0") as stack:
        stack.start(["reasoner"])
        stack.wait_alive(bus, timeout_s=180)

        def on_spec(k: str, msg: SafetySpecMessage) -> None:
            now = time.perf_counter()
            with lock:
                received.append((now, k))
                t0 = sent.get((msg.drone_id, msg.seq))
                if t0 is not None:
                    lat_ms.append((now - t0) * 1e3)

        bus.subscribe(any_drone(Topic.SPEC), SafetySpecMessage, on_spec)
        time.sleep(1.0)
        t_start = time.perf_counter()
        n, seq = 0, 0
        while (elapsed := time.perf_counter() - t_start) < seconds:
            for d in range(drones):
                c = [captions[(seq * drones + d + i) % len(captions)] for i in range(3)]
                drone = f"d{d}"
                scene = SceneDescription(
                    drone_id=drone, stamp=elapsed, seq=seq, caption=Caption(text=c[0], backend="bench"),
                    objects=[SceneObject(obj_id=f"b{i}", caption=Caption(text=c[i], backend="bench"),
                                         centroid_m=(float(i), 0.0, 0.5), size_m=(0.5, 0.5, 1.0)) for i in (1, 2)],
                )
                with lock:
                    sent[(drone, seq)] = time.perf_counter()
                bus.publish(key(drone, Topic.SCENE), scene)
                n += 1
            seq += 1
            time.sleep(max(0.0, t_start + seq / rate_hz - time.perf_counter()))
        time.sleep(3.0)
    with lock:
        window = [t for t, _ in received if t - t_start <= seconds]
        per_drone = {k for _, k in received}
    out = {"reasoner_fleet_drones": drones, "reasoner_fleet_scenes_offered_per_s": round(n / seconds, 2),
           "reasoner_fleet_specs_per_s": round(len(window) / seconds, 2),
           "reasoner_fleet_drones_served": len(per_drone)}
    if lat_ms:
        out.update(percentiles(lat_ms, "reasoner_fleet_scene_to_spec_ms"))
    return out


def run_reasoner(quick: bool = False) -> dict[str, Any]:
    figures = _per_mode(["rag"] if quick else ["rag", "llm", "retrieval"])
    figures.update(_fleet(seconds=5.0 if quick else 15.0))
    return figures
