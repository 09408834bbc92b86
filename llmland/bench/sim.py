"""Simulator speed: physics steps/s headless without camera, real-time factor with camera."""

from __future__ import annotations

import time

import numpy as np
from llmland_schemas import MissionGoal
from llmland_sim.settings import SimSettings
from llmland_sim.simulation import Simulation
from llmland_sim.vehicle import ReferencePositionController

from . import percentiles


def _fly(sim: Simulation, seconds: float, camera_hz: float) -> tuple[float, list[float]]:
    """Hover the vehicle for ``seconds`` of sim time; returns (wall s, camera ms list)."""
    assert sim.quad is not None
    ctrl = ReferencePositionController(sim.params)
    hold = sim.quad.state().pos_m.copy()
    cam_ms: list[float] = []
    next_cam = 0.0
    t0 = time.perf_counter()
    while sim.t_s < seconds:
        if camera_hz > 0 and sim.t_s + 1e-9 >= next_cam:
            c0 = time.perf_counter()
            sim.camera_frame()
            cam_ms.append((time.perf_counter() - c0) * 1e3)
            next_cam += 1.0 / camera_hz
        st = sim.quad.state()
        rates, thrust = ctrl.update(st.pos_m, st.vel_mps, st.quat_xyzw, hold)
        sim.quad.set_command(rates, thrust)
        sim.step()
    return time.perf_counter() - t0, cam_ms


def run_sim(quick: bool = False) -> dict[str, float]:
    seconds = 5.0 if quick else 20.0
    mission = MissionGoal(episode_id="bench", world="open_field", seed=1, timeout_s=1e3)
    out: dict[str, float] = {}
    # 1. headless, no camera: raw physics + vehicle + actors + scoring throughput
    sim = Simulation(SimSettings(camera_hz=0))
    sim.reset(mission)
    wall, _ = _fly(sim, seconds, 0.0)
    steps = sim.seq * sim.settings.substeps
    out["sim_physics_steps_per_s"] = round(steps / wall, 0)
    out["sim_rtf_no_camera"] = round(seconds / wall, 1)
    sim.close()
    # 2. with the RGB-D camera at 5 Hz (384x384 by default)
    sim = Simulation(SimSettings(camera_hz=5.0))
    sim.reset(mission)
    wall, cam_ms = _fly(sim, seconds, 5.0)
    out["sim_rtf_camera_5hz"] = round(seconds / wall, 1)
    out.update(percentiles(cam_ms, "sim_camera_frame_ms"))
    out["sim_camera_renderer"] = sim.camera.renderer if sim.camera is not None else "none"  # type: ignore[assignment]
    out["sim_physics_hz"] = float(sim.settings.physics_hz)
    sim.close()
    return {k: (float(v) if isinstance(v, np.floating) else v) for k, v in out.items()}
