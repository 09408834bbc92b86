"""`llmland bench ... --json` prints the figures the issues name."""

from __future__ import annotations

import json

import pytest

from .conftest import run_cli

pytestmark = pytest.mark.integration


def test_bench_bus_json() -> None:
    proc = run_cli("bench", "bus", "--json", "--quick")
    assert proc.returncode == 0, proc.stderr[-2000:]
    fig = json.loads(proc.stdout)
    assert fig["bus_state_rtt_us_p50"] > 0 and fig["bus_state_rtt_us_p95"] >= fig["bus_state_rtt_us_p50"]
    assert fig["bus_lost"] == 0


def test_bench_sim_json() -> None:
    proc = run_cli("bench", "sim", "--json", "--quick")
    assert proc.returncode == 0, proc.stderr[-2000:]
    fig = json.loads(proc.stdout)
    for k in ("sim_physics_steps_per_s", "sim_rtf_no_camera", "sim_rtf_camera_5hz", "sim_camera_frame_ms_p50"):
        assert fig[k] > 0, k


def test_bench_startup_json() -> None:
    proc = run_cli("bench", "startup", "--json", "--quick")
    assert proc.returncode == 0, proc.stderr[-2000:]
    fig = json.loads(proc.stdout)
    each = [fig[f"startup_{n}_s_p50"] for n in ("sim", "planner", "vle", "reasoner")]
    assert all(s > 0 for s in each) and fig["startup_all_s_p50"] == max(each)
