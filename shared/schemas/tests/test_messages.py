import json
from typing import Any

import pytest
from llmland_schemas import (
    ControlCommand,
    EpisodeResult,
    MessageError,
    MissionGoal,
    SafetySpec,
    Topic,
    VehicleState,
    any_drone,
    decode,
    drone_of,
    encode,
    key,
)


def _state(position_m: tuple[float, float, float] = (0, 0, 1), **envelope: Any) -> VehicleState:
    """A vehicle at rest at ``position_m``; ``envelope``: any other fields (drone_id, stamp, ...)."""
    return VehicleState(position_m=position_m, velocity_mps=(0, 0, 0), quat_xyzw=(0, 0, 0, 1),
                        euler_rpy_rad=(0, 0, 0), body_rates_rps=(0, 0, 0), **envelope)


def test_round_trip_keeps_every_field():
    msg = _state(drone_id="d7", stamp=1.25, seq=42, episode_id="e1")
    back = decode(VehicleState, encode(msg))
    assert back == msg
    assert back.schema_version == 1


@pytest.mark.parametrize(
    "payload",
    [
        b"",
        b"not json",
        b'{"position_m": [0, 0]}',
        json.dumps({"thrust_n": -1.0, "body_rates_rps": [0, 0, 0], "state_seq": 1}).encode(),
        json.dumps({"thrust_n": 1.0, "body_rates_rps": [0, 0, 0], "state_seq": 1, "extra": 1}).encode(),
        b'{"thrust_n": NaN, "body_rates_rps": [0, 0, 0], "state_seq": 1}',
        json.dumps({"thrust_n": 1.0, "body_rates_rps": [0, 0, 0], "state_seq": 1, "schema_version": 99}).encode(),
    ],
)
def test_malformed_command_is_a_message_error(payload):
    with pytest.raises(MessageError):
        decode(ControlCommand, payload)


def test_non_finite_numbers_rejected_on_construction():
    with pytest.raises(ValueError):
        _state(position_m=(float("nan"), 0, 0))


def test_conservative_spec_is_the_most_careful_class():
    spec = SafetySpec.conservative("a blurry shape")
    assert spec.is_dynamic and spec.source == "fallback"
    assert spec.buffer_m >= 5.0 and spec.z_min >= 5.0


def test_keys():
    assert key("d0", Topic.STATE) == "llmland/d0/sim/state"
    assert any_drone(Topic.SCENE) == "llmland/*/vle/scene"
    assert drone_of("llmland/d3/reasoner/spec") == "d3"
    with pytest.raises(ValueError):
        key("a/b", Topic.STATE)
    with pytest.raises(ValueError):
        drone_of("other/d0/x")


def test_mission_and_result_defaults():
    m = MissionGoal(episode_id="x")
    assert m.clock == "lockstep" and m.world == "open_field"
    r = EpisodeResult(episode_id="x", world="open_field", seed=1, method="reference", clock="lockstep",
                      success=False, outcome="timeout")
    assert decode(EpisodeResult, encode(r)) == r
