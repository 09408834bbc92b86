"""`llmland experiment` end to end through real processes: the folder, reproducibility, --resume."""

from __future__ import annotations

import contextlib
import csv
import json
import signal
import subprocess
import time
from pathlib import Path

import psutil
import pytest

from llmland.experiment import code_version
from llmland.experiment.runner import WALL_COLUMNS

from .conftest import BIN, REPO, run_cli

pytestmark = pytest.mark.integration

#: two seeds, short episodes, the real pipeline with a modelled latency (reproducible)
ARGS = ["experiment", "exp1", "--trials", "2", "--seed-base", "3", "--methods", "llm-land",
        "--latency-model", "fixed:200", "--timeout", "20"]


def _interruptible() -> None:
    """``preexec_fn``: the CLI gets Ctrl-C's default action whatever the test runner's is. A shell
    runs background jobs with SIGINT ignored, the child inherits that, and Python then installs no
    handler: the CLI never sees the test's SIGINT (the suite started with ``nohup … &``)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _exit_code(proc: subprocess.Popen[bytes], stderr_path: Path, services: list[psutil.Process],
               timeout_s: float = 30.0) -> int:
    """``proc``'s exit code; if it has not exited within ``timeout_s``, fail with every thread's
    stack (the CLI dumps them on SIGUSR1) and the tail of its stderr: what it was waiting on. The
    CLI and its ``services`` are killed then, so a failure leaves nothing running."""
    try:
        return proc.wait(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        proc.send_signal(signal.SIGUSR1)
        time.sleep(2.0)
        proc.kill()
        proc.wait()
        for service in services:
            with contextlib.suppress(psutil.NoSuchProcess):
                service.kill()
        pytest.fail(f"the CLI did not exit within {timeout_s:.0f} s; its stderr ends:\n"
                    + stderr_path.read_text(errors="replace")[-8000:])


def _start_experiment(tmp_path: Path, args: list[str], n_services: int
                      ) -> tuple[subprocess.Popen[bytes], list[psutil.Process], Path]:
    """``llmland experiment exp1 ARGS --out TMP/out`` with its stderr in ``TMP/cli.stderr``; waits
    (at most ``STARTUP_WAIT_S``) until it has ``n_services`` child processes, and returns the CLI,
    those it has by then and the stderr's path."""
    stderr_path = tmp_path / "cli.stderr"
    with stderr_path.open("wb") as err:  # Popen holds its own copy of the descriptor
        proc = subprocess.Popen([str(BIN / "llmland"), "experiment", "exp1", *args, "--out", str(tmp_path / "out")],
                                cwd=REPO, stdout=subprocess.DEVNULL, stderr=err, preexec_fn=_interruptible)
    parent = psutil.Process(proc.pid)
    deadline = time.monotonic() + STARTUP_WAIT_S
    services: list[psutil.Process] = []
    while time.monotonic() < deadline and len(services) < n_services:
        services = parent.children(recursive=True)
        time.sleep(0.2)
    return proc, services, stderr_path


def _rows_without_wall_columns(path: Path) -> list[dict[str, str]]:
    with path.open(newline="") as fh:
        return [{k: v for k, v in row.items() if k not in WALL_COLUMNS} for row in csv.DictReader(fh)]


def test_two_trial_experiment_writes_its_folder_and_replays_identically(tmp_path: Path) -> None:
    first, second = tmp_path / "first", tmp_path / "second"
    proc = run_cli(*ARGS, "--out", str(first), timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    summary = json.loads((first / "summary.json").read_text())
    assert summary["experiment"] == "exp1" and summary["latency_model"] == "fixed:200"
    (row,) = summary["rows"]
    assert set(row) == {"world", "method", "n", "success_rate", "close_calls", "collisions", "timeouts",
                        "time_to_land_s_median", "closest_person_m_p5", "spec_latency_ms_mean"}
    assert row["n"] == 2 and row["world"] == "open_field" and row["method"] == "llm-land"
    assert row["spec_latency_ms_mean"] == pytest.approx(200.0)
    meta = json.loads((first / "meta.json").read_text())
    assert meta["code"] == code_version() and meta["code"] in (first / "results.md").read_text()
    md = (first / "results.md").read_text()
    assert "96.0 %" in md and "llm-land" in md and "seeds: 3–4" in md  # the paper's number beside ours
    for png in ("success.png", "closest_person.png", "spec_latency.png", "trajectory_llm-land.png"):
        assert (first / png).stat().st_size > 5_000, png
    rows = _rows_without_wall_columns(first / "trials.csv")
    assert [r["seed"] for r in rows] == ["3", "4"]
    assert all(int(r["perception_requests"]) > 10 and r["latency_model"] == "fixed:200" for r in rows)

    # again, the two trials side by side: each its own stack and bus port, paced by the modelled
    # latency, so neither the other job's load nor the order of finishing changes an episode
    proc = run_cli(*ARGS, "--out", str(second), "--jobs", "2", timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    again = sorted(_rows_without_wall_columns(second / "trials.csv"), key=lambda r: int(r["seed"]))
    assert again == rows  # same seeds + latency model (rows are written as trials end)

    before = (first / "trials.csv").read_text()
    proc = run_cli(*ARGS, "--out", str(first), "--resume", timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert (first / "trials.csv").read_text() == before  # nothing flown again


def test_the_code_version_names_the_commit_and_a_dirty_tree(tmp_path: Path) -> None:
    """meta.json names what was flown: the commit, ``-dirty`` with uncommitted changes to tracked
    files, ``unknown`` outside a git checkout."""
    assert code_version(tmp_path) == "unknown"
    git = ["git", "-C", str(tmp_path), "-c", "user.name=t", "-c", "user.email=t@t"]
    subprocess.run([*git, "init", "-q"], check=True)
    (tmp_path / "a.txt").write_text("a\n")
    subprocess.run([*git, "add", "a.txt"], check=True)
    subprocess.run([*git, "commit", "-q", "-m", "a"], check=True)
    head = subprocess.run([*git, "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                          check=True).stdout.strip()
    assert code_version(tmp_path) == head
    (tmp_path / "b.txt").write_text("untracked\n")
    assert code_version(tmp_path) == head
    (tmp_path / "a.txt").write_text("changed\n")
    assert code_version(tmp_path) == f"{head}-dirty"


def test_interrupted_experiment_leaves_no_service_running(tmp_path: Path) -> None:
    """SIGTERM (or Ctrl-C) mid-trial stops every service of every job; --resume flies what is left."""
    args = ["--trials", "2", "--methods", "baseline", "--jobs", "2"]
    proc, services, stderr_path = _start_experiment(tmp_path, args, 4)  # two jobs × (sim, planner)
    assert len(services) >= 4, "the stacks did not start"
    proc.send_signal(signal.SIGTERM)
    assert _exit_code(proc, stderr_path, services) != 0
    gone, alive = psutil.wait_procs(services, timeout=10)
    assert not alive, [p.pid for p in alive]
    if (tmp_path / "out" / "trials.csv").exists():  # a trial that ended before the signal is kept, the rest is not
        assert len(_rows_without_wall_columns(tmp_path / "out" / "trials.csv")) < 2


def test_ctrl_c_twice_while_the_stack_starts_leaves_no_service_running(tmp_path: Path) -> None:
    """One job, the pipeline stack still starting (the reasoner loads for ~12 s): Ctrl-C, and
    Ctrl-C again, stop every service at once. Before, the first interrupted ``Thread.join`` marked
    the running job as stopped (CPython 3.11), the CLI exited at once and all five processes
    (four services and the LLM worker) were orphaned."""
    # sim, planner, vle, reasoner + LLM worker
    proc, services, stderr_path = _start_experiment(tmp_path, ["--trials", "1", "--methods", "llm-land"], 5)
    assert len(services) >= 5, "the stack did not start"
    proc.send_signal(signal.SIGINT)
    time.sleep(0.3)
    proc.send_signal(signal.SIGINT)
    assert _exit_code(proc, stderr_path, services) != 0
    gone, alive = psutil.wait_procs(services, timeout=10)
    assert not alive, [(p.pid, p.name()) for p in alive]


#: wall seconds the stacks get to start
STARTUP_WAIT_S = 60.0
