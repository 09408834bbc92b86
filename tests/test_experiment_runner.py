"""The experiment runner's bookkeeping with stand-in stacks (no processes): every trial a job
takes ends as a row, whatever the fault; error rows stay out of the figures, make the command
fail and are flown again by ``--resume``."""

from __future__ import annotations

import csv
import faulthandler
import json
import signal
import time
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


#: stand-in stacks opened so far, and how many more closes raise (a service that will not die)
_OPENED: list[int] = []
_FAILING_CLOSES: list[int] = [0]


@contextmanager
def _fake_stack(*_: object, **__: object) -> Iterator[Any]:
    _OPENED.append(1)
    yield SimpleNamespace(bus=None, runner=SimpleNamespace(drone_id="d0", abort=lambda: None))
    if _FAILING_CLOSES[0] > 0:
        _FAILING_CLOSES[0] -= 1
        raise OSError("a service did not stop")


def _landed(trial: Trial) -> dict[str, Any]:
    """A landing's row; like the real ones, no latency model where nothing is perceived."""
    perceives = trial.method not in ("baseline", "conservative")
    row: dict[str, Any] = {c: "" for c in COLUMNS}
    row.update({"world": trial.world, "method": trial.method, "variant": trial.variant, "seed": trial.seed,
                "outcome": "landed", "success": 1, "time_to_land_s": "20.0", "closest_person_m": "5.0",
                "close_calls": "0", "spec_latency_ms_mean": "50.0",
                "latency_model": (trial.latency_model or "measured") if perceives else ""})
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

    _OPENED.clear()
    _FAILING_CLOSES[0] = 0
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


def test_a_retry_flies_on_a_fresh_stack_and_a_stack_that_will_not_stop_loses_nothing(
        tmp_path: Path, stand_ins: dict[int, int]) -> None:
    stand_ins.update({2: 1, 3: 2})
    _FAILING_CLOSES[0] = 3  # every failed trial's stack, and the last one, raise when closed
    trials = [Trial("open_field", "llm-land", s) for s in range(1, 6)]
    ExperimentRunner(trials, tmp_path, jobs=1).run()
    assert sorted(int(r["seed"]) for r in read_rows(tmp_path / "trials.csv")) == [1, 2, 3, 4, 5]
    assert len(_OPENED) == 4  # the first, then a fresh one after each of the three failures


def test_errored_trials_are_named_left_out_of_the_figures_and_flown_again_on_resume(
        tmp_path: Path, stand_ins: dict[int, int]) -> None:
    stand_ins[2] = 2
    summary = experiment.run_experiment("exp1", tmp_path, trials=3, methods=["llm-land"])
    assert summary["errored_trials"] == {"open_field-llm-land-s2": "KeyError: 'a bug, not a stack fault'"}
    assert summary["missing_trials"] == []
    (row,) = summary["rows"]
    assert row["n"] == 2 and row["success_rate"] == 1.0  # the error is not counted as a failed landing
    assert "Incomplete: 1 trial(s)" in (tmp_path / "results.md").read_text()

    kept = [r for r in read_rows(tmp_path / "trials.csv") if r["outcome"] != "error"]
    summary = experiment.run_experiment("exp1", tmp_path, trials=3, methods=["llm-land"], resume=True)
    assert summary["errored_trials"] == {} and summary["rows"][0]["n"] == 3
    rows = read_rows(tmp_path / "trials.csv")
    assert sorted(int(r["seed"]) for r in rows) == [1, 2, 3]  # no error row left
    assert rows[: len(kept)] == kept  # the finished rows untouched, in their order
    assert (tmp_path / "trials.csv").read_text().splitlines()[0] == ",".join(COLUMNS)
    assert not (tmp_path / "trials.csv.tmp").exists()


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


def test_resume_refuses_rows_flown_with_another_latency_model(tmp_path: Path, stand_ins: dict[int, int]) -> None:
    experiment.run_experiment("exp1", tmp_path, trials=2, methods=["llm-land"], latency_model="fixed:200")
    with pytest.raises(ValueError, match="fixed:200"):
        experiment.run_experiment("exp1", tmp_path, trials=3, methods=["llm-land"], resume=True)
    summary = experiment.run_experiment("exp1", tmp_path, trials=3, methods=["llm-land"],
                                        latency_model="fixed:200", resume=True)
    assert summary["rows"][0]["n"] == 3
    # the geometric methods perceive nothing: no latency model in their rows, any plan resumes them
    experiment.run_experiment("exp1", tmp_path / "b", trials=2, methods=["baseline"], latency_model="fixed:200")
    summary = experiment.run_experiment("exp1", tmp_path / "b", trials=2, methods=["baseline"], resume=True)
    assert summary["rows"][0]["n"] == 2


def test_resume_on_a_folder_written_with_older_columns_keeps_rows_in_line(tmp_path: Path,
                                                                           stand_ins: dict[int, int]) -> None:
    """A folder from before a column was added (``commands_missing``): its rows are rewritten with
    today's header before new ones are appended, so every row reads back under the right names."""
    experiment.run_experiment("exp1", tmp_path, trials=2, methods=["llm-land"])
    path = tmp_path / "trials.csv"
    old = [c for c in COLUMNS if c != "commands_missing"]
    rows = read_rows(path)
    with path.open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=old, extrasaction="ignore")
        w.writeheader()
        w.writerows(rows)
    summary = experiment.run_experiment("exp1", tmp_path, trials=3, methods=["llm-land"], resume=True)
    assert summary["rows"][0]["n"] == 3
    assert path.read_text().splitlines()[0] == ",".join(COLUMNS)
    assert [r["outcome"] for r in read_rows(path)] == ["landed"] * 3
    assert [r["latency_model"] for r in read_rows(path)] == ["measured"] * 3


def test_resume_flies_a_row_cut_short_again_and_names_a_file_that_is_no_trials_table(
        tmp_path: Path, stand_ins: dict[int, int]) -> None:
    """A run killed while writing a row leaves it cut short: --resume counted it as done, then
    failed on it. It is now left out (and flown again); a file that is no trials table is named."""
    experiment.run_experiment("exp1", tmp_path, trials=2, methods=["llm-land"])
    path = tmp_path / "trials.csv"
    text = path.read_text()
    path.write_text(text[: text.rindex("\n", 0, len(text) - 1) + 1] + text.splitlines()[-1][:25])
    assert [int(r["seed"]) for r in read_rows(path)] == [1]
    summary = experiment.run_experiment("exp1", tmp_path, trials=2, methods=["llm-land"], resume=True)
    assert summary["rows"][0]["n"] == 2
    assert sorted(int(r["seed"]) for r in read_rows(path)) == [1, 2]
    text = path.read_text()
    path.write_text(text[:-3])  # cut inside the last field (the episode id): the fields are all there
    assert sorted(int(r["seed"]) for r in read_rows(path)) == [1]
    experiment.run_experiment("exp1", tmp_path, trials=2, methods=["llm-land"], resume=True)
    assert sorted(int(r["seed"]) for r in read_rows(path)) == [1, 2]  # the next row not glued onto it
    for bad, says in ((b"a,b\n1,2\n", "not a trials table"), (b"\xff\xfe\x00", "not a readable trials table")):
        path.write_bytes(bad)
        with pytest.raises(ValueError, match=says) as err:
            read_rows(path)
        assert str(path) in str(err.value)


def test_an_earlier_run_is_kept_unless_resumed_or_overwritten(tmp_path: Path, stand_ins: dict[int, int]) -> None:
    """A folder holding an earlier run is refused without --resume or --overwrite (a forgotten
    --resume deleted its trials.csv and left its plots and traces beside the new run's); with
    --overwrite the earlier run's files go and the folder's other files stay."""
    experiment.run_experiment("exp1", tmp_path, trials=2, methods=["llm-land"])
    (tmp_path / "traces").mkdir(exist_ok=True)
    (tmp_path / "traces" / "old.json").write_text("{}")
    (tmp_path / "notes.txt").write_text("mine")
    (tmp_path / "site_photo.png").write_bytes(b"mine")  # a user's own picture is no plot (review)
    with pytest.raises(ValueError, match="--resume to finish it, or --overwrite"):
        experiment.run_experiment("exp1", tmp_path, trials=1, methods=["llm-land"])
    assert len(read_rows(tmp_path / "trials.csv")) == 2  # untouched
    summary = experiment.run_experiment("exp1", tmp_path, trials=1, methods=["llm-land"], overwrite=True)
    assert summary["rows"][0]["n"] == 1 and len(read_rows(tmp_path / "trials.csv")) == 1
    assert not (tmp_path / "traces" / "old.json").exists() and (tmp_path / "notes.txt").read_text() == "mine"
    assert (tmp_path / "site_photo.png").read_bytes() == b"mine"


def test_without_a_terminal_the_running_counts_are_log_lines(tmp_path: Path, stand_ins: dict[int, int],
                                                             caplog: pytest.LogCaptureFixture) -> None:
    """No progress bar when stderr is no terminal (its redraws prefixed every captured log line);
    its running success counts come as a log line per trial instead."""
    caplog.set_level("INFO", logger="llmland.experiment.runner")
    trials = [Trial("open_field", "llm-land", s) for s in range(1, 4)]
    ExperimentRunner(trials, tmp_path, jobs=1).run()
    assert "3 of 3 trials done; succeeded: llm-land 3/3" in caplog.text


def test_an_interrupted_run_leaves_its_meta_and_a_resume_adds_to_it(
        tmp_path: Path, stand_ins: dict[int, int], monkeypatch: pytest.MonkeyPatch) -> None:
    """Ctrl-C left no meta.json: a --resume then recorded only its own part (wall time, code) and
    its own command (a newcomer's 0.7 min for a 1.4 min experiment)."""
    real_fly = ExperimentRunner._fly

    def interrupted(self: ExperimentRunner, running: Any, tracer: Any, trial: Trial) -> dict[str, Any]:
        if trial.seed == 2:  # Ctrl-C reaches the main thread while a job flies
            signal.raise_signal(signal.SIGINT)
            time.sleep(0.5)
        return real_fly(self, running, tracer, trial)

    monkeypatch.setattr(ExperimentRunner, "_fly", interrupted)
    monkeypatch.setattr(experiment.sys, "argv", ["llmland", "experiment", "exp1", "--trials", "3"])
    with pytest.raises(KeyboardInterrupt):
        experiment.run_experiment("exp1", tmp_path, trials=3, methods=["llm-land"], machine="m")
    meta = json.loads((tmp_path / "meta.json").read_text())
    assert meta["interrupted"] is True and meta["trials"] is None and meta["code"]
    assert meta["command"] == "llmland experiment exp1 --trials 3" and meta["wall_time_s"] >= 0.4  # the sleep
    interrupted_wall = meta["wall_time_s"]
    meta["code"] = "aaa"  # as if the first part flew another version
    (tmp_path / "meta.json").write_text(json.dumps(meta))

    monkeypatch.setattr(ExperimentRunner, "_fly", real_fly)
    monkeypatch.setattr(experiment.sys, "argv", ["llmland", "experiment", "exp1", "--trials", "3", "--resume"])
    experiment.run_experiment("exp1", tmp_path, trials=3, methods=["llm-land"], resume=True, machine="m")
    meta = json.loads((tmp_path / "meta.json").read_text())
    assert meta["command"] == "llmland experiment exp1 --trials 3"  # the first command, not the resume
    assert meta["resumed_with"] == ["llmland experiment exp1 --trials 3 --resume"]
    assert meta["trials"] == 3 and "interrupted" not in meta
    assert meta["wall_time_s"] >= interrupted_wall and meta["code"].startswith("aaa then ")
    assert experiment._code_parts("aaa then bbb", "bbb") == "aaa then bbb"  # a repeat named once
    assert "resumed with `llmland experiment exp1 --trials 3 --resume`" in (tmp_path / "results.md").read_text()
