"""Tracking depth-image obstacles (:class:`llmland_schemas.depth.Blob`) over frames.

Each frame's blobs are associated with the existing tracks by their horizontal centroid
distance (world frame, metres) to the tracks' constant-velocity predictions, with an optimal
assignment (``scipy.optimize.linear_sum_assignment``) gated at ``gate_m``. Matched tracks take
the new bounds and centroid; their horizontal velocity (m/s, z velocity is 0) is the
exponentially smoothed centroid difference over time. Unmatched blobs start new tracks
``"t0"``, ``"t1"``, …

Rigid motion: the centroid of a *visible surface* moves when more or less of a still object
comes into view (a parked car seen first by one corner, then whole), and that is not motion.
A body that moves carries both of its visible edges along, so the tracker also keeps
``rigid_velocity_mps``: per horizontal axis, the velocity both edges agree on — the smaller of
the two edge velocities when they have the same sign, else 0 (the *minmod* of the two; LeVeque,
*Finite Volume Methods for Hyperbolic Problems*, 2002, §6.11). It is what a motion test
should read; ``velocity_mps`` (the centroid's) stays the conservative speed for prediction.
A view that cuts the object at an image edge (:attr:`~llmland_schemas.depth.Blob.touches_border`)
gives no rigid sample, nor does the next view compared with it: where the image edge cuts it,
the bound is the view's and moves as the camera turns or flies (a tree at the image's side,
a few pixels wide, "travelled" 1.2 m in one frame while the drone turned along its path).

Forgetting: a track that was not matched accumulates *missed time*, and is dropped once that
exceeds ``forget_after_s``. When the camera looks away, obstacles leave the field of view but
are still there, so ``update`` accepts ``visible_fn(point_m) -> bool`` (true when a world
point is inside the current camera frustum and range): a track whose predicted centroid is
not visible does not accumulate missed time, and is dropped only ``forget_out_of_view_after_s``
after it was last seen. Without ``visible_fn`` every track is assumed visible.
"""

from __future__ import annotations

import logging
import math
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from llmland_schemas.arrays import FloatArray
from llmland_schemas.depth import Blob
from scipy.optimize import linear_sum_assignment

from llmland_planner.specs import AttachedSpec

log = logging.getLogger(__name__)

VisibleFn = Callable[[FloatArray], bool]

#: Association gate (m) between a track's prediction and a blob.
GATE_M = 1.5
#: A visible track missed this long (s) is dropped.
FORGET_AFTER_S = 2.0
#: Any track unseen this long (s) is dropped, in view or not.
FORGET_OUT_OF_VIEW_AFTER_S = 30.0
#: Smoothing weight of the newest velocity sample (0..1].
VELOCITY_ALPHA = 0.5
#: Constant-velocity prediction is trusted this long (s).
PREDICT_CAP_S = 1.0
#: An unseen track's gate widens at this speed (m/s) up to GATE_MAX_M (m), toward blobs whose
#: height differs by at most GATE_HEIGHT_ALIKE_M (m).
GATE_GROWTH_MPS = 1.5
GATE_MAX_M = 5.0
GATE_HEIGHT_ALIKE_M = 0.4
#: Sightings kept per track (the sim's 5 Hz forward + 5 Hz downward frames: ≈ 6 s, longer than
#: a spec's measured latency here; an older spec falls back to the last-seen centroid).
SIGHTINGS_KEPT = 64
#: points of a camera's rigid path kept for the excursion (views; ~13 s at 5 Hz)
RIGID_PATH_KEPT = 64
#: A sighting this close in time (s) to a frame's stamp was made from that frame's instant.
SAME_INSTANT_S = 1e-3
#: A side view that cuts a track at the top but sees no higher than its known top plus this (m;
#: depth noise at the top edge, well under the 0.4 m height gate) leaves the known top standing.
TOP_SEEN_TOLERANCE_M = 0.1


def _minmod(a: FloatArray, b: FloatArray) -> FloatArray:
    """Elementwise: the smaller magnitude of ``a`` and ``b`` where they share a sign, else 0."""
    return np.where(a * b > 0.0, np.sign(a) * np.minimum(np.abs(a), np.abs(b)), 0.0)


def _cut(blob: Blob) -> bool:
    """Whether the view cut ``blob`` at an image edge, so its bounds (its height too) are partly
    the view's. A blob cut at the top touches the border too; both are read so that a blob built
    with only ``touches_top`` set counts as cut."""
    return blob.touches_border or blob.touches_top


@dataclass(frozen=True)
class _Seen:
    """One camera's view of a track: centroid and visible-surface bounds (3,) each, m; ``cut``:
    the view cut it at an image edge (its bounds are partly the view's)."""

    centroid_m: FloatArray
    lo_m: FloatArray
    hi_m: FloatArray
    cut: bool = False

    @classmethod
    def of(cls, blob: Blob) -> _Seen:
        c, lo, hi = (np.array(x, dtype=np.float64) for x in (blob.centroid_m, blob.lo_m, blob.hi_m))
        return cls(c, lo, hi, cut=_cut(blob))

    @classmethod
    def of_track(cls, track: TrackedObstacle) -> _Seen:
        return cls(track.centroid_m.copy(), track.lo_m.copy(), track.hi_m.copy())


@dataclass
class TrackedObstacle:
    """An obstacle followed over frames (world frame; metres, seconds, m/s).

    ``centroid_m``, ``lo_m``, ``hi_m`` (3,) are from the last matched blob at ``last_seen_s``
    (visible-surface bounds, see :class:`~llmland_schemas.depth.Blob`); ``velocity_mps`` (3,)
    is the horizontal velocity estimate (zero until ``hits >= min_hits_for_velocity``);
    ``missed_s`` is the time the track should have been seen but was not; ``spec`` is the
    semantic spec the world model attached; ``meta`` is free for callers.
    """

    track_id: str
    centroid_m: FloatArray
    lo_m: FloatArray
    hi_m: FloatArray
    velocity_mps: FloatArray
    first_seen_s: float
    last_seen_s: float
    hits: int = 1
    missed_s: float = 0.0
    meta: dict[str, Any] = field(default_factory=dict)
    #: the last side view cut it at the top of the image and saw more of it than its known top
    #: (``top_seen_m``): its top is unknown (at least ``hi_m[2]``)
    touches_top: bool = False
    #: ``(lo (3,), hi (3,))`` m: the bounds of the side views that saw it whole (sky or background
    #: above it), merged; ``hi[2]`` is its known top. None until one does
    #: (:meth:`ObstacleTracker._fold_top`)
    whole_box_m: tuple[FloatArray, FloatArray] | None = None
    #: it has been seen moving (set by the caller's motion test): a person who walked and now
    #: stands still is still a possible person
    has_moved: bool = False
    #: the last matched view cut it at an image edge (its seen height may be the view's)
    last_view_cut: bool = False
    #: the semantic spec attached to it (by the world model), if any
    spec: AttachedSpec | None = None
    #: (3,) horizontal velocity (m/s) both visible edges agree on (see the module docstring)
    rigid_velocity_mps: FloatArray = field(default_factory=lambda: np.zeros(3))
    #: the newest sightings ``(stamp s, centroid (3,) m)``, every camera: what a spec computed from
    #: an older frame is matched against (the thing may have moved since)
    sightings: deque[tuple[float, FloatArray]] = field(default_factory=lambda: deque(maxlen=SIGHTINGS_KEPT))
    #: per camera, the rigid path: the horizontal displacement (3,) m both visible edges agreed on,
    #: summed over consecutive views, one point per view (the newest ``RIGID_PATH_KEPT``)
    rigid_path_m: dict[str, deque[FloatArray]] = field(default_factory=dict)
    #: the farthest (m) a rigid path has been from any of its earlier points (kept ones), any camera
    rigid_excursion_m: float = 0.0
    #: ``velocity_mps`` is an estimate: two sightings at different instants (until then it reads 0,
    #: which says nothing about how fast the thing moves)
    velocity_known: bool = False

    @property
    def half_extent_m(self) -> FloatArray:
        """Half sizes (2,) m of the seen footprint along x and y."""
        result: FloatArray = 0.5 * (self.hi_m[:2] - self.lo_m[:2])
        return result

    @property
    def top_seen_m(self) -> float | None:
        """The highest top (z, m) a side view saw whole; None until one does."""
        return None if self.whole_box_m is None else float(self.whole_box_m[1][2])

    @property
    def height_m(self) -> float:
        """Seen height (m) from the ground under it to the highest point seen."""
        return float(self.hi_m[2] - self.lo_m[2])

    @property
    def half_diagonal_m(self) -> float:
        """Half the seen footprint's diagonal (m): the radius it sweeps turning on the spot."""
        return float(np.hypot(*self.half_extent_m))

    @property
    def rigid_travel_m(self) -> dict[str, FloatArray]:
        """Per camera, where the rigid path is now (3,) m: how far the body travelled, view changes
        and jitter cancelling out."""
        return {source: path[-1] for source, path in self.rigid_path_m.items()}


class ObstacleTracker:
    """Nearest-neighbour multi-obstacle tracker with constant-velocity prediction.

    ``gate_m``: largest horizontal distance (m) between a prediction and a blob to associate
    them. ``forget_after_s``: missed time (s) after which a visible track is dropped.
    ``velocity_alpha``: smoothing weight of the newest velocity sample (0..1].
    ``min_hits_for_velocity``: observations before a velocity is reported (and used to predict).
    ``forget_out_of_view_after_s``: time since last seen (s) after which any track is dropped.
    """

    def __init__(
        self,
        gate_m: float = GATE_M,
        forget_after_s: float = FORGET_AFTER_S,
        velocity_alpha: float = VELOCITY_ALPHA,
        min_hits_for_velocity: int = 2,
        forget_out_of_view_after_s: float = FORGET_OUT_OF_VIEW_AFTER_S,
        predict_cap_s: float = PREDICT_CAP_S,
        gate_growth_mps: float = GATE_GROWTH_MPS,
        gate_max_m: float = GATE_MAX_M,
    ) -> None:
        if not 0.0 < velocity_alpha <= 1.0:
            raise ValueError(f"velocity_alpha must be in (0, 1], got {velocity_alpha}")
        self.gate_m = gate_m
        self.forget_after_s = forget_after_s
        self.velocity_alpha = velocity_alpha
        self.min_hits_for_velocity = max(2, min_hits_for_velocity)
        self.forget_out_of_view_after_s = forget_out_of_view_after_s
        self.predict_cap_s = predict_cap_s
        self.gate_growth_mps = gate_growth_mps
        self.gate_max_m = gate_max_m
        self._tracks: list[TrackedObstacle] = []
        #: track id → smoothed (2, 3) velocities: the centroid's (row 0) and the rigid one (row 1)
        self._raw_velocity: dict[str, FloatArray] = {}
        #: (track id, camera) → that camera's last observation of the track and its stamp
        self._last_by_source: dict[tuple[str, str], tuple[_Seen, float]] = {}
        self._next_id = 0
        self._last_update_s: float | None = None
        #: bumps whenever the live tracks may have changed (an update or a motion mark)
        self.revision = 0

    def update(
        self, blobs: Sequence[Blob], stamp_s: float, visible_fn: VisibleFn | None = None, source: str = ""
    ) -> list[TrackedObstacle]:
        """Associate one frame's blobs (taken at ``stamp_s``, s) and return the live tracks.

        ``source`` names the camera: velocity samples come from consecutive observations by the
        same camera (two cameras see different surfaces of an object: that shift is not motion).
        Several cameras' frames of one instant are fed one after the other with the same stamp.
        """
        self.revision += 1
        dt_frame = 0.0 if self._last_update_s is None else max(0.0, stamp_s - self._last_update_s)
        self._last_update_s = stamp_s
        matched_tracks: set[int] = set()
        matched_blobs: set[int] = set()
        if self._tracks and blobs:
            pred = np.array([self.predict(t, stamp_s)[:2] for t in self._tracks])  # (T, 2)
            obs = np.array([b.centroid_m[:2] for b in blobs], dtype=np.float64)  # (B, 2)
            cost = np.linalg.norm(pred[:, None, :] - obs[None, :, :], axis=-1)
            gate = self._gates(stamp_s, blobs)  # (T, B)
            gated = np.where(cost <= gate, cost, 1e6)
            for ti, bi in zip(*linear_sum_assignment(gated), strict=True):
                if cost[ti, bi] <= gate[ti, bi]:
                    self._correct(self._tracks[ti], blobs[bi], stamp_s, source)
                    matched_tracks.add(int(ti))
                    matched_blobs.add(int(bi))
        kept: list[TrackedObstacle] = []
        for i, track in enumerate(self._tracks):
            if i not in matched_tracks:
                if visible_fn is None or visible_fn(self.predict(track, stamp_s)):
                    track.missed_s += dt_frame
                too_long = stamp_s - track.last_seen_s > self.forget_out_of_view_after_s
                if track.missed_s > self.forget_after_s or too_long:
                    log.debug("forgetting track %s (missed %.2f s)", track.track_id, track.missed_s)
                    self._raw_velocity.pop(track.track_id, None)
                    for key in [k for k in self._last_by_source if k[0] == track.track_id]:
                        del self._last_by_source[key]
                    continue
            kept.append(track)
        for bi, blob in enumerate(blobs):
            if bi not in matched_blobs:
                kept.append(self._new_track(blob, stamp_s, source))
        self._tracks = kept
        return list(self._tracks)

    def _gates(self, stamp_s: float, blobs: Sequence[Blob]) -> FloatArray:
        """Association gates (T, B) in metres.

        ``gate_m`` for every pair; for a track unseen for a while, the gate widens at
        ``gate_growth_mps`` (up to ``gate_max_m``) towards blobs of about its height, so a
        person who walked on while out of view is picked up again instead of leaving a
        ghost track behind. A track that has moved, last seen whole, gets no blob seen whole whose
        height differs from its own by more than ``GATE_HEIGHT_ALIKE_M`` (the gate is -1 m): a
        walker's track must not stay on a still thing the walker passed.
        """
        age = np.array([max(0.0, stamp_s - t.last_seen_s) for t in self._tracks])
        wide = np.minimum(self.gate_m + self.gate_growth_mps * age, max(self.gate_m, self.gate_max_m))
        t_h = np.array([t.height_m for t in self._tracks])
        b_h = np.array([b.hi_m[2] - b.lo_m[2] for b in blobs])
        alike = np.abs(t_h[:, None] - b_h[None, :]) <= GATE_HEIGHT_ALIKE_M
        gates = np.where(alike, wide[:, None], self.gate_m)
        # A track that has moved keeps its identity only on blobs of about its height, where the
        # views on both sides are whole: a walker's track must not stay on a still thing of
        # another height that the walker passed (their blobs merge, then part; a merged blob has
        # the walker's height). Left there, it made the still thing a possible person for good.
        walker = np.array([t.has_moved and not t.last_view_cut for t in self._tracks])
        whole = np.array([not _cut(b) for b in blobs])
        other = walker[:, None] & whole[None, :] & ~alike
        return np.where(other, -1.0, gates)

    def _new_track(self, blob: Blob, stamp_s: float, source: str = "") -> TrackedObstacle:
        track = TrackedObstacle(
            track_id=f"t{self._next_id}",
            centroid_m=np.array(blob.centroid_m, dtype=np.float64),
            lo_m=np.array(blob.lo_m, dtype=np.float64),
            hi_m=np.array(blob.hi_m, dtype=np.float64),
            velocity_mps=np.zeros(3),
            first_seen_s=stamp_s,
            last_seen_s=stamp_s,
            last_view_cut=_cut(blob),
        )
        if source != "down":
            self._fold_top(track, blob)
        self._last_by_source[(track.track_id, source)] = (_Seen.of(blob), stamp_s)
        track.sightings.append((stamp_s, track.centroid_m.copy()))
        self._next_id += 1
        return track

    def _correct(self, track: TrackedObstacle, blob: Blob, stamp_s: float, source: str = "") -> None:
        """Fold a matched blob into ``track``: smoothed horizontal velocity, latest bounds."""
        seen = _Seen.of(blob)
        prev, prev_t = self._last_by_source.get((track.track_id, source), (_Seen.of_track(track), track.last_seen_s))
        self._last_by_source[(track.track_id, source)] = (seen, stamp_s)
        track.sightings.append((stamp_s, np.array(blob.centroid_m, dtype=np.float64)))
        dt = stamp_s - prev_t
        if dt > 1e-6:
            sample = np.zeros((2, 3))  # horizontal only: z velocity stays 0
            sample[0, :2] = (seen.centroid_m[:2] - prev.centroid_m[:2]) / dt
            if not (seen.cut or prev.cut):  # an image edge's bound moves with the view, not the body
                sample[1, :2] = _minmod((seen.lo_m[:2] - prev.lo_m[:2]) / dt, (seen.hi_m[:2] - prev.hi_m[:2]) / dt)
            self._extend_rigid_path(track, source, sample[1] * dt)
            previous = self._raw_velocity.get(track.track_id)
            a = self.velocity_alpha
            self._raw_velocity[track.track_id] = sample if previous is None else a * sample + (1.0 - a) * previous
        track.hits += 1
        track.centroid_m = seen.centroid_m.copy()
        track.lo_m = np.array(blob.lo_m, dtype=np.float64)
        track.hi_m = np.array(blob.hi_m, dtype=np.float64)
        track.last_view_cut = seen.cut
        if source != "down":  # a downward view sees tops; a side view may cut them off
            self._fold_top(track, blob)
        track.last_seen_s = max(track.last_seen_s, stamp_s)
        track.missed_s = 0.0
        if track.hits >= self.min_hits_for_velocity and track.track_id in self._raw_velocity:
            track.velocity_mps, track.rigid_velocity_mps = self._raw_velocity[track.track_id].copy()
            track.velocity_known = True

    @staticmethod
    def _fold_top(track: TrackedObstacle, blob: Blob) -> None:
        """Fold a side view's top into ``track`` (after its bounds took the blob's).

        A view that sees the thing whole (not cut at the image's top edge) sees its top and the
        space straight above it: ``whole_box_m`` merges the bounds of those views, its top the
        highest seen. A later, closer view that cuts a thing that has not moved at the top, but
        sees no higher than that top plus :data:`TOP_SEEN_TOLERANCE_M`, shows nothing new above
        it: the top stays known, and the track's bounds keep the whole views' top and footprint
        (a cut trunk's blob matched to its crown's track must not shrink the crown to the trunk).
        Before, the cut view made the top unknown and the keep-out went up to the altitude
        ceiling: a parked car seen whole at 1.5 m became a 10.5 m wall when the drone came near
        (urban seeds 12, 31). A cut view that sees higher than the known top (a trunk whose crown
        was its own blob), or of a thing that has moved, leaves the top unknown, as before.
        Whatever stood above the thing was in the whole view: its own blob and track (planner
        README, "Known tops").
        """
        whole = track.whole_box_m
        if not blob.touches_top:
            lo, hi = np.asarray(blob.lo_m, dtype=np.float64), np.asarray(blob.hi_m, dtype=np.float64)
            track.whole_box_m = (lo.copy(), hi.copy()) if whole is None else (np.minimum(lo, whole[0]),
                                                                             np.maximum(hi, whole[1]))
            track.touches_top = False
        elif whole is not None and not track.has_moved and blob.hi_m[2] <= whole[1][2] + TOP_SEEN_TOLERANCE_M:
            track.touches_top = False
            track.lo_m[:2] = np.minimum(track.lo_m[:2], whole[0][:2])
            track.hi_m = np.maximum(track.hi_m, whole[1])
        else:
            track.touches_top = True

    @staticmethod
    def _extend_rigid_path(track: TrackedObstacle, source: str, step_m: FloatArray) -> None:
        """Add one view's rigid step to the camera's rigid path; update the excursion.

        The excursion is how far the path's newest point is from the farthest of its kept earlier
        points, not from its start: a walker who turns back (open_field seed 35: 1.4 m out, then
        1.1 m back) ends near where they started, yet is metres from their turning point. A still
        object's path stays within its jitter (view changes go back and forth) from every point.
        """
        path = track.rigid_path_m.setdefault(source, deque([np.zeros(3)], maxlen=RIGID_PATH_KEPT))
        here = path[-1] + step_m
        farthest = float(np.max(np.linalg.norm(np.asarray(path)[:, :2] - here[:2], axis=1)))
        track.rigid_excursion_m = max(track.rigid_excursion_m, farthest)
        path.append(here)

    def predict(self, track: TrackedObstacle, t_s: float) -> FloatArray:
        """(3,) centroid (m) of ``track`` at ``t_s`` under constant velocity for at most ``predict_cap_s``."""
        dt = min(max(0.0, t_s - track.last_seen_s), self.predict_cap_s)
        return np.asarray(track.centroid_m + track.velocity_mps * dt, dtype=np.float64)

    def mark_moved(self, is_moving: Callable[[TrackedObstacle], bool]) -> None:
        """Set ``has_moved`` on every live track that ``is_moving`` says moves now (sticky)."""
        for t in self._tracks:
            if not t.has_moved and is_moving(t):
                t.has_moved = True
                self.revision += 1

    def tracks(self, at_s: float | None = None) -> list[TrackedObstacle]:
        """Copies of the live tracks; with ``at_s`` (s), centroid and bounds are moved to that time."""
        out = []
        for t in self._tracks:
            shift = np.zeros(3) if at_s is None else self.predict(t, at_s) - t.centroid_m
            out.append(
                replace(
                    t,
                    centroid_m=t.centroid_m + shift,
                    lo_m=t.lo_m + shift,
                    hi_m=t.hi_m + shift,
                    velocity_mps=t.velocity_mps.copy(),
                    rigid_velocity_mps=t.rigid_velocity_mps.copy(),
                    meta=dict(t.meta),
                )
            )
        return out

    def match(self, position_m: Sequence[float] | FloatArray, max_dist_m: float) -> TrackedObstacle | None:
        """The live track (not a copy: ``meta`` may be edited) horizontally nearest ``position_m``.

        Distances are to the last-seen centroids; ``None`` when none is within ``max_dist_m``.
        """
        if not self._tracks:
            return None
        p = np.asarray(position_m, dtype=np.float64)[:2]
        dist = [float(np.linalg.norm(t.centroid_m[:2] - p)) for t in self._tracks]
        i = int(np.argmin(dist))
        return self._tracks[i] if dist[i] <= max_dist_m else None

    def match_all(self, position_m: Sequence[float] | FloatArray, radius_m: float,
                  stamp_s: float | None = None) -> list[tuple[TrackedObstacle, float]]:
        """Every live track (not copies) within ``radius_m`` horizontally of ``position_m`` (3,), with
        its distance (m): where it was seen at ``stamp_s`` (see :func:`distance_at`), else where it
        was last seen."""
        found = ((t, distance_at(t, position_m, stamp_s)) for t in self._tracks)
        return [(t, d) for t, d in found if d <= radius_m]


def distance_at(track: TrackedObstacle, position_m: Sequence[float] | FloatArray, stamp_s: float | None) -> float:
    """Horizontal distance (m) from ``position_m`` to the track where it was seen at ``stamp_s`` (the
    nearest of that instant's sightings: two cameras see different surfaces), or, when it was not
    seen then (``None``, born later, sighting dropped), to its last-seen centroid.

    A spec describes an object as seen in one frame and arrives a latency later; a thing that moves
    meanwhile (a car at 8 m/s, 0.5 s: 4 m) is then far from that position, but it was there then.
    """
    p = np.asarray(position_m, dtype=np.float64)[:2]
    then = [] if stamp_s is None else [c for t, c in track.sightings if abs(t - stamp_s) <= SAME_INSTANT_S]
    return min((float(np.linalg.norm(c[:2] - p)) for c in then or [track.centroid_m]), default=math.inf)
