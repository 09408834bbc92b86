"""``llmland ceiling``: the planner's own gate on the people's true states, per seed."""

from __future__ import annotations

import json
import os
import subprocess

from .conftest import BIN, REPO


def _ceiling(*args: str, env: dict[str, str] | None = None) -> dict:
    proc = subprocess.run([str(BIN / "llmland"), "ceiling", "--json", *args], capture_output=True, text=True,
                          timeout=300, cwd=REPO, env={**os.environ, **(env or {})})
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout)


def test_the_gate_opens_on_open_ground_and_never_when_people_could_run_anywhere() -> None:
    out = _ceiling("--worlds", "open_field", "--seeds", "1-2")
    assert out["open_field"]["seeds"] == 2 and out["gate_duration_s"] > 0
    assert out["open_field"]["gate_opens"] == 2, out  # one or two walkers on a wide field
    # the gate reads the planner's motion bounds: people who could cover 100 m in a descent are never far enough
    fast = _ceiling("--worlds", "open_field", "--seeds", "1-2", env={"LLMLAND_PLANNER_HUMAN_MAX_SPEED_MPS": "50",
                                                                      "LLMLAND_PLANNER_HUMAN_STEP_SPEED_MPS": "50"})
    assert fast["open_field"]["gate_opens"] == 0 and fast["open_field"]["never_opens"] == [1, 2], fast
