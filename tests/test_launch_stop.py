"""Stopping a stack is not itself interruptible: a second Ctrl-C or SIGTERM waits until every
service is stopped (seen: ``pkill -TERM -f "land --world"`` signalled both ``timeout`` and the CLI,
``timeout`` forwarded its signal, and the second interrupted the stop, orphaning a planner, the
VLEs, the reasoners and their LLM workers for an hour)."""

from __future__ import annotations

import os
import signal
import subprocess
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from llmland import launch
from llmland.launch import Stack, raise_keyboard_interrupt, stop_signals_deferred

from .conftest import BIN, REPO

#: a service that ignores SIGTERM, so only the stop's SIGKILL after its grace period ends it
STUBBORN_SERVICE = """
import os, signal, sys, time
signal.signal(signal.SIGTERM, signal.SIG_IGN)
open(os.path.join(os.path.dirname(__file__), f"ready.{os.getpid()}"), "w").close()
time.sleep(120)
"""
#: seconds the stop waits before SIGKILL; the second signal arrives well inside it
GRACE_S = 1.5
SECOND_SIGNAL_AFTER_S = 0.3


@pytest.fixture
def sigterm_interrupts() -> Iterator[None]:
    previous = signal.signal(signal.SIGTERM, raise_keyboard_interrupt)  # as the CLI's main() does
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def _stubborn_stack(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, n: int) -> Stack:
    (tmp_path / "stubborn_service.py").write_text(STUBBORN_SERVICE)
    names = [f"stubborn{i}" for i in range(n)]
    for name in names:
        monkeypatch.setitem(launch.SERVICE_MODULES, name, "stubborn_service")
    stack = Stack(port=1, env={"PYTHONPATH": str(tmp_path)})
    stack.start(names)
    deadline = time.monotonic() + 30.0
    while len(list(tmp_path.glob("ready.*"))) < n:
        assert time.monotonic() < deadline, "the stub services did not start"
        time.sleep(0.05)
    return stack


def test_a_sigterm_during_the_stop_is_delivered_after_every_service_is_stopped(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, sigterm_interrupts: None) -> None:
    stack = _stubborn_stack(tmp_path, monkeypatch, n=3)
    procs = list(stack.procs.values())
    threading.Timer(SECOND_SIGNAL_AFTER_S, os.kill, args=(os.getpid(), signal.SIGTERM)).start()
    try:
        with pytest.raises(KeyboardInterrupt):
            stack.stop(grace_s=GRACE_S)
        assert all(p.poll() is not None for p in procs), [p.pid for p in procs if p.poll() is None]
    finally:  # a failing run leaves no stub behind
        for p in procs:
            if p.poll() is None:
                os.killpg(p.pid, signal.SIGKILL)
                p.wait()


def test_signals_are_handed_on_once_each_and_the_handlers_restored(sigterm_interrupts: None) -> None:
    before = signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)
    with pytest.raises(KeyboardInterrupt), stop_signals_deferred():
        os.kill(os.getpid(), signal.SIGTERM)
        os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(0.05)  # the handler runs between bytecodes of the main thread
    assert (signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)) == before


def test_outside_the_main_thread_nothing_is_deferred() -> None:
    seen: list[object] = []

    def body() -> None:
        with stop_signals_deferred():
            seen.append(signal.getsignal(signal.SIGTERM))

    t = threading.Thread(target=body)
    t.start()
    t.join()
    assert seen == [signal.getsignal(signal.SIGTERM)]


def _alive(pid: int) -> bool:
    """Whether ``pid`` runs (a zombie, exited but not yet reaped by init, does not)."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except FileNotFoundError:
        return False


def test_services_stop_when_their_launcher_is_killed_outright(tmp_path: Path) -> None:
    """SIGKILL leaves the CLI no chance to stop its services: each watches its launcher and stops
    itself (before, a test that timed out left a sim and a planner running for over an hour)."""
    log = (tmp_path / "up.log").open("w+")
    cli = subprocess.Popen([str(BIN / "llmland"), "up", "--services", "planner", "--port", str(launch.free_port())],
                           stdout=log, stderr=log, cwd=REPO)
    try:
        deadline = time.monotonic() + 60.0
        while "services up" not in Path(log.name).read_text():
            assert cli.poll() is None and time.monotonic() < deadline, Path(log.name).read_text()[-2000:]
            time.sleep(0.2)
        children = [int(p) for p in Path(f"/proc/{cli.pid}/task/{cli.pid}/children").read_text().split()]
        assert children, "the planner is not the CLI's child"
        cli.kill()
        cli.wait()
        deadline = time.monotonic() + 15.0
        while any(_alive(p) for p in children) and time.monotonic() < deadline:
            time.sleep(0.2)
        left = [p for p in children if _alive(p)]
        for p in left:
            os.kill(p, signal.SIGKILL)
        assert not left, "a service outlived its SIGKILLed launcher"
    finally:
        if cli.poll() is None:
            cli.kill()
        log.close()
