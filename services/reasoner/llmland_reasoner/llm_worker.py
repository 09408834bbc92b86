"""The native LLM in a supervised worker process, so a crash in it never takes the reasoner down.

llama.cpp is native code: a bad build for the CPU (the AMX fault of issue 9), a corrupt GGUF
or an out-of-memory kill ends the whole process that runs it. :class:`WorkerLlmBackend`
implements :class:`~llmland_reasoner.llm.LlmBackend` by sending each call over a pipe to a
child process that runs :class:`~llmland_reasoner.llm.LlamaCppBackend`:

- a call to a dead, hung (no answer within ``call_timeout_s``) or not-yet-restarted worker
  raises :class:`LlmUnavailableError` at once; the extractor answers it with the conservative
  fallback spec (``source="fallback"``, the reason in ``reason``);
- a supervisor thread restarts the worker after ``restart_backoff_s`` (doubling up to
  ``MAX_BACKOFF_S`` while starts keep failing) and re-evaluates the prompt prefixes the
  previous worker had seen, so the first call after a restart pays only its suffix;
- :meth:`WorkerLlmBackend.health` says ``ready``, ``starting``, ``restarting`` or ``failed``
  with the restart count and the last error (``/healthz`` shows it).

Calls are serialised (one in flight), as they are in the in-process backend.

The worker is its own program (``python -m llmland_reasoner.llm_worker``), not a
``multiprocessing`` spawn: a spawned child re-imports the parent's ``__main__`` module, which for
the reasoner is the whole service (torch, sentence-transformers, llama-index: about 6 s of CPU
before the model even starts loading) and, in a user's script without a ``__main__`` guard, a
crash. The two ends talk over a socket pair with :class:`multiprocessing.connection.Connection`.
The worker can be started without waiting for it (``wait=False``, then :meth:`WorkerLlmBackend.wait_ready`),
so the model loads while the caller loads its other models.
"""

from __future__ import annotations

import argparse
import logging
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Sequence
from multiprocessing.connection import Connection
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from .llm import ScoreRequest

log = logging.getLogger(__name__)

#: ceiling of the restart back-off (s) while starts keep failing
MAX_BACKOFF_S = 30.0
#: prompt prefixes re-evaluated in a restarted worker (the newest ones)
MAX_WARM_PREFIXES = 4
#: longest wait (s) for a new worker to load its model and say it is ready
START_TIMEOUT_S = 120.0


class LlmUnavailableError(RuntimeError):
    """The LLM worker is down, restarting or did not answer in time."""


def _serve(conn: Connection, model_path: str | None, n_threads: int, n_ctx: int,
           state_dir: str | None = None) -> None:
    """Child process: load the model, then answer ``(op, args)`` requests until ``stop``."""
    from .llm import LlamaCppBackend

    try:
        backend = LlamaCppBackend(model_path, n_threads=n_threads, n_ctx=n_ctx, state_dir=state_dir)
    except Exception as exc:  # noqa: BLE001 - reported to the parent, which decides
        conn.send(("error", f"{type(exc).__name__}: {exc}"))
        return
    conn.send(("ready", backend.name))
    while True:
        try:
            op, args = conn.recv()
        except EOFError:
            return
        if op == "stop":
            return
        try:
            if op == "score":
                value: Any = backend.score(*args)
            elif op == "score_many":
                value = backend.score_many(args[0])
            elif op == "complete":
                value = backend.complete(*args)
            elif op == "warm":
                value = backend.score(args[0], " ", [" "], True)
            else:
                raise ValueError(f"unknown operation {op!r}")
            conn.send(("ok", value))
        except Exception as exc:  # noqa: BLE001 - a Python error is the caller's, the worker lives on
            conn.send(("error", f"{type(exc).__name__}: {exc}"))


class _WorkerProcess:
    """The worker program as a child process, with the part of ``multiprocessing.Process``'s
    interface the supervisor uses (``exitcode`` negative: killed by that signal)."""

    def __init__(self, conn_fd: int, model_path: str, n_threads: int, n_ctx: int, state_dir: str | None) -> None:
        cmd = [sys.executable, "-m", __name__, "--fd", str(conn_fd), "--model", model_path,
               "--threads", str(n_threads), "--ctx", str(n_ctx)]
        if state_dir is not None:
            cmd += ["--state-dir", state_dir]
        self._popen = subprocess.Popen(cmd, pass_fds=(conn_fd,), stdin=subprocess.DEVNULL)
        self.pid = self._popen.pid

    @property
    def exitcode(self) -> int | None:
        return self._popen.poll()

    def is_alive(self) -> bool:
        return self._popen.poll() is None

    def join(self, timeout: float | None = None) -> None:
        try:
            self._popen.wait(timeout)
        except subprocess.TimeoutExpired:
            pass

    def kill(self) -> None:
        if self._popen.poll() is None:
            self._popen.kill()


def _spawn(args: tuple[str, int, int, str | None], prefixes: Sequence[str]) -> tuple[_WorkerProcess, Connection]:
    """Start the worker program ``args = (model_path, n_threads, n_ctx, state_dir)`` and queue the evaluation
    of ``prefixes`` behind its model load (it answers each after its ready signal); returns it and
    the parent's end of its connection."""
    parent_sock, child_sock = socket.socketpair()
    try:
        proc = _WorkerProcess(child_sock.fileno(), *args)
    finally:
        child_sock.close()
    conn = Connection(parent_sock.detach())
    for prefix in prefixes:
        conn.send(("warm", (prefix,)))
    return proc, conn


def _discard(proc: _WorkerProcess, conn: Connection) -> None:
    """Kill a worker that is not (or no longer) in service and close its connection."""
    proc.kill()
    proc.join(timeout=2.0)
    conn.close()


class WorkerLlmBackend:
    """An :class:`~llmland_reasoner.llm.LlmBackend` whose model runs in a child process."""

    def __init__(self, model_path: str | Path | None = None, n_threads: int = 1, n_ctx: int = 2048, *,
                 call_timeout_s: float = 10.0, restart_backoff_s: float = 0.5, wait: bool = True,
                 warm_prefixes: Sequence[str] = (), state_dir: str | Path | None = None) -> None:
        """Start the worker; with ``wait`` (the default) block until it is ready (RuntimeError if it
        cannot start, FileNotFoundError without the GGUF), else return at once and let
        :meth:`wait_ready` do that. ``warm_prefixes``: prompt prefixes the worker evaluates right
        after loading (a restarted worker too), so no call pays for them; ``state_dir``: where the
        worker keeps evaluated prefixes between runs (:mod:`.prefix_state`)."""
        from .llm import default_gguf_path

        path = Path(model_path) if model_path else default_gguf_path()
        if not path.is_file():
            raise FileNotFoundError(f"GGUF model not found: {path}")
        self.path = path
        self.name = path.stem
        self._args = (str(path), n_threads, n_ctx, str(state_dir) if state_dir is not None else None)
        self.call_timeout_s = call_timeout_s
        self.restart_backoff_s = restart_backoff_s
        self._call_lock = threading.Lock()
        self._state_lock = threading.Lock()
        self._proc: Any = None
        self._conn: Connection | None = None
        self._state = "starting"
        self._closed = False
        self.restarts = 0
        self.crashes = 0
        self.last_error = ""
        self._evaluated: set[str] = set()  # prefixes the current worker has evaluated
        self._wake = threading.Event()
        self._supervisor: threading.Thread | None = None
        self._prefixes = list(warm_prefixes)[-MAX_WARM_PREFIXES:]
        self._pending: tuple[_WorkerProcess, Connection] | None = _spawn(self._args, self._prefixes)
        if wait:
            self.wait_ready()

    def wait_ready(self) -> None:
        """Wait for the worker started by the constructor to load its model, then supervise it.
        RuntimeError if it could not start. Idempotent."""
        if self._supervisor is not None:
            return
        pending, self._pending = self._pending, None
        if pending is not None:
            try:
                self._handshake(*pending, list(self._prefixes))  # no call can add one before ready
            except BaseException:  # interrupted: never leave the worker behind
                _discard(*pending)
                raise
        if self._state == "restarting":  # the model loaded, then the worker crashed: serve the fallback
            log.error("LLM worker lost: %s; answering with the conservative fallback until it restarts",
                      self.last_error)
            self._wake.set()
        elif self._state != "ready":
            raise RuntimeError(f"LLM worker could not start: {self.last_error}")
        self._supervisor = threading.Thread(target=self._supervise, name="llm-supervisor", daemon=True)
        self._supervisor.start()

    # ------------------------------------------------------------------ interface
    def score(self, prefix: str, suffix: str, continuations: Sequence[str],
              first_token_only: bool = False) -> list[float]:
        return list(self._call("score", (prefix, suffix, list(continuations), first_token_only),
                               timeout_s=self._timeout_for([prefix])))

    def score_many(self, requests: Sequence[ScoreRequest]) -> list[list[float]]:
        """Several ``score`` calls in one round trip; a worker lost during it fails them all
        (:class:`LlmUnavailableError`: every caption of the batch gets the fallback)."""
        if not requests:
            return []
        batch = [(p, s, list(c), f) for p, s, c, f in requests]
        wait_s = self._timeout_for([r[0] for r in batch]) + self.call_timeout_s * (len(batch) - 1)
        value = self._call("score_many", (batch,), timeout_s=wait_s)
        return [list(v) for v in value]

    def complete(self, prefix: str, suffix: str, grammar: str | None, max_tokens: int, temperature: float) -> str:
        return str(self._call("complete", (prefix, suffix, grammar, max_tokens, temperature),
                              timeout_s=self._timeout_for([prefix])))

    def health(self) -> dict[str, Any]:
        with self._state_lock:
            return {"state": self._state, "restarts": self.restarts, "crashes": self.crashes,
                    "last_error": self.last_error, "pid": self._proc.pid if self._proc is not None else None,
                    "prefixes_evaluated": len(self._evaluated)}

    @property
    def pid(self) -> int | None:
        return self._proc.pid if self._proc is not None else None

    def close(self) -> None:
        self._closed = True
        self._wake.set()
        pending, self._pending = self._pending, None
        if pending is not None:  # never waited for
            _discard(*pending)
        with self._state_lock:
            self._stop_worker(graceful=True)

    # ------------------------------------------------------------------ calls
    def _timeout_for(self, prefixes: Sequence[str]) -> float:
        """How long a call may take: ``call_timeout_s``, or :data:`START_TIMEOUT_S` when the
        worker has not evaluated one of its prompt prefixes yet (hundreds of tokens: on a
        loaded CPU that first evaluation can take longer than any call, and killing the worker
        for it would only make the next worker evaluate it again)."""
        new = False
        for prefix in prefixes:
            if prefix not in self._prefixes:
                self._prefixes = (self._prefixes + [prefix])[-MAX_WARM_PREFIXES:]
            new = new or prefix not in self._evaluated
        return max(self.call_timeout_s, START_TIMEOUT_S) if new else self.call_timeout_s

    def _call(self, op: str, args: tuple[Any, ...], timeout_s: float | None = None) -> Any:
        wait_s = self.call_timeout_s if timeout_s is None else timeout_s
        self._raise_unless_ready()  # fail fast while the worker restarts: never queue behind it
        with self._call_lock:
            self._raise_unless_ready()
            conn = self._conn
            assert conn is not None
            try:
                conn.send((op, args))
                if not conn.poll(wait_s):
                    self._worker_lost(f"LLM worker gave no answer within {wait_s:.1f} s (killed)")
                    raise LlmUnavailableError(self.last_error)
                kind, value = conn.recv()
            except (EOFError, OSError, BrokenPipeError):
                self._worker_lost(f"LLM worker died ({self._exit_reason()}) during {op}")
                raise LlmUnavailableError(self.last_error) from None
            if kind == "error":
                raise RuntimeError(f"LLM error: {value}")
            if op in ("score", "complete"):
                self._evaluated.add(args[0])
            elif op == "score_many":
                self._evaluated.update(r[0] for r in args[0])
            return value

    def _raise_unless_ready(self) -> None:
        if self._state != "ready" or self._conn is None:
            raise LlmUnavailableError(f"LLM worker {self._state}: {self.last_error or 'not ready'}")

    def _exit_reason(self) -> str:
        proc = self._proc
        if proc is None:
            return "no process"
        proc.join(timeout=1.0)
        return self._code_reason(proc.exitcode)

    @staticmethod
    def _code_reason(code: int | None) -> str:
        if code is None:
            return "still running"
        return f"killed by signal {-code}" if code < 0 else f"exit code {code}"

    def _worker_lost(self, reason: str) -> None:
        log.error("LLM worker lost: %s; answering with the conservative fallback until it restarts", reason)
        with self._state_lock:
            self.crashes += 1
            self.last_error = reason
            self._state = "restarting"
            self._stop_worker(graceful=False)
        self._wake.set()

    # ------------------------------------------------------------------ lifecycle
    def _start_worker(self) -> None:
        prefixes = list(self._prefixes)  # the new worker evaluates the known prefixes once
        try:
            pending = _spawn(self._args, prefixes)
        except OSError as exc:  # could not even start the program (or queue its warm-up)
            with self._state_lock:
                self.last_error = f"could not start the LLM worker: {exc}"
                self._state = "failed"
            return
        self._handshake(*pending, prefixes)

    def _fail_start(self, proc: _WorkerProcess, parent: Connection, reason: str, state: str = "failed") -> None:
        _discard(proc, parent)
        with self._state_lock:
            self.last_error = reason
            self._state = state
            if state == "restarting":
                self.crashes += 1

    def _handshake(self, proc: _WorkerProcess, parent: Connection, prefixes: list[str]) -> None:
        """Wait for a started worker's ready signal and its answers to the prefix warm-ups queued
        by :func:`_spawn`; the state becomes ``ready``; ``failed`` with the reason in ``last_error``
        when the model did not load; ``restarting`` (a crash: the supervisor restarts it) when the
        model loaded and the worker then died or hung in the warm-up (a bad llama.cpp build for the
        CPU faults at the first evaluation, not at load)."""
        ok = parent.poll(START_TIMEOUT_S)
        try:
            kind, value = parent.recv() if ok else ("error", f"no ready signal within {START_TIMEOUT_S:.0f} s")
        except (EOFError, OSError):
            proc.join(timeout=1.0)
            kind, value = "error", f"worker died while loading (exit {proc.exitcode})"
        if kind != "ready":
            self._fail_start(proc, parent, str(value))
            return
        evaluated: set[str] = set()
        for prefix in prefixes:
            try:
                if not parent.poll(START_TIMEOUT_S):
                    # its late answer would be read as the next call's: the pipe would stay one
                    # answer behind. A crash instead (killed; the supervisor restarts it).
                    self._fail_start(proc, parent, "LLM worker gave no answer to the prefix warm-up within "
                                     f"{START_TIMEOUT_S:.0f} s (killed)", "restarting")
                    return
                answer = parent.recv()
            except (EOFError, OSError):
                proc.join(timeout=1.0)
                self._fail_start(proc, parent, f"LLM worker died ({self._code_reason(proc.exitcode)}) during the "
                                 "prefix warm-up", "restarting")
                return
            if answer[0] == "ok":
                evaluated.add(prefix)
        self._evaluated = evaluated
        with self._state_lock:
            self._proc, self._conn = proc, parent
            self._state = "ready"
        log.info("LLM worker ready (pid %d, %s)", proc.pid, self.name)

    def _stop_worker(self, graceful: bool) -> None:
        proc, conn = self._proc, self._conn
        self._proc, self._conn = None, None
        if conn is not None:
            if graceful:
                try:
                    conn.send(("stop", ()))
                except (OSError, BrokenPipeError):
                    pass
            conn.close()
        if proc is not None:
            if graceful:
                proc.join(timeout=2.0)
            if proc.is_alive():
                proc.kill()
            proc.join(timeout=2.0)

    def _supervise(self) -> None:
        backoff = self.restart_backoff_s
        while not self._closed:
            self._wake.wait(1.0)
            self._wake.clear()
            if self._closed:
                return
            with self._state_lock:
                dead = self._proc is not None and not self._proc.is_alive()
                if dead:  # died between calls: notice it here, not only at the next call
                    self.crashes += 1
                    self.last_error = f"LLM worker died ({self._exit_reason()})"
                    self._state = "restarting"
                    self._stop_worker(graceful=False)
                needs_start = self._state in ("restarting", "failed")
            if not needs_start:
                backoff = self.restart_backoff_s
                continue
            time.sleep(backoff)
            if self._closed:
                return
            with self._call_lock:
                with self._state_lock:
                    self._state = "restarting"
                self._start_worker()
            if self._state == "ready":
                self.restarts += 1
                backoff = self.restart_backoff_s
            else:
                log.error("LLM worker restart failed: %s (next try in %.1f s)", self.last_error, backoff)
                backoff = min(MAX_BACKOFF_S, 2.0 * backoff)
                self._wake.set()


def main(argv: list[str] | None = None) -> None:
    """The worker program: serve the parent over the inherited connection ``--fd``."""
    ap = argparse.ArgumentParser(prog="python -m llmland_reasoner.llm_worker", description=__doc__.splitlines()[0])
    ap.add_argument("--fd", type=int, required=True, help="file descriptor of the connection to the parent")
    ap.add_argument("--model", required=True, help="GGUF path")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--ctx", type=int, default=2048)
    ap.add_argument("--state-dir", default=None, help="where evaluated prompt prefixes are kept between runs")
    args = ap.parse_args(argv)
    from llmland_schemas.service import configure_logging

    configure_logging()
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C reaches the whole group: the parent stops us
    _serve(Connection(args.fd), args.model, args.threads, args.ctx, args.state_dir)


if __name__ == "__main__":
    main()
