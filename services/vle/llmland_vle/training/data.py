"""Render captioned training / held-out data from seeded simulator worlds.

For every (world, seed) a fresh pybullet client builds the world (:func:`~llmland_vle.simrender.world_scene`,
the VLE's one door to the simulator); actors walk and drive
between renders; each render is taken from a sampled drone pose. From one render come:

* seg crops — one per visible object, boxed by its segmentation mask (ground truth, used
  for labels only), with the box jittered the way depth-blob boxes differ from it;
* blob crops — one per depth blob (``find_blobs``, the run-time path), labelled by the
  truth object at the blob's world position (``pos_cls``); the training label also needs
  that object to be seen inside the box (segmentation), else the blob is skipped; blobs
  that are only terrain are labelled ``ground``;
* the frame — the whole image with its frame caption.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from llmland_schemas import WORLD_NAMES
from llmland_schemas.depth import find_blobs

from ..captions import crop_caption, frame_caption, vehicle_noun
from ..crops import crop_square, resize
from ..matching import TruthItem, match_position
from ..simrender import world_scene
from .poses import object_colour, sample_pose, surface_at

log = logging.getLogger(__name__)

WORLDS = WORLD_NAMES
MIN_SEG_PX = 50
#: Objects nearer the camera than this (m, nearest visible point) are not sampled: the
#: drone never flies that close to an obstacle (1 m from a person is already a failure),
#: and a crop from that close shows a featureless patch of shirt or paint.
MIN_OBJECT_DEPTH_M = 1.5
FRAME_MIN_PX = 120
#: Per render, keep at most this many seg crops of these (plentiful) classes.
PER_RENDER_CAP = {"tree": 4, "bush": 3, "building": 3}
BLOB_KW = {"stride": 2, "max_range_m": 30.0}
MAX_BLOBS = 16


@dataclass
class RenderSet:
    """Crops and frames with their captions (numpy arrays plus parallel lists)."""

    crops: list[np.ndarray] = field(default_factory=list)
    captions: list[str] = field(default_factory=list)
    classes: list[str] = field(default_factory=list)  # training label ("" = none)
    pos_classes: list[str] = field(default_factory=list)  # class of the truth object at the blob position
    sources: list[str] = field(default_factory=list)  # "seg" | "blob"
    groups: list[str] = field(default_factory=list)  # "<world>:<seed>"
    #: blob crops: share of the box's pixels showing the position-matched object (seg crops: 1)
    inside: list[float] = field(default_factory=list)
    frames: list[np.ndarray] = field(default_factory=list)
    frame_captions: list[str] = field(default_factory=list)
    renders: int = 0

    def extend(self, other: RenderSet) -> None:
        for name in ("crops", "captions", "classes", "pos_classes", "sources", "groups", "inside", "frames",
                     "frame_captions"):
            getattr(self, name).extend(getattr(other, name))
        self.renders += other.renders


def _jitter_box(box: tuple[int, int, int, int], rng: np.random.Generator) -> tuple[int, int, int, int]:
    u0, v0, u1, v1 = box
    w, h = u1 - u0, v1 - v0
    du0, du1 = rng.uniform(-0.12, 0.12, 2) * w
    dv0, dv1 = rng.uniform(-0.12, 0.12, 2) * h
    nu0, nv0 = int(round(u0 + du0)), int(round(v0 + dv0))
    return nu0, nv0, max(int(round(u1 + du1)), nu0 + 2), max(int(round(v1 + dv1)), nv0 + 2)


def _add(out: RenderSet, crop: np.ndarray, caption: str, cls: str, pos_cls: str, source: str, group: str,
         inside: float) -> None:
    out.crops.append(crop)
    out.captions.append(caption)
    out.classes.append(cls)
    out.pos_classes.append(pos_cls)
    out.sources.append(source)
    out.groups.append(group)
    out.inside.append(inside)


def _seg_crops(
    out: RenderSet, world: Any, r: Any, rng: np.random.Generator, crop_size: int, group: str
) -> tuple[dict[int, str], dict[int, bool], list[str]]:
    """Seg crops of one render; returns the captions and nearness per body, and the frame's nouns."""
    by_body = {o.body_id: o for o in world.objects}
    ids, counts = np.unique(r.seg, return_counts=True)
    seen = {int(i): int(c) for i, c in zip(ids, counts, strict=True) if int(i) in by_body}
    captions: dict[int, str] = {}
    near: dict[int, bool] = {}
    nouns: list[str] = []
    kept: dict[str, int] = {}
    for body, n_px in sorted(seen.items(), key=lambda kv: -kv[1]):
        o = by_body[body]
        if n_px >= FRAME_MIN_PX:
            noun = vehicle_noun(o.size_m) if o.cls == "vehicle" else o.cls
            nouns.append("landing pad" if o.cls == "pad" else noun)
        if o.cls == "pad" or n_px < MIN_SEG_PX:
            continue
        rows, cols = np.nonzero(r.seg == body)
        near[body] = float(r.depth_m[rows, cols].min()) < MIN_OBJECT_DEPTH_M
        pos_o = o.position()
        captions[body] = crop_caption(
            o.cls,
            colour=object_colour(o.cls, r.rgb, rows, cols),
            surface=surface_at(world, float(pos_o[0]), float(pos_o[1])),
            speed_mps=float(np.hypot(*o.velocity()[:2])),
            dynamic=o.dynamic,
            size_m=o.size_m,
        )
        box = (int(cols.min()), int(rows.min()), int(cols.max()) + 1, int(rows.max()) + 1)
        kept[o.cls] = kept.get(o.cls, 0) + 1
        if near[body] or kept[o.cls] > PER_RENDER_CAP.get(o.cls, 99):
            continue
        _add(out, crop_square(r.rgb, _jitter_box(box, rng), crop_size), captions[body], o.cls, o.cls, "seg", group,
             1.0)
    return captions, near, nouns


def _blob_crops(
    out: RenderSet, world: Any, r: Any, captions: dict[int, str], near: dict[int, bool], crop_size: int, group: str
) -> None:
    """Blob crops of one render, labelled by the truth object at each blob's position."""
    items = [o for o in world.objects if o.cls != "pad"]
    obj_bodies = np.array([o.body_id for o in items], dtype=np.int32)
    truth = [
        TruthItem(o.obj_id, o.cls, tuple(o.position()), (o.size_m[0], o.size_m[1], o.size_m[2]),
                  tuple(o.velocity()), o.dynamic)
        for o in items
    ]
    blobs = find_blobs(r.depth_m, r.intrinsics, r.T_world_camera, **BLOB_KW)  # type: ignore[arg-type]
    for b in blobs[:MAX_BLOBS]:
        u0, v0, u1, v1 = b.bbox_px
        box_seg = r.seg[v0:v1, u0:u1]
        k = match_position(b.centroid_m, truth, b.size_m)
        pos_cls = truth[k].cls if k is not None else ""
        label, caption, inside = "", "", 0
        if k is not None:
            body = items[k].body_id
            if near.get(body, False):
                continue
            inside = int((box_seg == body).sum())
            if body in captions and inside >= max(30, 0.05 * box_seg.size):
                label, caption = items[k].cls, captions[body]
        else:
            objects_px = int(np.isin(box_seg, obj_bodies).sum())
            if objects_px <= 0.03 * box_seg.size:
                surf = surface_at(world, float(b.centroid_m[0]), float(b.centroid_m[1]))
                label, caption = "ground", crop_caption("ground", surface=surf)
        if not label and not pos_cls:
            continue
        _add(out, crop_square(r.rgb, b.bbox_px, crop_size), caption, label, pos_cls or label, "blob", group,
             inside / max(box_seg.size, 1))


def _render_world(
    name: str, seed: int, n_renders: int, renderer: str, crop_size: int, frame_size: int, n_pedestrians: int | None
) -> RenderSet:
    out = RenderSet()
    group = f"{name}:{seed}"
    rng = np.random.default_rng([seed, WORLDS.index(name), 7])
    with world_scene(name, seed, renderer=renderer, n_pedestrians=n_pedestrians) as (world, cam):
        for _ in range(n_renders):
            for _ in range(int(rng.integers(2, 25))):
                world.step_actors(0.1)
            pos, quat = sample_pose(world, rng)
            r = cam.render(pos, quat, with_seg=True)
            captions, near, nouns = _seg_crops(out, world, r, rng, crop_size, group)
            _blob_crops(out, world, r, captions, near, crop_size, group)
            out.frames.append(resize(r.rgb, frame_size))
            out.frame_captions.append(frame_caption(name, nouns))
            out.renders += 1
    return out


def render_set(
    seeds: Sequence[int],
    renders_per_world: int,
    *,
    worlds: Sequence[str] = WORLDS,
    crop_size: int = 96,
    frame_size: int = 128,
    renderers: Sequence[str] = ("auto", "auto", "tiny"),
    extra_pedestrians: bool = True,
) -> RenderSet:
    """Render every world for every seed; the renderer cycles through ``renderers`` per world.

    With ``extra_pedestrians`` the pedestrian count is drawn from 3..6 per world (seeded),
    so persons, the costly class to miss, are well represented.
    """
    total = RenderSet()
    t0 = time.perf_counter()
    k = 0
    for seed in seeds:
        for name in worlds:
            n_ped = int(np.random.default_rng([seed, 11]).integers(3, 7)) if extra_pedestrians else None
            renderer = renderers[k % len(renderers)]
            part = _render_world(name, seed, renders_per_world, renderer, crop_size, frame_size, n_ped)
            k += 1
            total.extend(part)
            log.info("rendered %s seed %d: %d crops, %d frames (%.0f s so far)", name, seed, len(part.crops),
                     len(part.frames), time.perf_counter() - t0)
    return total
