"""A secured multi-host bus: two ``llmland-router``s, mutual TLS and access control (docs/network.md).

Topology (all on loopback, with throw-away certificates from ``scripts/gen_test_certs.py``)::

    drone d0's sim ──tcp──▶ drone router (cert d0) ══tls══▶ ground router (ACL) ◀══tls══ planner-d0, ground, d1

The ground router enforces the fleet policy: drone ``d0`` may publish only its own ``sim/*``,
``vle/*``, ``episode/*`` keys and receive its own ``planner/*``, ``reasoner/spec``, ``mission``;
only ``planner-d0`` publishes ``llmland/d0/planner/*``; only the ground station publishes specs
and missions.
"""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
import zenoh
from llmland_schemas import VLE_CAPTION_QUERY, ControlCommand, EpisodeResult, Topic, VehicleState, key
from llmland_schemas.bus import Bus, ZenohSettings

from llmland.episodes import EpisodeRunner
from llmland.launch import Stack, free_port
from llmland.stacks import StackConfig, make_mission

pytestmark = pytest.mark.integration

REPO = Path(__file__).resolve().parents[1]
IDENTITIES = ["router-ground", "ground", "d0", "d1", "planner-d0"]
ROUTER_START_S = 30.0
#: how long a refused message is given to (not) arrive
REFUSAL_WAIT_S = 2.0


@pytest.fixture(scope="module")
def certs(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("certs")
    subprocess.run([sys.executable, str(REPO / "scripts" / "gen_test_certs.py"), str(out),
                    "--names", ",".join(IDENTITIES)], check=True, capture_output=True, timeout=60)
    return out


def tls_env(certs: Path, name: str) -> dict[str, str]:
    return {"ZENOH_TLS_ROOT_CA": str(certs / "ca.pem"), "ZENOH_TLS_CERTIFICATE": str(certs / f"{name}.pem"),
            "ZENOH_TLS_PRIVATE_KEY": str(certs / f"{name}-key.pem")}


def tls_client(certs: Path, name: str | None, endpoint: str) -> ZenohSettings:
    """Client settings for ``endpoint`` with identity ``name`` (``None``: no certificate, CA only)."""
    cert, private_key = (certs / f"{name}.pem", certs / f"{name}-key.pem") if name else (None, None)
    return ZenohSettings(mode="client", connect=[endpoint], tls_root_ca=certs / "ca.pem", tls_certificate=cert,
                         tls_private_key=private_key)


def _wait_port(port: int, proc: subprocess.Popen[bytes]) -> None:
    deadline = time.monotonic() + ROUTER_START_S
    while time.monotonic() < deadline:
        assert proc.poll() is None, f"router exited with {proc.returncode}"
        try:
            socket.create_connection(("127.0.0.1", port), 0.5).close()
            return
        except OSError:
            time.sleep(0.2)
    raise TimeoutError(f"router on port {port} did not start")


@pytest.fixture(scope="module")
def routers(certs: Path) -> Iterator[tuple[str, str]]:
    """(ground router tls endpoint, drone router tcp endpoint); the drone router links to the ground's."""
    g_port, d_port = free_port(), free_port()
    ground_ep, drone_ep = f"tls/127.0.0.1:{g_port}", f"tcp/127.0.0.1:{d_port}"
    base = {k: v for k, v in os.environ.items() if not k.startswith(("ZENOH_", "LLMLAND_ROUTER_"))}
    ground = subprocess.Popen(
        [sys.executable, "-m", "llmland_schemas.router", "--listen", ground_ep],
        env={**base, **tls_env(certs, "router-ground"), "LLMLAND_ROUTER_ACL": "true",
             "LLMLAND_ROUTER_ACL_GROUND": "ground", "LLMLAND_ROUTER_ACL_DRONES": "d0,d1"})
    drone = None
    try:
        _wait_port(g_port, ground)
        drone = subprocess.Popen(
            [sys.executable, "-m", "llmland_schemas.router", "--listen", drone_ep, "--connect", ground_ep],
            env={**base, **tls_env(certs, "d0")})
        _wait_port(d_port, drone)
        yield ground_ep, drone_ep
    finally:
        for proc in (drone, ground):
            if proc is not None:
                proc.terminate()
                proc.wait(10)


def _state(seq: int) -> VehicleState:
    return VehicleState(drone_id="d0", seq=seq, position_m=(0, 0, 1), velocity_mps=(0, 0, 0),
                        quat_xyzw=(0, 0, 0, 1), euler_rpy_rad=(0, 0, 0), body_rates_rps=(0, 0, 0))


def _command(seq: int, drone: str = "d0") -> ControlCommand:
    return ControlCommand(drone_id=drone, seq=seq, state_seq=seq, body_rates_rps=(0, 0, 0), thrust_n=9.81)


def test_a_client_without_a_certificate_cannot_connect(certs: Path, routers: tuple[str, str]) -> None:
    ground_ep, _ = routers
    with pytest.raises(zenoh.ZError):
        Bus(tls_client(certs, None, ground_ep))  # trusts the CA but shows no certificate: mTLS refuses
    with pytest.raises(zenoh.ZError):
        Bus(ZenohSettings(mode="client", connect=[ground_ep.replace("tls/", "tcp/")]))  # plain TCP
    with Bus(tls_client(certs, "ground", ground_ep)) as ok:  # the same endpoint with a certificate
        assert ok.session.info.routers_zid()


def test_authorised_round_trip_and_refused_commands(certs: Path, routers: tuple[str, str]) -> None:
    """The drone's state reaches its planner and the planner's command the drone, across both routers;
    another drone, the ground station and the drone itself cannot publish ``llmland/d0/planner/command``."""
    ground_ep, drone_ep = routers
    commands: dict[int, ControlCommand] = {}
    got_state = threading.Event()
    got_cmd = threading.Event()
    with (Bus(ZenohSettings(mode="client", connect=[drone_ep])) as sim,
          Bus(tls_client(certs, "planner-d0", ground_ep)) as planner,
          Bus(tls_client(certs, "d1", ground_ep)) as rogue_drone,
          Bus(tls_client(certs, "ground", ground_ep)) as ground):

        def on_command(_k: str, cmd: ControlCommand) -> None:
            commands[cmd.seq] = cmd
            got_cmd.set()

        def on_state(_k: str, st: VehicleState) -> None:
            got_state.set()
            planner.publish(key("d0", Topic.COMMAND), _command(st.seq))

        sim.subscribe(key("d0", Topic.COMMAND), ControlCommand, on_command)
        planner.subscribe(key("d0", Topic.STATE), VehicleState, on_state)
        deadline = time.monotonic() + 20
        seq = 0
        while not got_cmd.is_set() and time.monotonic() < deadline:
            seq += 1
            sim.publish(key("d0", Topic.STATE), _state(seq))
            got_cmd.wait(0.2)
        assert got_state.is_set() and got_cmd.is_set(), "authorised state → command round trip failed"

        refused = {10_001: rogue_drone, 10_002: ground}
        for _ in range(5):
            for s, bus in refused.items():
                bus.publish(key("d0", Topic.COMMAND), _command(s))
            time.sleep(REFUSAL_WAIT_S / 5)
        sent_by_sim_side = 10_003  # the drone router (identity d0) forwards it: d0 may not command itself
        with Bus(ZenohSettings(mode="client", connect=[drone_ep])) as onboard:
            seen: list[int] = []
            planner.subscribe(key("d0", Topic.COMMAND), ControlCommand, lambda _k, c: seen.append(c.seq))
            time.sleep(0.5)
            for _ in range(5):
                onboard.publish(key("d0", Topic.COMMAND), _command(sent_by_sim_side))
                time.sleep(REFUSAL_WAIT_S / 5)
        assert not set(refused) & set(commands), "a refused identity's command reached the drone"
        assert sent_by_sim_side not in seen, "the drone's own planner/command crossed the ground router"
        assert planner.dropped.total() == 0 and sim.dropped.total() == 0


def test_an_authorised_drone_flies_an_episode_through_two_tls_routers(
        certs: Path, routers: tuple[str, str], tmp_path: Path) -> None:
    """Sim on the drone router (plain TCP on loopback), planner and mission sender as TLS clients of the
    ground router (identities ``planner-d0`` and ``ground``): a baseline landing, seed 1."""
    ground_ep, drone_ep = routers
    client = {"ZENOH_MODE": "client", "ZENOH_LISTEN": ""}
    sim = Stack(0, "d0", env={**client, "ZENOH_CONNECT": drone_ep}, log_level="INFO", log_dir=tmp_path / "sim")
    planner = Stack(0, "d0", env={**client, "ZENOH_CONNECT": ground_ep, **tls_env(certs, "planner-d0")},
                    log_level="INFO", log_dir=tmp_path / "planner")
    with sim, planner, Bus(tls_client(certs, "ground", ground_ep)) as bus:
        sim.start(["sim"])
        planner.start(["planner"])
        sim.wait_alive(bus, timeout_s=120)
        planner.wait_alive(bus, timeout_s=120)
        mission = make_mission(StackConfig(method="baseline"), world="open_field", seed=1, timeout_s=60.0)
        result: EpisodeResult = EpisodeRunner(bus, "d0").run(mission, wall_timeout_s=600)
    assert result.outcome == "landed" and result.success, result


def test_only_the_ground_station_publishes_specs_and_drones_serve_captions(
        certs: Path, routers: tuple[str, str]) -> None:
    ground_ep, drone_ep = routers
    specs: list[str] = []
    with (Bus(ZenohSettings(mode="client", connect=[drone_ep])) as drone,
          Bus(tls_client(certs, "d1", ground_ep)) as rogue_drone,
          Bus(tls_client(certs, "ground", ground_ep)) as ground):
        drone.session.declare_subscriber(key("d0", Topic.SPEC), lambda s: specs.append(s.payload.to_string()))
        drone.queryable(VLE_CAPTION_QUERY, lambda q: q.reply(VLE_CAPTION_QUERY, b'{"caption": "a field"}'))
        deadline = time.monotonic() + 20
        while "ground" not in specs and time.monotonic() < deadline:
            rogue_drone.session.put(key("d0", Topic.SPEC), "d1")
            ground.session.put(key("d0", Topic.SPEC), "ground")
            time.sleep(0.2)
        replies = list(ground.session.get(VLE_CAPTION_QUERY, payload=b"png", timeout=10.0))
    assert "ground" in specs and "d1" not in specs
    assert len(replies) == 1 and replies[0].ok is not None
    assert str(replies[0].ok.encoding) == "application/json"


@pytest.mark.parametrize(("service", "identity"), [("sim", "d0"), ("planner", "planner-d0")])
def test_compose_health_checks_pass_under_access_control(
        certs: Path, routers: tuple[str, str], service: str, identity: str) -> None:
    """compose's health check (``python -m llmland_schemas.health SERVICE d0``) runs with the container's own
    identity: it must see its service's liveliness token through the ground router."""
    ground_ep, _ = routers
    env = {**{k: v for k, v in os.environ.items() if not k.startswith("ZENOH_")}, **tls_env(certs, identity),
           "ZENOH_MODE": "client", "ZENOH_CONNECT": ground_ep}
    with Bus(tls_client(certs, identity, ground_ep)) as svc:
        svc.announce(f"llmland/d0/alive/{service}")
        rc = 1
        for _ in range(3):
            rc = subprocess.run([sys.executable, "-m", "llmland_schemas.health", service, "d0"], env=env,
                                timeout=60).returncode
            if rc == 0:
                break
    assert rc == 0


def test_a_drone_cannot_pose_as_a_shared_service_or_another_drone(certs: Path, routers: tuple[str, str]) -> None:
    ground_ep, _ = routers
    with (Bus(tls_client(certs, "d1", ground_ep)) as rogue, Bus(tls_client(certs, "ground", ground_ep)) as ground):
        rogue.announce("llmland/@ground/alive/reasoner")
        rogue.announce("llmland/d0/alive/sim")
        rogue.announce("llmland/d1/alive/sim")  # its own: allowed
        seen: set[str] = set()
        deadline = time.monotonic() + 10
        while "llmland/d1/alive/sim" not in seen and time.monotonic() < deadline:
            seen = ground.alive("llmland/*/alive/*", 0.5) | ground.alive("llmland/@ground/alive/*", 0.5)
    assert seen == {"llmland/d1/alive/sim"}
