"""Fault runs (issue 9): perception dies mid-episode; the drone lands or holds, never within 1 m of
a person, and the EpisodeResult names the fault."""

from __future__ import annotations

import pytest

from llmland.stacks import StackConfig, make_mission, open_stack

pytestmark = pytest.mark.integration

#: a request unanswered this long (s, wall) counts as lost (the default is 15 s)
PERCEPTION_TIMEOUT_S = 2.0
ENV = {"LLMLAND_SIM_PERCEPTION_TIMEOUT_S": str(PERCEPTION_TIMEOUT_S)}
#: sim time (s) at which the service is killed
KILL_AT_S = 6.0
#: the camera's frame period (s, sim): the sim's default 5 Hz
FRAME_PERIOD_S = 0.2
#: slack (s, sim) for the sim's tick and the bus's delivery of the state the kill time is read from
SLACK_S = 0.5


@pytest.mark.parametrize("service", ["reasoner", "vle"])
def test_perception_killed_mid_episode(service: str) -> None:
    cfg = StackConfig("llm-land", "pipeline")
    with open_stack(cfg, env=ENV) as running:
        running.kill_at(service, KILL_AT_S)
        r = running.run(make_mission(cfg, world="open_field", seed=2, timeout_s=30.0))
        assert running.stack.procs[service].poll() is not None  # it really died
    assert r.outcome in ("landed", "timeout"), r
    assert r.close_calls == 0 and r.collisions == []
    assert min(r.min_person_distance_m.values()) >= 1.0
    assert r.perception_degraded and r.perception_lost >= 1
    # Degraded from the kill to the episode's end, whenever that was (with the measured latency the
    # landing time moves with the machine's load). A request is counted lost PERCEPTION_TIMEOUT_S of
    # wall after it was sent, and the sim runs no faster than real time while it waits. The first
    # request the dead service cannot answer is the one outstanding at the kill, or the first frame
    # after the release of the last answered one: that release is at most PERCEPTION_TIMEOUT_S after
    # the kill (a longer latency is itself a loss), and the frame comes within a frame period of it.
    # (The bound without that release failed by 0.08 s at load ~5: an answer measured at ≈ 0.8 s.)
    killed_s = running.killed_at_s[service]
    degraded_from_s = r.sim_time_s - r.perception_degraded_s
    latest_s = killed_s + PERCEPTION_TIMEOUT_S + FRAME_PERIOD_S + PERCEPTION_TIMEOUT_S + SLACK_S
    assert KILL_AT_S <= killed_s <= degraded_from_s <= latest_s, (killed_s, r)
    assert r.services_killed_at_s == {service: round(killed_s, 3)}  # the result names the fault
    assert r.spec_latency_ms_mean is not None  # specs did arrive before the fault


def test_a_sim_that_dies_ends_the_wait_at_once() -> None:
    """A sim that exits mid-episode (a crash, a kill) can send no result: the wait ends with a
    RuntimeError within seconds, not after the wall limit (was up to 30 min: `land --rrd <folder>`
    crashed the sim at its first frame and the command hung)."""
    import os
    import signal
    import time

    cfg = StackConfig("baseline", "none")
    with open_stack(cfg) as running:
        sim = running.stack.procs["sim"]
        t0 = time.monotonic()
        os.killpg(sim.pid, signal.SIGKILL)  # not through kill(): unasked, as a crash
        with pytest.raises(RuntimeError, match="the sim exited"):
            running.run(make_mission(cfg, world="open_field", seed=1, timeout_s=60.0))
        assert time.monotonic() - t0 < 30.0  # the wall limit is 20 min


def test_a_killed_planner_costs_no_wall_time_per_tick() -> None:
    """Once the planner's liveliness token is gone, a lockstep tick stops waiting for its command:
    the vehicle flies its failsafe as before (every tick after the kill a missing command), and a
    sim second costs far less than one of wall (was 50 ms a tick: 30 s flown in 85 s of wall)."""
    import time

    cfg = StackConfig("baseline", "none")
    with open_stack(cfg) as running:
        running.kill_at("planner", 3.0)
        t0 = time.monotonic()
        r = running.run(make_mission(cfg, world="open_field", seed=1, timeout_s=30.0))
        wall_s = time.monotonic() - t0
    assert r.outcome == "timeout" and r.close_calls == 0 and min(r.min_person_distance_m.values()) >= 1.0, r
    assert r.commands_missing >= 25 * 50, r  # 25 of the 30 s without a planner, 50 ticks a second
    assert list(r.services_killed_at_s) == ["planner"] and r.services_killed_at_s["planner"] >= 3.0, r
    assert wall_s < 1.5 * r.sim_time_s, wall_s  # 2.8x before; ≈ 0.55x on the 2-core machine
