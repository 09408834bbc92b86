"""Latency-faithful lockstep (DESIGN §4): the perception clock without a bus."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest
from llmland_sim.perception_clock import LatencyModel, PerceptionClock

STOP = threading.Event()


def _drawn_s(model: LatencyModel, rng: np.random.Generator) -> float:
    """A drawn latency: ``fixed`` and ``normal`` models always draw one."""
    s = model.sample_s(rng)
    assert s is not None
    return s


def test_latency_models_parse_and_sample() -> None:
    rng = np.random.default_rng(0)
    assert LatencyModel.parse("measured").sample_s(rng) is None
    assert LatencyModel.parse("fixed:1453.6").sample_s(rng) == pytest.approx(1.4536)
    normal = LatencyModel.parse("normal:200,50")
    draws = [_drawn_s(normal, rng) for _ in range(2000)]
    assert np.mean(draws) == pytest.approx(0.2, abs=0.01) and min(draws) >= 0.0
    for bad in ("fixed", "fixed:-1", "normal:200", "gaussian:1,2", "fixed:1e3"):
        with pytest.raises(ValueError):
            LatencyModel.parse(bad)


def test_normal_draws_are_seeded() -> None:
    def draws(seed: int) -> list[float]:
        clock = PerceptionClock(LatencyModel.parse("normal:300,100"), seed, timeout_s=5.0)
        out = []
        for k in range(5):
            clock.on_frame_sent(k, 0.2 * k)
            assert clock._inflight is not None and clock._inflight.release_s is not None
            out.append(clock._inflight.release_s)
            clock.on_spec(k, 1.0, 0.2 * k)
        return out

    assert draws(7) == draws(7) and draws(7) != draws(8)


def test_modelled_latency_is_one_server_and_releases_at_stamp_plus_latency() -> None:
    clock = PerceptionClock(LatencyModel.parse("fixed:300"), seed=1, timeout_s=5.0)
    assert clock.should_perceive(0.0)
    clock.on_frame_sent(0, 0.0)
    clock.wait_before(0.2, STOP)  # before the release: free running, returns at once
    assert not clock.should_perceive(0.2)  # busy until 0.3
    arrived: list[float] = []

    def deliver() -> None:
        arrived.append(time.perf_counter())
        clock.on_spec(0, 12.0, 0.2)

    threading.Timer(0.05, deliver).start()
    clock.wait_before(0.3, STOP)  # at the release: waits for the real spec
    returned = time.perf_counter()
    # it returned only once the spec was in (no wall-time bound: a loaded machine can delay the
    # timer past any bound, and then the wait is simply longer)
    assert arrived and arrived[0] <= returned
    assert clock.released_upto_s(0.29) is None and clock.released_upto_s(0.3) == 0.0
    assert clock.should_perceive(0.4)
    assert clock.effective_latency_ms == [pytest.approx(300.0)] and clock.compute_ms == [12.0]


def test_measured_latency_paces_the_sim_no_faster_than_real_time() -> None:
    clock = PerceptionClock(LatencyModel.parse("measured"), seed=1, timeout_s=5.0)
    t0 = time.perf_counter()  # before the send: the pacing counts from the send, never earlier
    clock.on_frame_sent(0, 1.0)
    clock.wait_before(1.1, STOP)  # 0.1 s of sim after the frame needs 0.1 s of wall time
    assert time.perf_counter() - t0 >= 0.1
    clock.on_spec(0, 5.0, 1.1)
    latency_s = clock.effective_latency_ms[0] / 1e3
    assert latency_s >= 0.1  # end to end, never in the past of the sim clock
    assert clock.released_upto_s(1.0 + latency_s - 1e-3) is None  # (queries go forward in time)
    assert clock.released_upto_s(1.0 + latency_s) == 1.0


def test_unanswered_request_times_out_into_degraded_and_recovers() -> None:
    clock = PerceptionClock(LatencyModel.parse("fixed:100"), seed=1, timeout_s=0.1)
    clock.on_frame_sent(0, 0.0)
    clock.wait_before(0.2, STOP)  # no spec: abandoned after 0.1 s wall
    assert clock.lost == 1 and clock.degraded_since_s == 0.2
    assert clock.should_perceive(0.4)
    clock.on_frame_sent(1, 0.4)  # a probe: never holds the sim back
    t0 = time.perf_counter()
    clock.wait_before(5.0, STOP)
    assert time.perf_counter() - t0 < 1.0  # not the 5 s wait (loose: CI load)
    clock.on_spec(1, 3.0, 2.0)  # perception is back at sim time 2.0
    clock.finish(3.0)
    assert clock.ever_degraded and clock.degraded_s == pytest.approx(1.8)
    assert clock.released_upto_s(2.0) == 0.4  # late: applies from its arrival, not in the past


def test_specs_for_other_frames_are_ignored() -> None:
    clock = PerceptionClock(LatencyModel.parse("fixed:100"), seed=1, timeout_s=5.0)
    clock.on_frame_sent(3, 0.6)
    clock.on_spec(2, 1.0, 0.6)
    clock.on_spec(3, 1.0, 0.6)
    clock.on_spec(3, 1.0, 0.6)  # duplicate
    assert clock.requests == 1 and len(clock.effective_latency_ms) == 1
