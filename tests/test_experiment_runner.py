"""The experiment runner's bookkeeping with stand-in stacks (no processes): every trial a job
takes ends as a row, whatever the fault; error rows stay out of the figures, make the command
fail and are flown again by ``--resume``."""

from __future__ import annotations

import faulthandler
import signal
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pytest

import llmland.experiment as experiment
from llmland.experiment import runner as runner_mod
from llmland.experiment.plan import Trial
from llmland.experiment.runner import COLUMNS, ExperimentRunner, read_rows


class _Tracer:
    def __init__(self, *_: object) -> None:
        pass


@contextmanager
def _fake_stack(*_: object, **__: object) -> Iterator[Any]:
    yield SimpleNamespace(bus=None, runner=SimpleNamespace(drone_id="d0", abort=lambda: None))


def _landed(trial: Trial) -> dict[str, Any]:
    row: dict[str, Any] = {c: "" for c in COLUMNS}
    row.update({"world": trial.world, "method": trial.method, "variant": trial.variant, "seed": trial.seed,
                "outcome": "landed", "success": 1, "time_to_land_s": "20.0", "closest_person_m": "5.0",
                "close_calls": "0", "spec_latency_ms_mean": "50.0"})
    return row


@pytest.fixture()
def stand_ins(monkeypatch: pytest.MonkeyPatch) -> dict[int, int]:
    """Stacks that open instantly; a trial's flight raises for the seeds in the returned dict
    (seed → how many more attempts fail), else lands."""
    failing: dict[int, int] = {}

    def fly(self: ExperimentRunner, running: Any, tracer: Any, trial: Trial) -> dict[str, Any]:
        if failing.get(trial.seed, 0) > 0:
            failing[trial.seed] -= 1
            raise KeyError("a bug, not a stack fault")  # not one of the expected faults
        return _landed(trial)

    monkeypatch.setattr(runner_mod, "open_stack", _fake_stack)
    monkeypatch.setattr(runner_mod, "TraceRecorder", _Tracer)
    monkeypatch.setattr(ExperimentRunner, "_fly", fly)
    return failing


@pytest.mark.parametrize("jobs", [1, 2])
def test_an_unexpected_fault_is_retried_then_recorded_and_the_job_flies_on(
        tmp_path: Path, stand_ins: dict[int, int], jobs: int) -> None:
    stand_ins.update({2: 1, 3: 2})  # seed 2 fails once (retried, lands); seed 3 fails twice
    trials = [Trial("open_field", "llm-land", s) for s in range(1, 6)]
    ExperimentRunner(trials, tmp_path, jobs=jobs).run()
    rows = {int(r["seed"]): r["outcome"] for r in read_rows(tmp_path / "trials.csv")}
    assert rows == {1: "landed", 2: "landed", 3: "error", 4: "landed", 5: "landed"}


def test_errored_trials_are_named_left_out_of_the_figures_and_flown_again_on_resume(
        tmp_path: Path, stand_ins: dict[int, int]) -> None:
    stand_ins[2] = 2
    summary = experiment.run_experiment("exp1", tmp_path, trials=3, methods=["llm-land"])
    assert summary["errored_trials"] == {"open_field-llm-land-s2": "KeyError: 'a bug, not a stack fault'"}
    assert summary["missing_trials"] == []
    (row,) = summary["rows"]
    assert row["n"] == 2 and row["success_rate"] == 1.0  # the error is not counted as a failed landing
    assert "Incomplete: 1 trial(s)" in (tmp_path / "results.md").read_text()

    summary = experiment.run_experiment("exp1", tmp_path, trials=3, methods=["llm-land"], resume=True)
    assert summary["errored_trials"] == {} and summary["rows"][0]["n"] == 3
    assert sorted(int(r["seed"]) for r in read_rows(tmp_path / "trials.csv")) == [1, 2, 3]  # no error row left


def test_a_trial_without_a_row_is_named_missing(tmp_path: Path, stand_ins: dict[int, int],
                                                monkeypatch: pytest.MonkeyPatch) -> None:
    """Whatever loses a row (here: a recorder that drops one), the summary says so."""
    record = ExperimentRunner._record

    def lossy(self: ExperimentRunner, row: dict[str, Any]) -> None:
        if int(row["seed"]) != 2:
            record(self, row)

    monkeypatch.setattr(ExperimentRunner, "_record", lossy)
    summary = experiment.run_experiment("exp1", tmp_path, trials=3, methods=["llm-land"])
    assert summary["missing_trials"] == ["open_field-llm-land-s2"]
    assert summary["rows"][0]["n"] == 2


def test_the_command_fails_when_a_trial_errored(tmp_path: Path, stand_ins: dict[int, int],
                                                monkeypatch: pytest.MonkeyPatch) -> None:
    """`llmland experiment` writes its folder and then exits 1, naming the trials to fly again."""
    from llmland import cli

    monkeypatch.setattr(signal, "signal", lambda *_: None)  # main() installs handlers; not in a test
    monkeypatch.setattr(faulthandler, "register", lambda *_, **__: None)
    stand_ins[1] = 2
    with pytest.raises(SystemExit) as exit_:
        cli.main(["experiment", "exp1", "--trials", "2", "--methods", "llm-land", "--out", str(tmp_path)])
    assert exit_.value.code == 1
    assert (tmp_path / "results.md").exists()
    with pytest.raises(SystemExit) as exit_:
        cli.main(["experiment", "exp1", "--trials", "2", "--methods", "llm-land", "--out", str(tmp_path),
                  "--resume"])
    assert exit_.value.code == 0
