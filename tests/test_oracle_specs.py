"""Specs from ground truth: every perceived frame is answered, whatever order the messages come in."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from llmland_schemas import (
    CameraFrameHeader,
    CameraIntrinsics,
    GroundTruth,
    MissionGoal,
    SafetySpecMessage,
    TruthObject,
)

from llmland.oracle_specs import DEFAULT_SPECS, OracleSpecPublisher


class RecordingBus:
    """Unit-test stand-in for the bus: hands out the callbacks, records what is published."""

    def __init__(self) -> None:
        self.callbacks: dict[str, Callable[[str, Any], None]] = {}
        self.published: list[SafetySpecMessage] = []

    def subscribe(self, key: str, _model: type, callback: Callable[[str, Any], None]) -> None:
        self.callbacks[key.rsplit("/", 1)[-1]] = callback

    def subscribe_parsed(self, key: str, _parse: Callable[..., Any], callback: Callable[[str, Any], None]) -> None:
        self.callbacks[key.rsplit("/", 1)[-1]] = callback

    def publish(self, _key: str, msg: SafetySpecMessage, **_: Any) -> None:
        self.published.append(msg)


def _messages(episode: str = "e1") -> tuple[MissionGoal, GroundTruth, CameraFrameHeader]:
    mission = MissionGoal(episode_id=episode, method="llm-land")
    person = TruthObject(obj_id="person_0", cls="person", position_m=(3.0, 0.0, 0.9), size_m=(0.5, 0.5, 1.8))
    truth = GroundTruth(world="open_field", target_m=(0.0, 0.0, 0.0), objects=[person], episode_id=episode)
    k = CameraIntrinsics.from_hfov(64, 64, 90.0)
    frame = CameraFrameHeader(stamp=0.0, seq=0, width=64, height=64, intrinsics=k, T_world_camera=[0.0] * 16,
                              episode_id=episode)
    return mission, truth, frame


def _deliver(bus: RecordingBus, order: str, msgs: tuple[MissionGoal, GroundTruth, CameraFrameHeader]) -> None:
    topic = {"m": ("mission", msgs[0]), "t": ("truth", msgs[1]), "f": ("camera", msgs[2])}
    for c in order:
        name, msg = topic[c]
        bus.callbacks[next(k for k in bus.callbacks if k == name)]("k", msg)


def test_a_frame_before_its_mission_or_truth_is_answered_when_they_arrive() -> None:
    # The first frame of an episode reached the oracle before the mission: it was dropped, the
    # sim waited 15 s of wall time for its spec and marked perception degraded (seen under load).
    for order in ("mtf", "fmt", "ftm", "mft", "tmf", "tfm"):
        bus = RecordingBus()
        OracleSpecPublisher(bus)  # type: ignore[arg-type]
        _deliver(bus, order, _messages())
        assert len(bus.published) == 1, order
        (msg,) = bus.published
        assert msg.frame_seq == 0 and msg.episode_id == "e1"
        assert msg.objects[0].spec == DEFAULT_SPECS["person"]


def test_frames_of_another_episode_are_not_answered_with_this_ones_truth() -> None:
    bus = RecordingBus()
    OracleSpecPublisher(bus)  # type: ignore[arg-type]
    mission, truth, _ = _messages("e1")
    _, _, other = _messages("e2")
    _deliver(bus, "f", (mission, truth, other))
    _deliver(bus, "mt", (mission, truth, other))
    assert bus.published == []
