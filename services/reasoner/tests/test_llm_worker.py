"""The LLM in a supervised worker process: a crash gives fallback specs, never a dead reasoner."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from fastapi.testclient import TestClient
from llmland_reasoner.engine import ReasonerEngine
from llmland_reasoner.http_api import create_app
from llmland_reasoner.llm_worker import LlmUnavailableError, WorkerLlmBackend
from llmland_reasoner.resources import Resources
from llmland_reasoner.settings import ReasonerSettings

PREFIX = "Answer with the obstacle.\n"


def _wait_ready(backend: WorkerLlmBackend, timeout_s: float = 60.0) -> None:
    deadline = time.monotonic() + timeout_s
    while backend.health()["state"] != "ready":
        assert time.monotonic() < deadline, backend.health()
        time.sleep(0.05)


@pytest.fixture()
def backend() -> Iterator[WorkerLlmBackend]:
    b = WorkerLlmBackend(n_threads=1, call_timeout_s=20.0, restart_backoff_s=0.1)
    yield b
    b.close()


def test_worker_answers_like_the_inline_backend(backend: WorkerLlmBackend) -> None:
    from llmland_reasoner.llm import LlamaCppBackend

    inline = LlamaCppBackend(n_threads=1)
    args = (PREFIX, "Caption: a dog on a road\nObstacle:", [" dog", " road"], True)
    assert backend.score(*args) == pytest.approx(inline.score(*args), abs=1e-4)
    assert backend.pid is not None and backend.pid != os.getpid()


def test_killed_mid_request_raises_then_restarts(backend: WorkerLlmBackend) -> None:
    backend.score(PREFIX, "x", [" y"], True)
    pid = backend.pid
    assert pid is not None
    os.kill(pid, signal.SIGSTOP)  # the request below is certainly in flight when the worker dies
    errors: list[BaseException] = []

    def call() -> None:
        try:
            backend.complete(PREFIX, "Caption: a tree\nJSON:", None, 8, 0.0)
        except BaseException as exc:  # noqa: BLE001
            errors.append(exc)

    t = threading.Thread(target=call)
    t.start()
    time.sleep(0.3)
    os.kill(pid, signal.SIGKILL)
    t.join(10)
    assert len(errors) == 1 and isinstance(errors[0], LlmUnavailableError), errors
    assert "signal 9" in str(errors[0])
    with pytest.raises(LlmUnavailableError):  # new calls fail fast while it restarts
        backend.score(PREFIX, "x", [" y"], True)
    _wait_ready(backend)
    h = backend.health()
    assert h["restarts"] == 1 and h["crashes"] == 1 and h["pid"] != pid
    assert len(backend.score(PREFIX, "x", [" y", " z"], True)) == 2


def test_worker_dying_between_calls_is_noticed_and_restarted(backend: WorkerLlmBackend) -> None:
    pid = backend.pid
    assert pid is not None
    os.kill(pid, signal.SIGSEGV)
    deadline = time.monotonic() + 30
    while backend.health()["restarts"] < 1:
        assert time.monotonic() < deadline, backend.health()
        time.sleep(0.05)
    assert backend.health()["state"] == "ready"
    assert "signal 11" in backend.health()["last_error"]


def test_missing_model_is_a_clear_error(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError):
        WorkerLlmBackend(tmp_path / "nope.gguf")
    bad = tmp_path / "bad.gguf"
    bad.write_bytes(b"not a gguf")
    with pytest.raises(RuntimeError, match="could not start"):
        WorkerLlmBackend(bad)


def test_api_stays_up_and_answers_fallback_while_the_worker_is_down(tmp_path: Path) -> None:
    s = ReasonerSettings(index_dir=tmp_path / "index", timeout_s=10.0, llm_restart_backoff_s=2.0, cache_size=0)
    engine = ReasonerEngine(s, Resources.load(s))
    try:
        backend = engine.resources.backend
        assert isinstance(backend, WorkerLlmBackend)
        client = TestClient(create_app(engine, lambda _img: None, s))
        ok = client.post("/v1/reason", json={"caption": "a child running on the road"}).json()
        assert ok["source"] == "rag" and ok["reason"] == ""
        pid = backend.pid
        assert pid is not None
        os.kill(pid, signal.SIGKILL)
        fallback = client.post("/v1/reason", json={"caption": "a white crane flying over the water"})
        assert fallback.status_code == 200
        body = fallback.json()
        assert body["source"] == "fallback" and body["is_dynamic"] is True and "LLM worker" in body["reason"]
        assert body["buffer_m"] >= ok["buffer_m"]
        health = client.get("/healthz").json()
        assert health["status"] == "degraded" and health["llm"]["state"] != "ready"
        assert client.post("/v1/reason", json={"caption": "a bench", "mode": "retrieval"}).json()["source"] == \
            "retrieval"  # retrieval needs no LLM: still answered for real
        assert client.post("/v1/reason", json={"caption": "a cat on a wall"}).json()["source"] == \
            "rag"  # nor does a caption whose spec no answer of the LLM could change
        _wait_ready(backend)
        assert client.get("/healthz").json()["status"] == "ok"
        assert client.post("/v1/reason", json={"caption": "a white crane flying over the water"}).json()["source"] \
            == "rag"
    finally:
        engine.close()


def test_prefixes_given_at_start_are_evaluated_before_ready() -> None:
    b = WorkerLlmBackend(n_threads=1, call_timeout_s=20.0, wait=False, warm_prefixes=[PREFIX])
    try:
        assert b.health()["state"] == "starting"  # returned before the model loaded
        b.wait_ready()
        assert b.health() | {"pid": None} == {"state": "ready", "restarts": 0, "crashes": 0, "last_error": "",
                                              "pid": None, "prefixes_evaluated": 1}
        assert len(b.score(PREFIX, "Caption: a dog\nObstacle:", [" dog"], True)) == 1
    finally:
        b.close()


def test_a_script_without_a_main_guard_can_start_the_worker(tmp_path: Path) -> None:
    """The worker is its own program: it never re-imports the caller's ``__main__`` (a
    ``multiprocessing`` spawn does, which failed here and cost the reasoner ~6 s of imports)."""
    (tmp_path / "unguarded.py").write_text(
        "from llmland_reasoner.llm_worker import WorkerLlmBackend\n"
        "b = WorkerLlmBackend(n_threads=1)\n"
        f"print(len(b.score({PREFIX!r}, 'x', [' y'], True)))\n"
        "b.close()\n")
    proc = subprocess.run([sys.executable, "-m", "unguarded"], cwd=tmp_path, capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 0 and proc.stdout.strip() == "1", proc.stderr[-2000:]


class _DeadAfterLoad:
    """A worker program (fake) that loads, says ready, then dies before answering its warm-up."""

    pid = 999_999
    exitcode = -11

    def is_alive(self) -> bool:
        return False

    def join(self, timeout: float | None = None) -> None:
        return None

    def kill(self) -> None:
        return None


def test_a_worker_dying_in_its_prefix_warm_up_is_a_crash_not_a_dead_reasoner(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """A bad llama.cpp build faults at the first evaluation, after loading: the backend comes up in
    the restarting state (fallback specs), it does not raise out of the reasoner's start-up."""
    import socket
    from multiprocessing.connection import Connection

    from llmland_reasoner import llm_worker

    def spawn(_args: tuple[str, int, int], prefixes: list[str]) -> tuple[_DeadAfterLoad, Connection]:
        ours, theirs = socket.socketpair()
        child = Connection(theirs.detach())
        child.send(("ready", "fake"))
        child.close()
        return _DeadAfterLoad(), Connection(ours.detach())  # type: ignore[return-value]

    monkeypatch.setattr(llm_worker, "_spawn", spawn)
    b = WorkerLlmBackend(n_threads=1, restart_backoff_s=30.0, warm_prefixes=[PREFIX])
    try:
        h = b.health()
        assert h["state"] == "restarting" and h["crashes"] == 1 and "warm-up" in h["last_error"], h
        assert "signal 11" in h["last_error"]
        with pytest.raises(LlmUnavailableError):
            b.score(PREFIX, "x", [" y"], True)
    finally:
        b.close()


def test_a_restarted_worker_restores_its_warm_prefix_from_disk(tmp_path: Path) -> None:
    """The warm-up's evaluated prefix is saved by the first worker; a second one (a restart,
    the next start of the service) finds it and answers the same."""
    prefix = PREFIX * 8
    args = (prefix, "Caption: a dog on a road\nObstacle:", [" dog", " road"], True)
    first = WorkerLlmBackend(n_threads=1, call_timeout_s=20.0, warm_prefixes=[prefix], state_dir=tmp_path)
    try:
        answer = first.score(*args)
    finally:
        first.close()
    saved = list(tmp_path.glob("*.kvstate"))
    assert len(saved) == 1
    stamp = saved[0].stat().st_mtime_ns
    second = WorkerLlmBackend(n_threads=1, call_timeout_s=20.0, warm_prefixes=[prefix], state_dir=tmp_path)
    try:
        assert second.score(*args) == answer
    finally:
        second.close()
    assert [p.stat().st_mtime_ns >= stamp for p in tmp_path.glob("*.kvstate")] == [True]  # read, not a new file
