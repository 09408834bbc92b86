"""Closed loop over real processes: a person standing by the pad starts walking to it as soon as
the final descent starts (within the stated bounds: a first step, 2 m/s², up to 1.6 m/s). The
hard-limit gate let the descent start only because they could not reach the vehicle before
touchdown: the drone finishes (or climbs out), never within 1 m of them."""

from __future__ import annotations

import json

import pytest

from .conftest import run_cli

pytestmark = pytest.mark.integration


@pytest.mark.parametrize(("seed", "specs"), [(1, "oracle"), (2, "oracle"), (3, "pipeline")])
def test_a_person_walking_in_during_the_descent_never_comes_within_1_m(seed: int, specs: str) -> None:
    proc = run_cli("land", "--method", "llm-land", "--specs", specs, "--seed", str(seed), "--timeout", "40",
                   "--scenario", "walk-in:5.5,1.6", timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    r = json.loads(proc.stdout)
    assert r["collisions"] == [] and r["close_calls"] == 0, r
    assert min(r["min_person_distance_m"].values()) >= 1.0, r
    assert r["outcome"] in ("landed", "timeout"), r  # finished, or climbed out and held
