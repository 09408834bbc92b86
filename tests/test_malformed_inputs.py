"""Garbage on every subscribed key: logged, counted, dropped; services keep running."""

from __future__ import annotations

import time
from pathlib import Path

import pytest
from llmland_schemas import MissionGoal, Topic, key

from llmland.episodes import EpisodeRunner, new_episode_id

pytestmark = pytest.mark.integration

GARBAGE = [b"", b"\x00\x01\x02", b"{not json", b'{"seq": -5}', b'{"thrust_n": "NaN"}', b"[" * 10_000]


def test_services_survive_garbage_and_still_fly(hub, stack_factory, tmp_path: Path) -> None:
    stack = stack_factory(["sim", "pilot"])
    stack.wait_alive(hub)
    for topic in (Topic.MISSION, Topic.COMMAND, Topic.STATE, Topic.PLAN, Topic.SCENE, Topic.SPEC):
        for payload in GARBAGE:
            # block: a burst of 36 messages (six of 10 kB) may fill Zenoh's queue, and a droppable
            # put would then lose one before the service could count it
            hub.publish_bytes(key("d0", topic), payload, block=True)
    time.sleep(1.0)
    for name, proc in stack.procs.items():
        assert proc.poll() is None, f"{name} died on garbage"
    stack.wait_alive(hub, timeout_s=5)

    runner = EpisodeRunner(hub)
    mission = MissionGoal(episode_id=new_episode_id("open_field", 3, "reference"), seed=3, timeout_s=40)
    result = runner.run(mission)
    assert result.outcome in ("landed", "off_target", "close_call")

    stack.stop()
    logs = {p.stem: p.read_text() for p in (tmp_path / "logs").glob("*.log")}
    # every subscribed key of each service logged its drops with a running count
    for topic in ("mission", "planner/command", "planner/plan", "vle/scene", "reasoner/spec"):
        assert f"dropped malformed message on llmland/d0/{topic} ({len(GARBAGE)} so far)" in logs["sim"], topic
    for topic in ("mission", "sim/state"):
        assert f"dropped malformed message on llmland/d0/{topic} ({len(GARBAGE)} so far)" in logs["pilot"], topic
