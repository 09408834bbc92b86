"""Fly an experiment's trials on ``jobs`` stacks side by side, one CSV row per trial as it ends.

Each job owns one stack (its own processes and loopback bus port) and keeps it while its
trials need the same services; a job that finds no trial for its stack starts the next one.
Rows are appended to ``trials.csv`` as soon as a trial ends, so ``--resume`` skips what is
done and a long experiment survives an interruption. A trial whose stack fails is retried
once on a fresh stack, then recorded with outcome ``error``: every trial taken ends as a row
unless an interrupt stops it (``--resume`` flies it) or its row cannot be written (logged; the
summary names it as missing).
"""

from __future__ import annotations

import csv
import io
import logging
import os
import signal
import threading
import time
from collections import Counter
from contextlib import ExitStack
from pathlib import Path
from typing import Any

from llmland_schemas import EpisodeResult
from tqdm import tqdm
from tqdm.contrib.logging import logging_redirect_tqdm

from ..launch import Stack, raise_keyboard_interrupt, stop_signals_deferred
from ..stacks import RunningStack, StackConfig, make_mission, open_stack
from .plan import Trial
from .traces import TraceRecorder

log = logging.getLogger(__name__)

COLUMNS = [
    "world", "method", "variant", "seed", "outcome", "success", "touchdown_error_m", "time_to_land_s",
    "closest_person_m", "min_person_distance_m", "close_calls", "collisions", "spec_latency_ms_mean",
    "latency_model", "perception_requests", "perception_degraded", "perception_degraded_s", "fallback_specs",
    "sim_time_s", "spec_compute_ms_mean", "mpc_solve_ms_p50", "mpc_solve_ms_p95", "deadline_misses",
    "commands_missing", "peak_memory_mb", "wall_time_s", "episode_id",
]
#: columns that depend on the machine's speed and load, not on the episode (the rest must be
#: identical when the same seeds are flown again with the same latency model)
WALL_COLUMNS = {"spec_compute_ms_mean", "mpc_solve_ms_p50", "mpc_solve_ms_p95", "deadline_misses",
                "peak_memory_mb", "wall_time_s", "episode_id"}
#: a trial whose episode never ends is abandoned after this much wall time per sim second
WALL_PER_SIM_S = 20.0
#: Seconds a service gets to exit on SIGTERM when an experiment is interrupted.
STOP_GRACE_S = 3.0
#: Seconds between checks for an interrupt while waiting for the jobs.
JOIN_POLL_S = 0.5
#: faults a stack is expected to show now and then (a service that does not come up, an episode
#: that does not end, a socket): logged in one line. Anything else is a bug, logged with its
#: traceback. Either way the trial is retried once, then recorded as an ``error`` row.
EXPECTED_FAULTS = (TimeoutError, RuntimeError, OSError)


def _fmt(v: float | None, digits: int = 3) -> str:
    return "" if v is None else f"{v:.{digits}f}"


def trial_row(trial: Trial, r: EpisodeResult, peak_memory_mb: float | None) -> dict[str, Any]:
    """The CSV row of one finished trial."""
    people = r.min_person_distance_m
    return {
        "world": trial.world, "method": trial.method, "variant": trial.variant, "seed": trial.seed,
        "outcome": r.outcome, "success": int(r.success), "touchdown_error_m": _fmt(r.touchdown_error_m),
        "time_to_land_s": _fmt(r.time_to_land_s, 2),
        "closest_person_m": _fmt(min(people.values()) if people else None),
        "min_person_distance_m": ";".join(f"{k}:{v:.3f}" for k, v in sorted(people.items())),
        "close_calls": r.close_calls, "collisions": ";".join(r.collisions),
        "spec_latency_ms_mean": _fmt(r.spec_latency_ms_mean, 1), "latency_model": r.latency_model,
        "perception_requests": r.perception_requests, "perception_degraded": int(r.perception_degraded),
        "perception_degraded_s": _fmt(r.perception_degraded_s, 2), "fallback_specs": r.fallback_specs,
        "sim_time_s": _fmt(r.sim_time_s, 2), "spec_compute_ms_mean": _fmt(r.spec_compute_ms_mean, 1),
        "mpc_solve_ms_p50": _fmt(r.mpc_solve_ms_p50), "mpc_solve_ms_p95": _fmt(r.mpc_solve_ms_p95),
        "deadline_misses": r.deadline_misses, "commands_missing": r.commands_missing,
        "peak_memory_mb": _fmt(peak_memory_mb, 1),
        "wall_time_s": _fmt(r.wall_time_s, 2), "episode_id": r.episode_id,
    }


def append_row(path: Path, row: dict[str, Any]) -> None:
    """Append one trial's row to the CSV at ``path`` (:data:`COLUMNS`; the header first if new)."""
    new = not path.exists()
    with path.open("a", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=COLUMNS)
        if new:
            w.writeheader()
        w.writerow(row)


def error_row(trial: Trial, reason: str) -> dict[str, Any]:
    row: dict[str, Any] = {c: "" for c in COLUMNS}
    row.update({"world": trial.world, "method": trial.method, "variant": trial.variant, "seed": trial.seed,
                "outcome": "error", "success": 0, "episode_id": " ".join(reason.split())[:200]})
    return row


#: the columns that name a trial (:func:`row_key`)
KEY_COLUMNS = ("world", "method", "variant", "seed")


def read_rows(path: Path) -> list[dict[str, str]]:
    """The complete rows of the trials table at ``path`` (see :func:`_read_table`)."""
    return _read_table(path)[1]


def _read_table(path: Path) -> tuple[list[str], list[dict[str, str]], int]:
    """The trials table at ``path``: its header, its complete rows and how many incomplete ones
    were left out (nothing when there is no file).

    A row cut short (a run killed while it wrote the row: fewer fields than the header, or a key
    that does not parse) is not a result: it is left out, with a warning naming the line, so
    ``--resume`` flies that trial again. A file that is not a trials table (not UTF-8 CSV, no
    world / method / variant / seed columns) raises ValueError naming it."""
    if not path.exists():
        return [], [], 0
    try:
        text = path.read_text(encoding="utf-8")
        reader = csv.DictReader(io.StringIO(text, newline=""))
        rows, header = list(reader), list(reader.fieldnames or [])
    except (UnicodeDecodeError, csv.Error) as exc:
        raise ValueError(f"{path} is not a readable trials table ({exc}): move it away or use another --out") from None
    # every row ends with a newline: a last row without one was cut, maybe inside its last field
    cut_last = bool(rows) and not text.endswith(("\n", "\r"))
    missing = [c for c in KEY_COLUMNS if c not in header]
    if header and missing:
        raise ValueError(f"{path} is not a trials table (no {', '.join(missing)} column): use another --out")
    complete: list[dict[str, str]] = []
    for line, row in enumerate(rows, start=2):
        try:
            if None in row.values() or None in row:
                raise ValueError("fewer or more fields than the header")
            if cut_last and line == len(rows) + 1:
                raise ValueError("no newline at its end")
            row_key(row)
        except ValueError as exc:
            log.warning("%s line %d is incomplete (%s; a run stopped while writing it?): not a result, "
                        "flown again on --resume", path, line, exc)
            continue
        complete.append(row)
    return header, complete, len(rows) - len(complete)


def drop_error_rows(path: Path) -> list[dict[str, str]]:
    """Remove the ``error`` rows and the incomplete ones from the CSV at ``path`` (a stack fault is
    not a result, nor is a row cut short: ``--resume`` flies those trials again) and return the rows
    that stay. The file is replaced in one step (a
    crash or Ctrl-C meanwhile leaves the old one), written with today's :data:`COLUMNS`; so is a
    file an older version wrote with other columns, or the rows appended to it would not line up
    with its header (a column missing from it stays empty)."""
    header, rows, incomplete = _read_table(path)
    kept = [r for r in rows if r["outcome"] != "error"]
    if incomplete or len(kept) < len(rows) or (path.exists() and header != COLUMNS):
        tmp = path.with_name(path.name + ".tmp")
        with tmp.open("w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=COLUMNS, extrasaction="ignore")
            w.writeheader()
            w.writerows(kept)
        os.replace(tmp, path)
    return kept


def _close_quietly(resources: ExitStack) -> None:
    """Stop a failed trial's stack; a failure to (a service that will not die) is logged, and the
    next trial starts a fresh stack."""
    try:
        resources.close()
    except Exception:
        log.exception("stopping a failed stack")


def row_key(row: dict[str, Any]) -> tuple[str, str, str, int]:
    return (str(row["world"]), str(row["method"]), str(row["variant"]), int(row["seed"]))


class ExperimentRunner:
    """Runs ``trials`` into ``out/trials.csv`` with ``jobs`` parallel stacks."""

    def __init__(self, trials: list[Trial], out: Path, *, jobs: int = 1, timeout_s: float = 90.0,
                 rrd: bool = False, resume: bool = False, log_level: str = "WARNING", label: str = "") -> None:
        self.out = out
        self.csv_path = out / "trials.csv"
        out.mkdir(parents=True, exist_ok=True)
        done: set[tuple[str, str, str, int]] = set()
        if resume:
            done = {row_key(r) for r in drop_error_rows(self.csv_path)}
        elif self.csv_path.exists():
            self.csv_path.unlink()
        self.todo = [t for t in trials if t.key not in done]
        self.skipped = len(trials) - len(self.todo)
        self.jobs = max(1, min(jobs, len(self.todo) or 1))
        self.timeout_s = timeout_s
        self.rrd = rrd
        self.log_level = log_level
        self.label = label
        self._lock = threading.Lock()
        self._tally: dict[str, Counter[str]] = {}
        self._bar: tqdm | None = None
        self._total = len(self.todo)  # trials this run flies (for the progress line without a terminal)
        self._stop = threading.Event()
        self._live: dict[int, RunningStack] = {}
        #: each job's stack from the moment its processes exist (up or still starting) to the job's end
        self._stacks: dict[int, Stack] = {}
        #: set by each job as its last act (after its stack stopped). Not ``Thread.is_alive()``:
        #: on CPython 3.11 a ``join`` interrupted by Ctrl-C marks a running thread as stopped, so
        #: the interpreter then exits without waiting for it and its services are orphaned.
        self._finished: list[threading.Event] = []

    # ------------------------------------------------------------------ scheduling
    def _take(self, current: StackConfig | None) -> Trial | None:
        """The next trial, preferring one that the job's running stack can fly."""
        with self._lock:
            if not self.todo:
                return None
            for i, t in enumerate(self.todo):
                if t.stack() == current:
                    return self.todo.pop(i)
            return self.todo.pop(0)

    def _record(self, row: dict[str, Any]) -> None:
        with self._lock:
            append_row(self.csv_path, row)
            name = row["method"] + (f" [{row['variant']}]" if row["variant"] else "")
            tally = self._tally.setdefault(name, Counter())
            tally["n"] += 1
            tally["ok"] += int(row["success"])
            counts = " · ".join(f"{k} {c['ok']}/{c['n']}" for k, c in self._tally.items())
            if self._bar is not None and not self._bar.disable:
                self._bar.set_postfix_str(counts)
                self._bar.update(1)
            else:  # no terminal: the bar's running counts as a log line
                done = sum(c["n"] for c in self._tally.values())
                log.info("%d of %d trials done; succeeded: %s", done, self._total, counts)

    def _record_safely(self, row: dict[str, Any]) -> None:
        """:meth:`_record`, and a failure to (a full disk) logged: the job flies on, and the
        summary names the trial as missing."""
        try:
            self._record(row)
        except Exception:
            log.exception("recording the row of %s failed", row_key(row))

    # ------------------------------------------------------------------ flying
    def _fly(self, running: RunningStack, tracer: TraceRecorder, trial: Trial) -> dict[str, Any]:
        rrd = str((self.out / "rrd" / f"{trial.name}.rrd").resolve()) if self.rrd else None
        mission = make_mission(trial.stack(), world=trial.world, seed=trial.seed, timeout_s=self.timeout_s,
                               n_pedestrians=trial.n_pedestrians, latency_model=trial.latency_model, rrd=rrd)
        tracer.start(mission.episode_id)
        result = running.run(mission, wall_timeout_s=60.0 + WALL_PER_SIM_S * self.timeout_s)
        tracer.save(self.out / "traces" / f"{trial.name}.json")
        peak = running.peak_rss_mb("reasoner") if trial.stack().perception == "pipeline" else None
        log.info("%s: %s", trial.name, result.outcome)
        return trial_row(trial, result, peak)

    def _job(self, index: int) -> None:
        current: StackConfig | None = None
        resources = ExitStack()
        running: RunningStack | None = None
        tracer: TraceRecorder | None = None
        try:
            while not self._stop.is_set() and (trial := self._take(current)) is not None:
                row: dict[str, Any] | None = None
                for attempt in (1, 2):
                    try:
                        if running is None or trial.stack() != current:
                            resources.close()
                            current = trial.stack()
                            running = resources.enter_context(open_stack(
                                current, log_level=self.log_level, log_dir=self.out / "logs" / f"job{index}",
                                on_start=lambda st: self._stacks.__setitem__(index, st)))
                            tracer = TraceRecorder(running.bus, running.runner.drone_id)
                            self._live[index] = running
                        assert running is not None and tracer is not None
                        if self._stop.is_set():
                            break
                        row = self._fly(running, tracer, trial)
                        break
                    except Exception as exc:  # any fault: a job that died here would lose its trial unseen
                        if self._stop.is_set():  # interrupted: the trial is not recorded, --resume flies it
                            break
                        log.error("%s failed on attempt %d: %s: %s", trial.name, attempt, type(exc).__name__, exc,
                                  exc_info=not isinstance(exc, EXPECTED_FAULTS))
                        _close_quietly(resources)
                        running, current = None, None
                        if attempt == 2:
                            row = error_row(trial, f"{type(exc).__name__}: {exc}")
                if row is not None:
                    self._record_safely(row)
        finally:
            self._live.pop(index, None)
            try:
                resources.close()
            finally:
                self._stacks.pop(index, None)
                self._finished[index].set()

    def _interrupt(self) -> None:
        """Ctrl-C or SIGTERM: fly nothing more and stop every stack now (no orphaned services)."""
        self._stop.set()
        with self._lock:
            self.todo.clear()
        for running in list(self._live.values()):
            running.runner.abort()
        for stack in list(self._stacks.values()):
            try:
                stack.stop(grace_s=STOP_GRACE_S)  # one still starting then fails its wait, and its job ends
            except (RuntimeError, OSError) as exc:  # a job thread closing the same stack
                log.debug("stopping a stack: %s", exc)

    def _stop_all(self, threads: list[threading.Thread]) -> None:
        """Stop every stack and wait until every job has ended (a job whose thread never started,
        the interrupt having come while starting them, has nothing to stop). A second Ctrl-C or
        SIGTERM meanwhile waits until then: leaving now would orphan the services still being
        stopped (seconds)."""
        with stop_signals_deferred():
            log.warning("interrupted: stopping %d stack(s); --resume continues from trials.csv", len(self._stacks))
            while not all(done.is_set() or t.ident is None for done, t in zip(self._finished, threads, strict=True)):
                self._interrupt()
                time.sleep(JOIN_POLL_S)

    def run(self) -> float:
        """Fly every trial still to do; returns the wall time (s)."""
        t0 = time.perf_counter()
        if not self.todo:
            return 0.0
        # no bar when stderr is no terminal (disable=None): in a captured log its redraws prefixed
        # every log line; each trial's outcome is logged anyway
        with logging_redirect_tqdm(), tqdm(total=len(self.todo), desc=self.label or "trials", unit="trial",
                                           dynamic_ncols=True, disable=None) as bar:
            self._bar = bar
            self._finished = [threading.Event() for _ in range(self.jobs)]
            threads = [threading.Thread(target=self._job, args=(i,), name=f"job{i}") for i in range(self.jobs)]
            previous = signal.signal(signal.SIGTERM, raise_keyboard_interrupt)
            try:
                for t in threads:
                    t.start()
                for done in self._finished:
                    while not done.wait(JOIN_POLL_S):  # a timed wait lets Ctrl-C / SIGTERM reach this thread
                        pass
            except KeyboardInterrupt:
                self._stop_all(threads)
                raise
            finally:
                signal.signal(signal.SIGTERM, previous)
                self._bar = None
        return time.perf_counter() - t0
