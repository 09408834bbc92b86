"""A running stack seen from the network (docs/network.md): loopback only, and outside tools in client
mode the way the official zenoh-python examples (``z_sub``, ``z_get``) open their sessions."""

from __future__ import annotations

import ipaddress
import json
import subprocess
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import psutil
import pytest
import zenoh
from llmland_schemas import REASONER_SPEC_QUERY, Topic, key

from llmland.launch import Fleet, free_port, hub_bus, hub_endpoint

from .conftest import BIN, REPO, run_cli

pytestmark = pytest.mark.integration

DRONES = ["d0", "d1"]
#: the reasoner without its LLM (top-1 KB entry): starts in seconds, the bus side is the same
ENV = {"LLMLAND_REASONER_MODE": "retrieval"}


def example_config(mode: str, connect: list[str]) -> zenoh.Config:
    """What ``examples/common/common.py:get_config_from_args`` builds for ``--mode client -e ENDPOINT``."""
    conf = zenoh.Config()
    conf.insert_json5("mode", json.dumps(mode))
    conf.insert_json5("connect/endpoints", json.dumps(connect))
    return conf


@pytest.fixture(scope="module")
def running(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[int, Fleet]]:
    port = free_port()
    env = {**ENV, "LLMLAND_REASONER_HTTP_PORT": str(free_port())}
    logs = tmp_path_factory.mktemp("logs")
    with hub_bus(port) as hub, Fleet(port, DRONES, env=env, log_level="INFO", log_dir=logs) as fleet:
        fleet.start(["sim", "planner", "vle", "reasoner"])
        fleet.wait_alive(hub, timeout_s=240)
        yield port, fleet


def _bound_addresses(pid: int) -> list[tuple[str, str]]:
    """(pid/name, ip) of every listening TCP socket and bound UDP socket of ``pid`` and its children."""
    out = []
    root = psutil.Process(pid)
    for proc in [root, *root.children(recursive=True)]:
        for conn in proc.net_connections(kind="inet"):
            listening = conn.type == 1 and conn.status == psutil.CONN_LISTEN  # SOCK_STREAM
            udp_bound = conn.type == 2 and not conn.raddr  # SOCK_DGRAM
            if (listening or udp_bound) and conn.laddr:
                out.append((f"{proc.pid}/{proc.name()}", conn.laddr.ip))
    return out


def test_no_socket_of_a_running_stack_listens_beyond_loopback(running: tuple[int, Fleet]) -> None:
    import os

    _, fleet = running
    pids = [os.getpid(), *(p.pid for p in fleet.procs().values())]
    bound = [b for pid in pids for b in _bound_addresses(pid)]
    assert len({who for who, _ in bound}) >= len(fleet.procs()) + 1, bound  # every process listens somewhere
    outside = [(who, ip) for who, ip in bound if not ipaddress.ip_address(ip).is_loopback]
    assert outside == [], f"listening beyond loopback: {outside}"


def test_outside_tools_in_client_mode_subscribe_query_and_send_a_mission(
        running: tuple[int, Fleet], tmp_path: Path) -> None:
    """`z_sub -m client -e tcp/127.0.0.1:PORT -k 'llmland/**'` sees the flight (JSON and frames told apart by
    encoding), `z_get -s llmland/@ground/reasoner/spec -p CAPTION` gets a JSON spec, and `llmland mission`
    flies drone d1 on the running stack."""
    port, _ = running
    endpoint = hub_endpoint(port)
    encodings: dict[str, set[str]] = {}
    states: list[int] = []
    lock = threading.Lock()

    def listener(sample: zenoh.Sample) -> None:  # the example's callback, plus the encoding policy
        k, enc = str(sample.key_expr), str(sample.encoding)
        with lock:
            encodings.setdefault(k.split("/", 2)[2], set()).add(enc)
        if enc == "application/json" and k == key("d1", Topic.STATE):
            states.append(json.loads(sample.payload.to_string())["seq"])

    with zenoh.open(example_config("client", [endpoint])) as session:
        session.declare_subscriber("llmland/**", listener)
        replies = list(session.get(REASONER_SPEC_QUERY, payload="a man walking a dog", timeout=30.0))
        assert len(replies) == 1 and replies[0].ok is not None, replies
        assert str(replies[0].ok.encoding) == "application/json"
        assert json.loads(replies[0].ok.payload.to_string())["is_dynamic"] is True
        assert list(session.get("llmland/**", timeout=2.0)) == []  # a wildcard query reaches no queryable

        proc = run_cli("mission", "--world", "open_field", "--seed", "1", "--method", "baseline",
                       "--drone-id", "d1", "--connect", endpoint, "--timeout", "60", timeout=900)
        assert proc.returncode == 0, proc.stderr[-3000:]
        result = json.loads(proc.stdout)
        assert result["drone_id"] == "d1" and result["outcome"] == "landed", result
        time.sleep(0.5)
    with lock:
        assert encodings["sim/state"] == {"application/json"} and len(states) > 20
        assert encodings["sim/camera"] == {"application/octet-stream"}
        assert encodings["episode/result"] == {"application/json"}
        assert all(encs <= {"application/json", "application/octet-stream"} for encs in encodings.values())


def test_mission_without_a_stack_says_what_is_missing() -> None:
    proc = run_cli("mission", "--world", "open_field", "--seed", "1", "--connect", f"tcp/127.0.0.1:{free_port()}",
                   timeout=120)
    assert proc.returncode == 2
    assert "cannot reach the bus" in proc.stderr


def _mission_cmd(endpoint: str, drone: str, *extra: str) -> list[str]:
    return [str(BIN / "llmland"), "mission", "--world", "open_field", "--seed", "2", "--method", "baseline",
            "--drone-id", drone, "--connect", endpoint, *extra]


def test_a_mission_that_waits_too_long_is_stopped_not_flown_later(running: tuple[int, Fleet]) -> None:
    """A mission queued behind another one says so, and when its wall limit passes it is stopped:
    the sim does not fly it afterwards for no one (it did: the next mission then waited for it)."""
    port, fleet = running
    endpoint = hub_endpoint(port)
    # paced to real time, so that it is still flying 12 s of wall later on any machine (lockstep,
    # it landed (24.8 s flown) within 12 s of wall on a faster one, and the second mission flew)
    first = subprocess.Popen(_mission_cmd(endpoint, "d0", "--timeout", "40", "--clock", "realtime"),
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=REPO)
    try:
        time.sleep(8.0)  # the first is flying
        second = run_cli(*_mission_cmd(endpoint, "d0", "--wall-timeout", "4")[1:], timeout=120)
        assert second.returncode == 1, second.stderr[-2000:]
        assert "is flying episode" in second.stderr and "did not start episode" in second.stderr, second.stderr
        out, err = first.communicate(timeout=600)
    finally:
        first.kill()
    assert first.returncode == 0, err[-2000:]
    sim_log = fleet.drones["d0"].log_dir
    assert sim_log is not None
    time.sleep(1.0)
    assert "was stopped before it started: not flown" in (sim_log / "sim.log").read_text()


def test_a_mission_whose_sim_dies_ends_at_once(running: tuple[int, Fleet]) -> None:
    """The drone's sim gone mid-mission (its stack crashed or stopped): the client says so within
    seconds, exit 1 (it waited up to 30 min). Last in this module: it kills d1's sim."""
    port, fleet = running
    proc = subprocess.Popen(_mission_cmd(hub_endpoint(port), "d1", "--timeout", "60", "--clock", "realtime"),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=REPO)  # flying at 8 s
    try:
        time.sleep(8.0)
        fleet.procs()["d1/sim"].kill()
        killed_at = time.monotonic()
        _, err = proc.communicate(timeout=60)
    finally:
        proc.kill()
    assert proc.returncode == 1, err[-2000:]
    assert "sim is gone" in err and time.monotonic() - killed_at < 20.0, err[-2000:]

