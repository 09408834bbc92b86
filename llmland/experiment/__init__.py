"""``llmland experiment exp1|exp2|exp3``: the paper's experiments (DESIGN §8) as one command.

:func:`run_experiment` builds the trials (:mod:`.plan`), flies them on parallel stacks
(:mod:`.runner`, one CSV row per trial as it ends, resumable), then writes ``summary.json``
and ``results.md`` (:mod:`.report`) and the PNG plots (:mod:`.plots`).
"""

from __future__ import annotations

import json
import logging
import os
import shlex
import shutil
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from .plan import EXPERIMENTS, Trial, build_trials
from .plots import PLOT_PATTERNS, write_plots
from .report import summarize, write_report
from .runner import ExperimentRunner, read_rows, row_key

log = logging.getLogger(__name__)

__all__ = ["EXPERIMENTS", "run_experiment"]


#: the checkout this package runs from (``llmland/experiment`` → the repository root)
REPO_ROOT = Path(__file__).resolve().parents[2]
#: seconds a git query for the code version may take
GIT_TIMEOUT_S = 5.0


def code_version(root: Path = REPO_ROOT) -> str:
    """The commit the experiment flies (``git rev-parse --short HEAD``), with ``-dirty`` when
    tracked files differ from it; ``"unknown"`` outside a git checkout (an installed wheel) or
    without git. Read when the run starts: the stacks load the code then."""
    try:
        head = subprocess.run(["git", "-C", str(root), "rev-parse", "--short", "HEAD"], capture_output=True,
                              text=True, timeout=GIT_TIMEOUT_S, check=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(root), "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True, timeout=GIT_TIMEOUT_S, check=True).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return "unknown"
    return f"{head}-dirty" if dirty else head or "unknown"


def _check_resumable(csv_path: Path, todo: list[Trial], default_lm: str) -> None:
    """``--resume`` only where the rows already there were flown with this plan's latency model:
    a trial's key names world, method, variant and seed, not how it was flown. ValueError names
    the first trial that differs."""
    expected = {t.key: t.latency_model or default_lm for t in todo}
    for row in read_rows(csv_path):
        want = expected.get(row_key(row))
        flown = row["latency_model"]  # "" where nothing was perceived (the geometric methods)
        if want is not None and row["outcome"] != "error" and flown and flown != want:
            raise ValueError(f"{csv_path} holds {row['world']} {row['method']} seed {row['seed']} flown with "
                             f"latency model {row['latency_model']!r}, this run asks for {want!r}: resume with "
                             "the same options or use another --out")


#: What a run writes into its folder: an earlier run's, removed by ``overwrite`` (nothing else is).
RUN_FILES = ("trials.csv", "summary.json", "results.md", "meta.json")
RUN_FOLDERS = ("traces", "rrd", "logs")


def clear_run(out: Path) -> None:
    """Remove an earlier run's files from ``out`` (:data:`RUN_FILES`, :data:`RUN_FOLDERS`, its
    plots: :data:`~.plots.PLOT_PATTERNS`); anything else in the folder stays."""
    for name in RUN_FILES:
        (out / name).unlink(missing_ok=True)
    for pattern in PLOT_PATTERNS:
        for png in out.glob(pattern):
            png.unlink()
    for name in RUN_FOLDERS:
        shutil.rmtree(out / name, ignore_errors=True)


def _write_meta(path: Path, previous: dict[str, Any], *, code: str, wall_s: float, jobs: int, machine: str,
                seeds: str, trials: int | None) -> dict[str, Any]:
    """Write ``meta.json`` (and return it): the first command, the commands that resumed it, the code
    each part flew (both named when they differ), the wall time of every part so far; ``trials``
    None marks a run that was interrupted (its rows are in trials.csv; ``--resume`` finishes it)."""
    command = shlex.join(["llmland", *sys.argv[1:]])
    meta: dict[str, Any] = {
        "command": previous.get("command", command),
        "seeds": seeds,
        "trials": trials,
        "machine": machine,
        # a resumed run may fly two versions: both are named
        "code": _code_parts(str(previous.get("code", code)), code),
        "jobs": jobs,
        "wall_time_s": round(float(previous.get("wall_time_s", 0.0)) + wall_s, 1),
    }
    resumed = list(previous.get("resumed_with", []))
    if previous:
        resumed.append(command)
    if resumed:
        meta["resumed_with"] = resumed
    if trials is None:
        meta["interrupted"] = True
    tmp = path.with_suffix(".json.tmp")  # a second Ctrl-C mid-write must not leave a cut file
    tmp.write_text(json.dumps(meta, indent=2) + "\n")
    os.replace(tmp, path)
    return meta


def _code_parts(previous: str, code: str) -> str:
    """The versions the parts of a run flew, in order, a repeat named once ("a then b", not
    "a then b then b")."""
    parts = previous.split(" then ")
    return " then ".join(parts if parts[-1] == code else [*parts, code])


def _previous_meta(path: Path) -> dict[str, Any]:
    """An earlier part's ``meta.json``; ``{}`` (with a warning) where it cannot be read."""
    if not path.exists():
        return {}
    try:
        meta = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        log.warning("%s cannot be read (%s): its command, code and wall time are not carried on", path, exc)
        return {}
    return meta if isinstance(meta, dict) else {}


def run_experiment(experiment: str, out: Path, *, trials: int = 50, seed_base: int = 1,
                   methods: list[str] | None = None, worlds: list[str] | None = None,
                   latency_model: str | None = None, specs: str = "pipeline", ggufs: list[Path] | None = None,
                   jobs: int = 1, timeout_s: float = 90.0, rrd: bool = False, resume: bool = False,
                   overwrite: bool = False, log_level: str = "WARNING", machine: str = "") -> dict[str, Any]:
    """Run (or finish, with ``resume``) an experiment into ``out``; returns ``summary.json``.

    Trials whose stack failed twice (``error`` rows) and trials with no row at all are left out
    of the figures and named in ``summary["errored_trials"]`` / ``summary["missing_trials"]``;
    ``--resume`` flies both again. A folder that holds an earlier run's ``trials.csv`` is
    refused (``ValueError``) unless ``resume`` finishes that run or ``overwrite`` removes it
    (:func:`clear_run`): a forgotten ``--resume`` would have thrown away hours of trials."""
    todo = build_trials(experiment, trials=trials, seed_base=seed_base, methods=methods, worlds=worlds,
                        latency_model=latency_model, specs=specs, ggufs=ggufs)
    if (out / "trials.csv").exists() and not resume:  # after the plan is checked: a bad one clears nothing
        if not overwrite:
            raise ValueError(f"{out} holds an earlier run (trials.csv): pass --resume to finish it, or "
                             "--overwrite to remove its results, plots, traces and logs and start over")
        clear_run(out)
    default_lm = latency_model or ("fixed:50" if specs == "oracle" else "measured")
    if resume:
        _check_resumable(out / "trials.csv", todo, default_lm)
    code = code_version()
    runner = ExperimentRunner(todo, out, jobs=jobs, timeout_s=timeout_s, rrd=rrd, resume=resume,
                              log_level=log_level, label=experiment)
    if runner.skipped:
        log.info("resuming: %d of %d trials already in %s", runner.skipped, len(todo), runner.csv_path)
    meta_path = out / "meta.json"
    previous = _previous_meta(meta_path) if resume else {}
    seeds = f"{seed_base}–{seed_base + trials - 1}"
    t0 = time.perf_counter()
    try:
        wall = runner.run()
        keys = {t.key for t in todo}
        recorded = [r for r in read_rows(runner.csv_path) if row_key(r) in keys]
        rows = [r for r in recorded if r["outcome"] != "error"]
        summary = summarize(experiment, rows, default_lm)
    except BaseException:  # Ctrl-C, a crash: what flew so far is still accounted, for --resume
        _write_meta(meta_path, previous, code=code, wall_s=time.perf_counter() - t0, jobs=jobs, machine=machine,
                    seeds=seeds, trials=None)
        raise
    seen = {row_key(r) for r in recorded}
    names = {t.key: t.name for t in todo}
    summary["errored_trials"] = {names[row_key(r)]: r["episode_id"] for r in recorded if r["outcome"] == "error"}
    summary["missing_trials"] = [t.name for t in todo if t.key not in seen]
    meta = _write_meta(meta_path, previous, code=code, wall_s=wall, jobs=jobs, machine=machine, seeds=seeds,
                       trials=len(rows))
    write_report(out, summary, meta)
    for png in write_plots(out, summary, rows):
        log.info("plot %s", png)
    return summary
