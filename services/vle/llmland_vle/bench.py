"""``llmland-vle bench``: simcap latency per frame and per crop, and drops at a 10 Hz stream.

A "frame" is the whole per-frame job of the service: decode, depth blobs, the full-frame
caption and one caption per blob crop. Frames are rendered with the simulator when it is
installed (the three worlds, along the drone's approach), else synthesised (flat ground plus
box obstacles). Drops: frames are offered to the latest-frame worker at 10 Hz for a few
seconds while it captions them; stale frames it never took are counted.
"""

from __future__ import annotations

import argparse
import json
import logging
import math
import sys
import time
from typing import Any

import numpy as np
from llmland_schemas import CameraFrameHeader, CameraIntrinsics, encode_frame

from .crops import crop_square
from .pipeline import FrameProcessor
from .settings import VleSettings
from .simcap.backend import SimcapCaptioner
from .worker import LatestFrameWorker

log = logging.getLogger(__name__)


def synthetic_frames(n: int, seed: int = 0) -> list[bytes]:
    """``n`` encoded 384×384 frames: flat ground seen from 3 m, 45° down, with five boxes each."""
    size, f = 384, 192.0
    rng = np.random.default_rng(seed)
    cam_h, pitch = 3.0, math.radians(45.0)
    v = np.arange(size, dtype=float)[:, None] - size / 2
    ang = pitch + np.arctan2(v, f)
    depth = np.where(ang > 0.01, cam_h / np.sin(np.clip(ang, 0.01, None)) * np.cos(np.arctan2(v, f)), np.inf)
    depth = np.repeat(depth, size, axis=1).astype(np.float32)
    T = np.eye(4)
    T[:3, :3] = np.array([[0.0, -math.sin(pitch), math.cos(pitch)], [-1.0, 0.0, 0.0],
                          [0.0, -math.cos(pitch), -math.sin(pitch)]])
    T[2, 3] = cam_h
    out = []
    for k in range(n):
        rgb = np.full((size, size, 3), (70, 140, 60), np.uint8)
        d = depth.copy()
        for _ in range(5):
            u0, v0 = int(rng.integers(20, 330)), int(rng.integers(120, 320))
            w, h = int(rng.integers(15, 50)), int(rng.integers(20, 60))
            d[v0 - h : v0, u0 : u0 + w] = depth[v0, 0]
            rgb[v0 - h : v0, u0 : u0 + w] = rng.integers(0, 255, 3)
        header = CameraFrameHeader(seq=k, stamp=0.1 * k, width=size, height=size,
                                   intrinsics=CameraIntrinsics(fx=f, fy=f, cx=191.5, cy=191.5, width=size, height=size),
                                   T_world_camera=[float(x) for x in T.ravel()])
        out.append(encode_frame(header, rgb, d))
    return out


def typical_frames(n: int = 12) -> list[bytes]:
    """Simulator frames when the simulator is installed (the ``train`` extra), else synthetic ones."""
    try:
        from .simrender import approach_frames

        return approach_frames(n)
    except ImportError:
        log.info("llmland_sim not installed: benchmarking synthetic frames")
        return synthetic_frames(n)


def _pct(xs: list[float], q: float) -> float:
    return round(float(np.percentile(np.asarray(xs), q)), 2)


def run_bench(quick: bool = False) -> dict[str, Any]:
    """simcap figures on this machine (see the module docstring)."""
    settings = VleSettings()
    captioner = SimcapCaptioner(settings.model_path, threads=settings.threads, crop_size=settings.crop_size)
    proc = FrameProcessor(captioner, settings)
    frames = typical_frames(6 if quick else 12)
    for payload in frames[:2]:  # warm-up
        proc.process(payload)
    frame_ms, crop_ms, n_objects = [], [], []
    for _ in range(3 if quick else 10):
        for payload in frames:
            t0 = time.perf_counter()
            scene = proc.process(payload)
            frame_ms.append((time.perf_counter() - t0) * 1e3)
            assert scene is not None
            n_objects.append(len(scene.objects))
    decoded = [proc.check(payload) for payload in frames]
    crops = [crop_square(f.rgb, b.bbox_px, settings.crop_size) for f in decoded for b in proc.blobs(f)]
    for crop in crops * (2 if quick else 5):
        t0 = time.perf_counter()
        captioner.caption_batch([crop], kind="object")
        crop_ms.append((time.perf_counter() - t0) * 1e3)

    worker: LatestFrameWorker[bytes] = LatestFrameWorker(lambda payload: proc.process(payload))
    duration_s, period_s = (3.0 if quick else 10.0), 0.1
    t_start = time.perf_counter()
    k = 0
    while k * period_s < duration_s:
        time.sleep(max(0.0, t_start + k * period_s - time.perf_counter()))
        worker.submit(frames[k % len(frames)])
        k += 1
    worker.wait_idle(10.0)
    worker.close()
    return {
        "vle_frame_ms_p50": _pct(frame_ms, 50),
        "vle_frame_ms_p95": _pct(frame_ms, 95),
        "vle_crop_ms_p50": _pct(crop_ms, 50),
        "vle_crop_ms_p95": _pct(crop_ms, 95),
        "vle_frames_dropped_at_10hz": worker.dropped,
        "vle_frames_offered_at_10hz": worker.offered,
        "vle_objects_per_frame_mean": round(float(np.mean(n_objects)), 2),
        "vle_model": captioner.model_version,
        "vle_threads": settings.threads,
    }


def add_arguments(ap: argparse.ArgumentParser) -> None:
    """The ``bench`` subcommand's options."""
    ap.add_argument("--quick", action="store_true", help="fewer repetitions, a 3 s stream")


def run(args: argparse.Namespace) -> int:
    """``llmland-vle bench``: the figures as one JSON object on stdout."""
    logging.basicConfig(level=logging.WARNING)
    sys.stdout.write(json.dumps(run_bench(quick=args.quick)) + "\n")
    return 0
