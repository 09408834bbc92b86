"""Latency-faithful lockstep (DESIGN §4): when perception results take effect in sim time.

The sim owns the clock. Perception (VLE captions → reasoner specs, or the oracle) is modelled
as one server that takes a camera frame and, after a latency, delivers a spec:

- a frame is sent *for perception* (``perceive`` in its header) only when the server is free:
  no request is outstanding and the previous result has been released. Every other frame still
  goes to the planner for depth tracking. The choice depends only on sim time and the latency
  model, so which frames are perceived is reproducible;
- a spec computed from a frame stamped ``t_f`` takes effect at sim time ``t_f + L``. With the
  ``measured`` model ``L`` is the wall time from sending the frame to receiving its spec (the
  real end-to-end latency on this machine: queueing, bus, captioning, reasoning); while such a
  request is outstanding the sim runs no faster than real time from the frame on, so ``t_f + L``
  is never in the past when the spec arrives. With ``fixed:<ms>`` or ``normal:<mean>,<sd>``
  ``L`` comes from the model (seeded): the sim runs at full speed and only waits, at
  ``t_f + L``, for the real spec if it has not arrived yet — a replay of other hardware
  (the paper's GPU timings) that gives the same episode for the same seed;
- the sim tells the planner, in each state, the stamp up to which specs are in effect
  (``VehicleState.specs_released_upto_s``), so the release does not depend on bus timing;
- a request unanswered for ``timeout_s`` of wall time is abandoned and perception counts as
  *degraded* (the VLE or reasoner is down) until a spec arrives again; degraded requests never
  hold the sim back. The planner meanwhile lets specs go stale and falls back to the most
  conservative class (never less careful).
"""

from __future__ import annotations

import math
import re
import threading
import time
from dataclasses import dataclass

import numpy as np
from llmland_schemas.messages import LATENCY_MODEL_PATTERN

#: how long (s, wall) the sim sleeps at most between checks while it waits for perception
POLL_S = 0.05
#: sim times closer than this (s) are the same instant (sums of physics steps drift)
EPS_S = 1e-9


@dataclass(frozen=True)
class LatencyModel:
    """Perception latency: measured on this machine, or drawn from a model (ms)."""

    kind: str  # measured | fixed | normal
    mean_ms: float = 0.0
    sd_ms: float = 0.0

    @classmethod
    def parse(cls, text: str) -> LatencyModel:
        """``measured`` | ``fixed:1453.6`` | ``normal:1453.6,120``; ValueError otherwise."""
        if not re.match(LATENCY_MODEL_PATTERN, text):
            raise ValueError(f"latency model must be measured, fixed:<ms> or normal:<mean_ms>,<sd_ms>; got {text!r}")
        kind, _, rest = text.partition(":")
        if kind == "measured":
            return cls("measured")
        if kind == "fixed":
            return cls("fixed", float(rest))
        mean, sd = (float(x) for x in rest.split(","))
        return cls("normal", mean, sd)

    def sample_s(self, rng: np.random.Generator) -> float | None:
        """A latency in seconds, or None for ``measured`` (known only when the spec arrives)."""
        if self.kind == "measured":
            return None
        if self.kind == "fixed":
            return self.mean_ms / 1e3
        return max(0.0, float(rng.normal(self.mean_ms, self.sd_ms))) / 1e3


@dataclass
class Request:
    frame_seq: int
    stamp_s: float
    sent_wall_s: float
    model_latency_s: float | None  # from the model; None: measured
    release_s: float | None = None  # set when the spec arrived (measured) or at send (model)
    arrived: bool = False
    compute_ms: float | None = None  # what the producer reported (VLE + reasoner)
    abandoned: bool = False


class PerceptionClock:
    """Per-episode bookkeeping; thread-safe (specs arrive on the bus thread)."""

    def __init__(self, model: LatencyModel, seed: int, timeout_s: float) -> None:
        self.model = model
        self.timeout_s = timeout_s
        self._rng = np.random.default_rng([seed, 0x1A7E])
        self._cond = threading.Condition()
        self._inflight: Request | None = None
        self._last_release_s = -math.inf
        self._released: list[Request] = []  # arrived, release known, in release order
        self._n_effective = 0  # how many of them are in effect at the last queried time
        self.requests = 0
        self.lost = 0
        self.degraded_since_s: float | None = None
        self.degraded_s = 0.0
        self.ever_degraded = False
        self.effective_latency_ms: list[float] = []
        self.compute_ms: list[float] = []

    # ------------------------------------------------------------------ frames
    def should_perceive(self, t_s: float) -> bool:
        """Send the frame at ``t_s`` for perception? Only when the server is free.

        Call :meth:`wait_before` for ``t_s`` first: with a modelled latency the server is free
        from the previous request's release on, and ``wait_before`` has then made sure its spec
        arrived, so the answer never depends on bus timing.
        """
        with self._cond:
            req = self._inflight
            if req is not None and not req.abandoned:
                if req.release_s is None or t_s < req.release_s - EPS_S:
                    return False  # measured and unanswered, or modelled and not yet released
            return t_s >= self._last_release_s - EPS_S

    def on_frame_sent(self, frame_seq: int, stamp_s: float) -> None:
        with self._cond:
            latency = self.model.sample_s(self._rng)
            req = Request(frame_seq, stamp_s, time.perf_counter(), latency)
            if latency is not None:
                req.release_s = stamp_s + latency
            # While degraded, requests are probes: they never hold the sim back, and the first
            # answer to one ends the degraded interval.
            req.abandoned = self.degraded_since_s is not None
            self._inflight = req
            self.requests += 1

    # ------------------------------------------------------------------ specs
    def on_spec(self, frame_seq: int, compute_ms: float, t_now_s: float) -> None:
        """A spec for frame ``frame_seq`` arrived (bus thread). ``t_now_s``: the sim time now."""
        with self._cond:
            req = self._inflight
            if req is None or req.frame_seq != frame_seq or req.arrived:
                return  # not ours, or a duplicate
            req.arrived = True
            req.compute_ms = compute_ms
            if req.release_s is None:  # measured: the end-to-end wall latency
                req.release_s = req.stamp_s + (time.perf_counter() - req.sent_wall_s)
            if req.abandoned:  # late answer after a timeout: applies from now, never in the past
                req.release_s = max(req.release_s, t_now_s)
            self._end_degraded(t_now_s)
            self._inflight = None
            self._last_release_s = req.release_s
            self._released.append(req)
            self.effective_latency_ms.append(1e3 * (req.release_s - req.stamp_s))
            self.compute_ms.append(compute_ms)
            self._cond.notify_all()

    # ------------------------------------------------------------------ stepping
    def wait_before(self, t_s: float, stop: threading.Event) -> None:
        """Block until the sim may publish the state at ``t_s`` (see the module docstring)."""
        with self._cond:
            while not stop.is_set():
                req = self._inflight
                if req is None or req.arrived or req.abandoned:
                    return
                elapsed = time.perf_counter() - req.sent_wall_s
                if elapsed > self.timeout_s:
                    req.abandoned = True
                    self.lost += 1
                    self._start_degraded(t_s)
                    return
                if req.release_s is None:  # measured: no faster than real time from the frame on
                    if t_s <= req.stamp_s + elapsed:
                        return
                    wait = max(1e-4, min(POLL_S, t_s - (req.stamp_s + elapsed)))
                elif t_s < req.release_s - EPS_S:  # modelled latency: free running until the release
                    return
                else:
                    wait = POLL_S
                self._cond.wait(wait)

    def released_upto_s(self, t_s: float) -> float | None:
        """Newest frame stamp whose spec is in effect at ``t_s`` (None: none yet)."""
        with self._cond:
            # Requests are served one at a time, so releases come in order: advance a cursor.
            while (self._n_effective < len(self._released)
                   and (self._released[self._n_effective].release_s or math.inf) <= t_s + EPS_S):
                self._n_effective += 1
            return self._released[self._n_effective - 1].stamp_s if self._n_effective else None

    # ------------------------------------------------------------------ degraded
    def _start_degraded(self, t_s: float) -> None:
        if self.degraded_since_s is None:
            self.degraded_since_s = t_s
            self.ever_degraded = True

    def _end_degraded(self, t_s: float) -> None:
        if self.degraded_since_s is not None:
            self.degraded_s += max(0.0, t_s - self.degraded_since_s)
            self.degraded_since_s = None

    def finish(self, t_s: float) -> None:
        """Close the episode's degraded interval at its end."""
        with self._cond:
            self._end_degraded(t_s)
