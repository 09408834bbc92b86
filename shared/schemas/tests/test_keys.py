"""Key space and encoding policy (docs/network.md): shared services under ``llmland/@ground/...``,
validated drone ids, queryables that wildcard queries do not reach, JSON vs octet-stream."""

from __future__ import annotations

import socket
import threading
import time
from collections.abc import Iterator

import pytest
import zenoh
from llmland_schemas import (
    REASONER_SPEC_QUERY,
    VLE_CAPTION_QUERY,
    Topic,
    VehicleState,
    alive,
    any_drone,
    drone_of,
    encode,
    ground_alive,
    key,
    validate_drone_id,
)
from llmland_schemas.bus import Bus, ZenohSettings, is_json
from llmland_schemas.keys import GROUND_PREFIX, alive_selector, is_shared

STATE = VehicleState(drone_id="d0", seq=1, position_m=(0, 0, 1), velocity_mps=(0, 0, 0), quat_xyzw=(0, 0, 0, 1),
                     euler_rpy_rad=(0, 0, 0), body_rates_rps=(0, 0, 0))


def test_shared_services_live_under_the_ground_prefix() -> None:
    assert REASONER_SPEC_QUERY == "llmland/@ground/reasoner/spec"
    assert VLE_CAPTION_QUERY == "llmland/@ground/vle/caption"
    assert ground_alive("reasoner") == "llmland/@ground/alive/reasoner"
    assert alive_selector("reasoner") == ground_alive("reasoner")
    assert alive_selector("sim") == "llmland/*/alive/sim" and alive_selector("sim", "d3") == alive("d3", "sim")
    assert is_shared(REASONER_SPEC_QUERY) and not is_shared(key("d0", Topic.SPEC))
    with pytest.raises(ValueError, match="shared-service key"):
        drone_of(REASONER_SPEC_QUERY)
    assert drone_of(key("uav-7", Topic.SPEC)) == "uav-7"


@pytest.mark.parametrize("bad", ["", "@ground", "a/b", "*", "**", "d$0", "d?0", "d#0", "-d0", "d 0", "x" * 65])
def test_invalid_drone_ids_are_refused(bad: str) -> None:
    with pytest.raises(ValueError, match="invalid drone id"):
        validate_drone_id(bad)
    with pytest.raises(ValueError):
        key(bad, Topic.STATE)


@pytest.mark.parametrize("ok", ["d0", "ground", "reasoner", "uav-7", "Fleet_A.3"])
def test_valid_drone_ids_cannot_reach_the_shared_space(ok: str) -> None:
    k = zenoh.KeyExpr(key(ok, Topic.SPEC))
    assert not k.intersects(zenoh.KeyExpr(f"{GROUND_PREFIX}/**"))


def test_drone_wildcards_never_match_the_ground_prefix() -> None:
    for selector in (any_drone(Topic.SPEC), "llmland/**", "llmland/*/alive/*", "**"):
        assert not zenoh.KeyExpr(selector).intersects(zenoh.KeyExpr(REASONER_SPEC_QUERY)), selector


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@pytest.fixture()
def pair() -> Iterator[tuple[Bus, Bus]]:
    port = _free_port()
    a = Bus(ZenohSettings(listen=[f"tcp/127.0.0.1:{port}"], connect=[]))
    b = Bus(ZenohSettings(mode="client", connect=[f"tcp/127.0.0.1:{port}"]))
    yield a, b
    b.close()
    a.close()


def test_wildcard_queries_do_not_trigger_a_shared_queryable(pair: tuple[Bus, Bus]) -> None:
    server, client = pair
    asked: list[str] = []

    def handler(q: zenoh.Query) -> None:
        asked.append(str(q.selector))
        q.reply(REASONER_SPEC_QUERY, encode(STATE))  # the handler names no encoding: JSON by policy

    server.queryable(REASONER_SPEC_QUERY, handler)
    time.sleep(0.3)
    for selector in ("llmland/**", "**", "llmland/*/reasoner/spec"):
        assert list(client.session.get(selector, timeout=1.0)) == [], selector
    assert asked == []
    replies = list(client.session.get(REASONER_SPEC_QUERY, timeout=5.0))
    assert len(replies) == 1 and replies[0].ok is not None
    assert str(replies[0].ok.encoding) == "application/json"
    assert asked == [REASONER_SPEC_QUERY]


def test_a_failing_queryable_replies_an_error_as_text(pair: tuple[Bus, Bus]) -> None:
    server, client = pair

    def handler(_q: zenoh.Query) -> None:
        raise RuntimeError("model exploded")

    server.queryable(VLE_CAPTION_QUERY, handler)
    time.sleep(0.3)
    replies = list(client.session.get(VLE_CAPTION_QUERY, timeout=5.0))
    assert len(replies) == 1 and replies[0].err is not None
    assert str(replies[0].err.encoding) == "text/plain"
    assert "model exploded" in replies[0].err.payload.to_string()


def test_puts_say_json_and_frames_say_octet_stream(pair: tuple[Bus, Bus]) -> None:
    """A generic subscriber on ``llmland/**`` can tell a JSON message from a camera frame by its encoding."""
    server, client = pair
    seen: dict[str, str] = {}
    done = threading.Event()

    def on_sample(sample: zenoh.Sample) -> None:
        seen[str(sample.key_expr)] = str(sample.encoding)
        if len(seen) == 2:
            done.set()

    handle = server.session.declare_subscriber("llmland/**", on_sample)
    time.sleep(0.3)
    frame = b"\x00\xffpixels"  # any frame bytes
    for _ in range(25):
        client.publish(key("d0", Topic.STATE), STATE)
        client.publish_bytes(key("d0", Topic.CAMERA), frame)
        if done.wait(0.2):
            break
    handle.undeclare()
    assert seen == {key("d0", Topic.STATE): "application/json", key("d0", Topic.CAMERA): "application/octet-stream"}


def test_json_subscribers_drop_frames_but_accept_untyped_json(pair: tuple[Bus, Bus]) -> None:
    server, client = pair
    got: list[int] = []
    ev = threading.Event()
    k = key("d0", Topic.STATE)

    def on_state(_k: str, m: VehicleState) -> None:
        got.append(m.seq)
        ev.set()

    server.subscribe(k, VehicleState, on_state)
    time.sleep(0.3)
    client.publish_bytes(k, encode(STATE))  # JSON text, but announced as a binary frame: refused
    client.session.put(k, encode(STATE.model_copy(update={"seq": 2})))  # what `z_put` sends: zenoh/bytes
    assert ev.wait(5)
    assert got == [2] and server.dropped[k] == 1
    assert is_json(zenoh.Encoding.APPLICATION_JSON) and is_json(zenoh.Encoding.ZENOH_BYTES)
    assert not is_json(zenoh.Encoding.APPLICATION_OCTET_STREAM)
