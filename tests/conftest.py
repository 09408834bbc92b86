"""Cross-service fixtures: real service processes on a real Zenoh bus over loopback."""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from llmland_schemas.bus import Bus

from llmland.launch import Stack, free_port, hub_bus

REPO = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent


@pytest.fixture()
def bus_port() -> int:
    return free_port()


@pytest.fixture()
def hub(bus_port: int) -> Iterator[Bus]:
    with hub_bus(bus_port) as bus:
        yield bus


@pytest.fixture()
def stack_factory(bus_port: int, tmp_path: Path) -> Iterator:
    stacks: list[Stack] = []

    def make(names: list[str], env: dict[str, str] | None = None, drone_id: str = "d0") -> Stack:
        st = Stack(bus_port, drone_id, env=env, log_level="INFO", log_dir=tmp_path / "logs")
        st.start(names)
        stacks.append(st)
        return st

    yield make
    for st in stacks:
        st.stop()


def run_cli(*args: str, timeout: float = 300) -> subprocess.CompletedProcess[str]:
    """Run the installed ``llmland`` CLI; stdout is its JSON, stderr its logs."""
    return subprocess.run([str(BIN / "llmland"), *args], capture_output=True, text=True, timeout=timeout, cwd=REPO)
