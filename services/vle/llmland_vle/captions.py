"""BLIP-style caption grammar built from ground truth, and the inverse (caption -> class).

The simcap training data, the oracle backend and the held-out evaluation all use these
functions, so a caption means the same thing everywhere. Crop captions look like
``"a person in a red shirt walking on the grass"`` or ``"a white van parked in a parking
lot"``; frame captions like ``"an aerial view of a street with a person and cars"``.
Only what the simulator's truth knows goes into a caption: the class (vehicles split into
car / van by their size), a colour word from the object's mean colour in the image, the
surface under it and a motion word from its true velocity.
"""

from __future__ import annotations

import colorsys
from collections.abc import Iterable, Sequence

import numpy as np

#: Object classes a crop caption can name ("ground" = a blob that is only terrain).
CLASSES = ("person", "vehicle", "building", "tree", "bush", "shed", "rock", "ground")
COLOURS = ("white", "black", "gray", "red", "orange", "yellow", "green", "blue", "purple", "brown", "pink")
#: surface key -> phrase
SURFACES = {
    "grass": "on the grass",
    "road": "on the road",
    "sidewalk": "on the sidewalk",
    "parking lot": "in a parking lot",
}
#: world name -> scene phrase of frame captions
SCENES = {"open_field": "a grass field", "urban": "a street", "forest_edge": "a meadow near a forest"}
#: class word in a caption -> class
WORD_CLASS = {
    "person": "person", "people": "person", "man": "person", "woman": "person", "pedestrian": "person",
    "car": "vehicle", "cars": "vehicle", "van": "vehicle", "vans": "vehicle", "vehicle": "vehicle",
    "truck": "vehicle", "building": "building", "buildings": "building", "house": "building",
    "tree": "tree", "trees": "tree", "bush": "bush", "bushes": "bush", "shrub": "bush",
    "shed": "shed", "sheds": "shed", "hut": "shed", "rock": "rock", "rocks": "rock", "stone": "rock",
    "automobile": "vehicle", "minivan": "vehicle", "oak": "tree", "boulder": "rock",
    "patch": "ground",
}
_PLURAL = {"person": "people", "car": "cars", "van": "vans", "building": "buildings", "tree": "trees",
           "bush": "bushes", "shed": "sheds", "rock": "rocks", "landing pad": "landing pads"}
#: order in which frame captions mention classes (most safety-relevant first)
FRAME_ORDER = ("person", "car", "van", "building", "tree", "shed", "bush", "rock", "landing pad")
#: van if the vehicle is longer than this (m); cars are 4.3 m, vans 5.0 m in the sim
VAN_MIN_LENGTH_M = 4.65
WALKING_MIN_SPEED_MPS = 0.3
DRIVING_MIN_SPEED_MPS = 0.5


def article(word: str) -> str:
    return "an" if word[:1] in "aeiou" else "a"


def with_article(phrase: str) -> str:
    return f"{article(phrase)} {phrase}"


def colour_word(rgb_mean: Sequence[float] | np.ndarray) -> str:
    """Basic colour name of a mean RGB colour (0-255)."""
    r, g, b = (float(np.clip(c, 0.0, 255.0)) / 255.0 for c in rgb_mean)
    h, s, v = colorsys.rgb_to_hsv(r, g, b)
    hue = h * 360.0
    if v < 0.2:
        return "black"
    if s < 0.2 or (s < 0.3 and v < 0.45):
        return "white" if v > 0.72 else "gray"
    if hue < 14.0 or hue >= 335.0:
        return "pink" if (s < 0.45 and v > 0.7) else ("brown" if v < 0.45 else "red")
    if hue < 45.0:
        return "brown" if v < 0.62 or s < 0.45 else "orange"
    if hue < 70.0:
        return "brown" if v < 0.45 else "yellow"
    if hue < 165.0:
        return "green"
    if hue < 260.0:
        return "blue"
    return "purple"


def vehicle_noun(size_m: Sequence[float]) -> str:
    return "van" if max(float(size_m[0]), float(size_m[1])) >= VAN_MIN_LENGTH_M else "car"


def motion_word(cls: str, speed_mps: float, dynamic: bool) -> str | None:
    if cls == "person":
        return "walking" if speed_mps >= WALKING_MIN_SPEED_MPS else "standing"
    if cls == "vehicle":
        return "driving" if dynamic and speed_mps >= DRIVING_MIN_SPEED_MPS else "parked"
    return None


def crop_caption(
    cls: str,
    *,
    colour: str | None = None,
    surface: str | None = "grass",
    speed_mps: float = 0.0,
    dynamic: bool = False,
    size_m: Sequence[float] = (1.0, 1.0, 1.0),
) -> str:
    """The caption of one object crop (``cls`` one of :data:`CLASSES`)."""
    where = SURFACES.get(surface or "", "")
    if cls == "ground":
        return f"a patch of {surface or 'grass'}"
    motion = motion_word(cls, speed_mps, dynamic)
    if cls == "person":
        words = ["a person"]
        if colour:
            words.append(f"in {with_article(colour)} shirt")
    else:
        noun = vehicle_noun(size_m) if cls == "vehicle" else cls
        words = [with_article(f"{colour} {noun}" if colour else noun)]
    if motion:
        words.append(motion)
    if where and cls != "building":
        words.append(where)
    return " ".join(words)


def frame_caption(world: str, visible: Iterable[str], max_items: int = 3) -> str:
    """Frame caption from the world name and the nouns visible in it (repeats = counts).

    ``visible`` holds nouns such as ``"person"``, ``"car"``, ``"van"``, ``"tree"``,
    ``"landing pad"``, once per visible instance.
    """
    counts: dict[str, int] = {}
    for noun in visible:
        counts[noun] = counts.get(noun, 0) + 1
    items = []
    for noun in FRAME_ORDER:
        n = counts.get(noun, 0)
        if n:
            items.append(with_article(noun) if n == 1 else _PLURAL[noun])
    items = items[:max_items]
    scene = SCENES.get(world, "the ground")
    if not items:
        return f"an aerial view of {scene}"
    listed = items[0] if len(items) == 1 else ", ".join(items[:-1]) + " and " + items[-1]
    return f"an aerial view of {scene} with {listed}"


def caption_class(text: str) -> str | None:
    """The class a crop caption names (its first class word), or None."""
    for word in text.lower().replace(",", " ").split():
        cls = WORD_CLASS.get(word)
        if cls is not None:
            return cls
    return None


def caption_vocabulary() -> list[str]:
    """Every word the grammar above can produce (sorted; the simcap vocabulary)."""
    words: set[str] = {"a", "an", ",", "and", "with", "of", "in", "shirt", "patch", "aerial", "view"}
    for phrase in list(SURFACES.values()) + list(SCENES.values()) + list(SURFACES):
        words.update(phrase.split())
    words.update(COLOURS)
    words.update(["person", "car", "van", "building", "tree", "bush", "shed", "rock", "landing", "pad"])
    words.update(w for p in _PLURAL.values() for w in p.split())
    words.update(["walking", "standing", "driving", "parked", "the"])
    return sorted(words)
