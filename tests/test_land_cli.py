"""`llmland land` end to end: sim and pilot as separate processes over real Zenoh."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from .conftest import BIN, run_cli

pytestmark = pytest.mark.integration


def test_land_open_field_reference_writes_verified_rrd(tmp_path: Path) -> None:
    rrd = tmp_path / "landing.rrd"
    proc = run_cli("land", "--world", "open_field", "--seed", "1", "--rrd", str(rrd))
    assert proc.returncode == 0, proc.stderr[-3000:]
    result = json.loads(proc.stdout)
    assert result["success"] is True, result
    assert result["outcome"] == "landed"
    assert result["touchdown_error_m"] < 0.5
    assert result["deadline_misses"] <= 0.05 * result["control_ticks"]  # counted; rare under load
    assert result["control_ticks"] > 50
    assert set(result["min_person_distance_m"]) and all(d >= 1.0 for d in result["min_person_distance_m"].values())
    assert rrd.exists() and rrd.stat().st_size > 10_000
    rerun = shutil.which("rerun", path=str(BIN)) or str(Path(sys.executable).parent / "rerun")
    verify = subprocess.run([rerun, "rrd", "verify", str(rrd)], capture_output=True, text=True, timeout=120)
    assert verify.returncode == 0, verify.stdout + verify.stderr


def test_land_realtime_clock(tmp_path: Path) -> None:
    proc = run_cli("land", "--world", "open_field", "--seed", "2", "--method", "reference", "--clock", "realtime",
                   "--timeout", "40")
    assert proc.returncode == 0, proc.stderr[-3000:]
    result = json.loads(proc.stdout)
    assert result["clock"] == "realtime"
    assert result["outcome"] in ("landed", "off_target", "close_call"), result
    # paced to the wall clock: never much faster than real time
    assert result["wall_time_s"] >= 0.8 * result["sim_time_s"]
