"""The ``oracle`` backend: captions written from simulator truth, with optional seeded noise.

For error studies only (sim runs). The run-time service never imports the simulator: the
oracle keeps the latest ``sim/truth`` messages (:class:`GroundTruth`: class, position,
size, velocity per object) and labels each depth blob with the truth object at its world
position (:func:`llmland_vle.matching.match_position`). Captions follow the simcap grammar
without colour or surface (``"a person walking"``, ``"a van parked"``); a blob with no
object under it is ``"an unknown object"``.

Noise: each caption is corrupted with probability ``noise`` (seeded RNG), by one of, chosen
uniformly: a synonym for the class word, an omission (the object is not mentioned), or a
wrong class word.
"""

from __future__ import annotations

import logging
import threading
from collections import deque
from collections.abc import Sequence

import numpy as np
from llmland_schemas import Caption, GroundTruth, Topic
from llmland_schemas.depth import Blob
from llmland_schemas.frames import CameraFrame

from .captioner import BusInput, CaptionKind, CaptionUnavailableError
from .captions import WORD_CLASS, crop_caption, frame_caption, vehicle_noun
from .matching import items_from_truth, match_position

log = logging.getLogger(__name__)

UNKNOWN = "an unknown object"
NOISE_KINDS = ("synonym", "omission", "wrong")
SYNONYMS = {
    "person": ("man", "woman", "pedestrian"), "people": ("pedestrian",), "car": ("automobile", "vehicle"),
    "cars": ("vehicle",), "van": ("minivan", "vehicle"), "building": ("house",), "buildings": ("house",),
    "tree": ("oak",), "trees": ("oak",), "bush": ("shrub",), "bushes": ("shrub",), "shed": ("hut",),
    "rock": ("stone", "boulder"), "rocks": ("stone",),
}
WRONG = ("person", "car", "van", "building", "tree", "bush", "shed", "rock")
OMITTED = "a patch of grass"


class OracleCaptioner:
    """Truth-based captions; feed it ``sim/truth`` with :meth:`on_truth`."""

    backend = "oracle"

    def __init__(self, noise: float = 0.0, seed: int = 0, history: int = 32) -> None:
        if not 0.0 <= noise <= 1.0:
            raise ValueError("noise must be within [0, 1]")
        self.noise = float(noise)
        self.model_version = f"oracle-noise{self.noise:g}"
        self._rng = np.random.default_rng(seed)
        self._truth: deque[GroundTruth] = deque(maxlen=history)
        self._lock = threading.Lock()
        self.corrupted = 0

    def on_truth(self, msg: GroundTruth) -> None:
        with self._lock:
            self._truth.append(msg)

    def bus_inputs(self) -> list[BusInput]:
        """The service feeds it the drone's ``sim/truth``."""
        return [BusInput(Topic.TRUTH, GroundTruth, self.on_truth)]

    def truth_for(self, stamp: float, episode_id: str = "") -> GroundTruth | None:
        """The stored truth of this episode closest in time to ``stamp``."""
        with self._lock:
            cands = [t for t in self._truth if not episode_id or t.episode_id in ("", episode_id)]
        return min(cands, key=lambda t: abs(t.stamp - stamp)) if cands else None

    # ---------------------------------------------------------------- Captioner protocol
    def caption(self, image_rgb: np.ndarray, kind: CaptionKind = "frame") -> Caption:
        raise CaptionUnavailableError("the oracle backend captions simulator frames only, not images")

    def caption_batch(self, images: Sequence[np.ndarray], kind: CaptionKind = "object") -> list[Caption]:
        raise CaptionUnavailableError("the oracle backend captions simulator frames only, not images")

    # ---------------------------------------------------------------- SceneCaptioner
    def caption_scene(self, frame: CameraFrame, blobs: Sequence[Blob]) -> tuple[Caption, list[Caption]]:
        truth = self.truth_for(frame.header.stamp, frame.header.episode_id)
        if truth is None:
            log.debug("oracle: no truth yet for frame %d", frame.header.seq)
            texts = [UNKNOWN for _ in blobs]
            return self._wrap("an aerial view"), [self._wrap(t) for t in texts]
        items = items_from_truth(truth)
        texts, nouns = [], []
        for b in blobs:
            k = match_position(b.centroid_m, items, b.size_m)
            if k is None:
                texts.append(UNKNOWN)
                continue
            it = items[k]
            texts.append(self.corrupt(crop_caption(it.cls, colour=None, surface=None, speed_mps=it.speed_mps,
                                                   dynamic=it.dynamic, size_m=it.size_m)))
            nouns.append(vehicle_noun(it.size_m) if it.cls == "vehicle" else it.cls)
        scene = self.corrupt(frame_caption(truth.world, nouns))
        return self._wrap(scene), [self._wrap(t) for t in texts]

    def _wrap(self, text: str) -> Caption:
        return Caption(text=text, backend=self.backend, model=self.model_version, latency_ms=0.0)

    def corrupt(self, text: str) -> str:
        """``text`` unchanged with probability ``1 - noise``, else with one error."""
        if self.noise <= 0.0 or self._rng.uniform() >= self.noise:
            return text
        words = text.split()
        idx = next((i for i, w in enumerate(words) if w.strip(",") in SYNONYMS), None)
        if idx is None:
            return text  # nothing to corrupt (e.g. "an aerial view of a street")
        self.corrupted += 1
        word = words[idx].strip(",")
        kind = NOISE_KINDS[int(self._rng.integers(len(NOISE_KINDS)))]
        if kind == "omission":
            return OMITTED if " view " not in f" {text} " else text.split(" with ")[0]
        if kind == "synonym":
            new = str(self._rng.choice(SYNONYMS[word]))
        else:
            new = str(self._rng.choice([w for w in WRONG if WORD_CLASS[w] != WORD_CLASS[word]]))
        words[idx] = words[idx].replace(word, new)
        if idx > 0 and words[idx - 1] in ("a", "an"):
            words[idx - 1] = "an" if new[0] in "aeiou" else "a"
        return " ".join(words)
