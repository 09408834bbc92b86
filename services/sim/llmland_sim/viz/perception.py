"""Cameras and what perception made of them: JPEG images, a coarse depth image, the depth
blobs of every frame as 2D boxes, each labelled with the caption, class and buffer of the
perceived object at its place (geometry only where nothing was perceived, as in baseline
runs), and the text lines of the log view.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import rerun as rr
from llmland_schemas import SafetySpecMessage, SceneDescription
from llmland_schemas.depth import Blob, blobs_from_frame
from llmland_schemas.frames import CameraFrame

JPEG_QUALITY = 75
#: depth is logged at 1/DEPTH_STRIDE of the camera resolution ...
DEPTH_STRIDE = 4
#: ... at most once per DEPTH_PERIOD_S of sim time (s)
DEPTH_PERIOD_S = 0.5
#: colour map range of the depth view (m); no return (sky) is NaN, i.e. not drawn
DEPTH_RANGE_M = 30.0
#: depth blobs as the VLE and the planner find them
BLOB_STRIDE = 2
BLOB_MAX_RANGE_M = 30.0
#: a blob takes the label of a perceived object within this horizontal distance (m) ...
MATCH_RADIUS_M = 1.5
#: ... seen at most this long ago (s, sim time)
PERCEPTION_MEMORY_S = 5.0
#: captions are cut to this many characters on 3D boxes, and shorter on 2D blobs
CAPTION_CHARS = 40
BLOB_CAPTION_CHARS = 24
HUMAN_COLOUR = (255, 60, 60)
PERCEIVED_COLOUR = (255, 200, 0)
GEOMETRY_COLOUR = (0, 220, 255)


@dataclass(frozen=True)
class Perceived:
    """One object as perception described it: where, what, and how much room it needs."""

    obj_id: str
    frame_seq: int
    stamp_s: float
    centroid_m: np.ndarray
    label: str
    buffer_m: float
    caption: str
    is_human: bool | None
    is_dynamic: bool

    @property
    def maybe_person(self) -> bool:
        """A person, or an unknown mover (the planner's hard limit treats those as people)."""
        return self.is_human is True or (self.is_human is None and self.is_dynamic)

    def describe(self, caption_chars: int = CAPTION_CHARS) -> str:
        text = self.caption if len(self.caption) <= caption_chars else self.caption[: caption_chars - 1] + "…"
        return f"{self.label} · buffer {self.buffer_m:.1f} m · “{text}”"


class PerceivedObjects:
    """The objects of recent specs, newest first; a new one replaces older ones at its place."""

    def __init__(self) -> None:
        self.objects: list[Perceived] = []
        self.captions: dict[tuple[int, str], str] = {}

    def on_scene(self, msg: SceneDescription) -> None:
        self.captions = {(msg.frame_seq, o.obj_id): o.caption.text for o in msg.objects}

    def on_spec(self, msg: SafetySpecMessage) -> None:
        new = [
            Perceived(obj_id=o.obj_id, frame_seq=msg.frame_seq, stamp_s=msg.stamp,
                      centroid_m=np.asarray(o.centroid_m, dtype=float), label=o.spec.label,
                      buffer_m=o.spec.buffer_m,
                      caption=o.spec.caption or self.captions.get((msg.frame_seq, o.obj_id), ""),
                      is_human=o.spec.is_human, is_dynamic=o.spec.is_dynamic)
            for o in msg.objects
        ]
        kept = [p for p in self.objects
                if p.stamp_s > msg.stamp - PERCEPTION_MEMORY_S
                and all(_dist_xy(p.centroid_m, q.centroid_m) > MATCH_RADIUS_M for q in new)]
        self.objects = new + kept

    def near(self, point_m: np.ndarray, t_s: float) -> Perceived | None:
        """The newest perceived object within MATCH_RADIUS_M of ``point_m``, if any."""
        best: Perceived | None = None
        best_d = MATCH_RADIUS_M
        for p in self.objects:
            if p.stamp_s < t_s - PERCEPTION_MEMORY_S:
                continue
            d = _dist_xy(p.centroid_m, point_m)
            if d <= best_d:
                best, best_d = p, d
        return best

    def human_buffer_m(self) -> float | None:
        """The largest buffer a perceived person asks for (None: no person perceived)."""
        buffers = [p.buffer_m for p in self.objects if p.maybe_person]
        return max(buffers) if buffers else None


def _dist_xy(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.hypot(a[0] - b[0], a[1] - b[1]))


def blob_boxes(blobs: list[Blob], perceived: PerceivedObjects, t_s: float) -> rr.Boxes2D:
    """2D boxes of depth blobs, labelled with what perception said is there."""
    labels, colours = [], []
    for b in blobs:
        p = perceived.near(b.centroid_m, t_s)
        if p is None:
            labels.append(f"{b.size_m[2]:.1f} m tall")
            colours.append(GEOMETRY_COLOUR)
        else:
            labels.append(p.describe(BLOB_CAPTION_CHARS))
            colours.append(HUMAN_COLOUR if p.maybe_person else PERCEIVED_COLOUR)
    return rr.Boxes2D(array=np.array([b.bbox_px for b in blobs], dtype=float).reshape(-1, 4),
                      array_format=rr.Box2DFormat.XYXY, labels=labels, colors=colours)


def log_frame(rec: rr.RecordingStream, frame: CameraFrame, rgb_path: str, blobs_path: str,
              perceived: PerceivedObjects, depth_path: str | None = None) -> None:
    """A camera frame as JPEG, its blobs and (if ``depth_path``) a coarse depth image."""
    rec.log(rgb_path, rr.Image(frame.rgb).compress(jpeg_quality=JPEG_QUALITY))
    blobs = blobs_from_frame(frame, stride=BLOB_STRIDE, max_range_m=BLOB_MAX_RANGE_M)
    rec.log(blobs_path, blob_boxes(blobs, perceived, frame.header.stamp))
    if depth_path is not None and frame.depth_m is not None:
        d = frame.depth_m[::DEPTH_STRIDE, ::DEPTH_STRIDE]
        d = np.where(np.isfinite(d) & (d > 0.0), d, np.nan).astype(np.float16)
        rec.log(depth_path, rr.DepthImage(d, meter=1.0, depth_range=(0.0, DEPTH_RANGE_M)))


def caption_line(msg: SceneDescription) -> str:
    objs = "; ".join(f"{o.obj_id} “{o.caption.text}”" for o in msg.objects)
    return f"VLE frame {msg.frame_seq}: “{msg.caption.text}”" + (f" — {objs}" if objs else "")


def spec_line(msg: SafetySpecMessage) -> str:
    objs = "; ".join(
        f"{o.obj_id} {o.spec.label} buffer {o.spec.buffer_m:.1f} m"
        + {True: " human", None: " human?", False: ""}[o.spec.is_human] + (" dynamic" if o.spec.is_dynamic else "")
        for o in msg.objects
    )
    return f"spec frame {msg.frame_seq} ({msg.latency_ms:.0f} ms): {objs or 'no objects'}"
