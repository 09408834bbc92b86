"""The VLE's one door to the simulator: seeded worlds rendered for training data and benchmarks.

The dependency runs one way: ``llmland_vle.training`` and ``llmland_vle.bench`` → this module →
``llmland_sim`` (installed with the ``train`` extra). The service (``main`` serve,
:mod:`.service`, :mod:`.pipeline`, the backends) never imports it, and the simulator never
imports the VLE; a test checks the first.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING

import numpy as np
from llmland_schemas.messages import WORLD_NAMES

if TYPE_CHECKING:
    from llmland_sim.camera import RgbdCamera
    from llmland_sim.world import World

#: Benchmark frames: the seed of every world, the end height (m) above the target, the yaw sway (rad).
BENCH_SEED = 7
BENCH_END_HEIGHT_M = 2.0
BENCH_YAW_SWAY_RAD = 0.4
#: Benchmark frames: actors move this long (s) between two frames.
BENCH_ACTOR_STEP_S = 0.2


@contextmanager
def world_scene(
    name: str, seed: int, *, renderer: str, n_pedestrians: int | None = None
) -> Iterator[tuple[World, RgbdCamera]]:
    """World ``name`` built from ``seed`` in a fresh headless pybullet client, and a camera in it."""
    import pybullet as p
    from llmland_sim.camera import RgbdCamera
    from llmland_sim.world import build_world

    client = p.connect(p.DIRECT)
    try:
        world = build_world(client, name, seed, n_pedestrians=n_pedestrians, renderer=renderer)
        yield world, RgbdCamera(client, renderer=renderer)
    finally:
        p.disconnect(client)


def approach_frames(n: int) -> list[bytes]:
    """``n`` encoded camera frames from the three worlds, along the drone's approach, looking around a little."""
    import pybullet as p
    from llmland_schemas import MissionGoal
    from llmland_sim.settings import SimSettings
    from llmland_sim.simulation import Simulation

    frames: list[bytes] = []
    for w, world in enumerate(WORLD_NAMES):
        sim = Simulation(SimSettings())
        try:
            sim.reset(MissionGoal(episode_id=f"vle-bench-{world}", world=world, seed=BENCH_SEED))  # type: ignore[arg-type]
            assert sim.world is not None and sim.quad is not None
            start, target = sim.quad_start_m, sim.world.target_m
            m = (n - len(frames)) // (len(WORLD_NAMES) - w)
            for k in range(m):
                a = k / max(m, 1)
                pos = (1 - a) * start + a * (target + np.array([0.0, 0.0, BENCH_END_HEIGHT_M]))
                yaw = math.atan2(target[1] - start[1], target[0] - start[0]) + BENCH_YAW_SWAY_RAD * math.sin(k)
                quat = p.getQuaternionFromEuler([0, 0, yaw])
                p.resetBasePositionAndOrientation(sim.quad.body_id, pos.tolist(), quat, physicsClientId=sim.client)
                sim.world.step_actors(BENCH_ACTOR_STEP_S)
                frames.append(sim.camera_frame())
        finally:
            sim.close()
    return frames
