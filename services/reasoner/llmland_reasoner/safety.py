"""Every mention grounded in the KB; the caption's spec is the most careful of them.

Each present mention (``mentions.py``) is grounded among the KB entries *of its own class*
(a person mention among person entries, a giraffe among animal entries): the entry whose
names (label + synonyms) are most similar to the mention's window — the mention and the
words after it, where BLIP puts what qualifies it ("man riding a bike", "truck parked in")
— wins. So the class of a mention is fixed by its noun (KB name or WordNet hypernym) and
only the details (cyclist or pedestrian, parked or moving) are chosen by similarity: a
person can never come back as a scarecrow, a giraffe never as a stuffed toy. A vehicle is
static (parked) only when its window says so (:data:`STATIONARY_CUES`); an unknown noun gets
the conservative spec.

The caption's spec is the most careful mention by :func:`care_key`: a human first (the
paper's headline class: a person anywhere in the caption means a person spec), then other
living or unknown things, then anything dynamic, then the larger buffer, then the higher
altitude floor. Terrain entries
carry a 0 m buffer, so a scene noun (field, road, snow) is the answer only when nothing
else is named.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from llmland_schemas.messages import CONSERVATIVE_BUFFER_M, CONSERVATIVE_Z_MIN_M

from .grounding import NameIndex
from .kb import MIN_BUFFER_M, KbEntry, KnowledgeBase
from .mentions import Found, tokenize

#: Words after the mention's first word that ground it (BLIP: "car parked on the").
WINDOW_WORDS = 4
#: Similarity bonus for the entry whose own name matched the mention (chosen on the dev sets).
NAME_MATCH_BONUS = 0.05
#: How far from a vehicle a stationary cue may stand (words).
CUE_REACH = 3
#: Words that say a vehicle is not moving (not "stopped": a bus stopped at a corner moves on).
STATIONARY_CUES = frozenset(
    "parked parking stationary docked moored anchored abandoned wrecked wreck junked".split()
)
#: Which KB categories a mention's class is grounded among.
CLASS_CATEGORIES: dict[str, tuple[str, ...]] = {
    "person": ("person",),
    "animal": ("animal",),
    "vehicle": ("vehicle",),
    "structure": ("structure",),
    "object": ("structure",),
    "vegetation": ("vegetation",),
    "lookalike": ("lookalike",),
    "terrain": ("terrain",),
}


@dataclass(frozen=True)
class Numbers:
    """The spec fields of one mention."""

    label: str
    kb_id: str
    category: str
    is_dynamic: bool
    is_human: bool
    z_min: float
    buffer_m: float

    @classmethod
    def of(cls, entry: KbEntry) -> Numbers:
        return cls(entry.label, entry.id, entry.category, entry.is_dynamic, entry.is_human, entry.z_min,
                   entry.buffer_m)


#: What an unknown noun gets: the planner's most conservative class (dynamic, largest buffer).
CAREFUL = Numbers("unknown", "", "unknown", True, False, CONSERVATIVE_Z_MIN_M, CONSERVATIVE_BUFFER_M)


@dataclass(frozen=True)
class Grounded:
    """A mention, the numbers it was given and the entries it could have been given."""

    found: Found
    numbers: Numbers
    score: float = 0.0
    pool: tuple[str, ...] = ()


def care_key(n: Numbers) -> tuple[bool, bool, bool, float, float]:
    """Larger = more careful: human, living (or unknown), dynamic, buffer, altitude floor."""
    return (n.is_human, n.category in ("person", "animal", "unknown"), n.is_dynamic, n.buffer_m, n.z_min)


def window(words: Sequence[str], found: Found) -> str:
    return " ".join(words[found.start : max(found.end, found.start + WINDOW_WORDS)])


def candidates(kb: KnowledgeBase, found: Found, parked: bool = False, ridden: bool = False) -> list[KbEntry]:
    """The KB entries a mention may be grounded in: its class's; for a vehicle the moving ones,
    or the parked ones when its window says it is parked; for a place the KB does not name,
    plain ground (water and rocks only by name); for a person the riders (a person
    class with a larger buffer: cyclist) only when a vehicle or bicycle is named near it."""
    categories = CLASS_CATEGORIES.get(found.word_class, ())
    entries = [e for e in kb.entries if e.category in categories]
    if found.word_class == "terrain" and found.source == "wordnet":
        entries = [e for e in entries if e.buffer_m == 0.0] or entries  # a place the KB lacks is ground
    if found.word_class == "person" and not ridden:
        floor = MIN_BUFFER_M["person"]
        entries = [e for e in entries if e.buffer_m <= floor or e.id == found.kb_id] or entries
    if found.word_class == "vehicle":
        entries = [e for e in entries if e.is_dynamic != parked] or entries
    return entries


#: Named wheeled things a person can ride (KB ids outside the vehicle class).
RIDDEN_IDS = frozenset({"bicycle"})


def _ridden(person: Found, mentions: Sequence[Found]) -> bool:
    """Whether a vehicle or a bicycle is named within the person's window ("a boy riding his bicycle")."""
    return any(person.end <= m.start < person.start + WINDOW_WORDS
               and (m.word_class == "vehicle" or m.kb_id in RIDDEN_IDS) for m in mentions)


def _parked(words: Sequence[str], vehicle: Found, mentions: Sequence[Found]) -> bool:
    """Whether a stationary cue belongs to this vehicle: within :data:`CUE_REACH` words after it
    ("cars are parked") or before it ("parked with numerous cars"), no other thing in between."""
    others = [m for m in mentions if m is not vehicle]
    for j in range(max(0, vehicle.start - CUE_REACH), min(len(words), vehicle.end + CUE_REACH)):
        if words[j] in STATIONARY_CUES and not (vehicle.start <= j < vehicle.end):
            lo, hi = sorted((j, vehicle.start if j < vehicle.start else vehicle.end - 1))
            if not any(lo < m.start <= hi or lo <= m.end - 1 < hi for m in others):
                return True
    return any(w in STATIONARY_CUES for w in words[vehicle.start : vehicle.end])  # "parked car"


def ground_mentions(
    caption: str, mentions: Sequence[Found], kb: KnowledgeBase, names: NameIndex
) -> list[Grounded]:
    """Ground every present mention; one batched embedding call for all windows."""
    words = tokenize(caption)
    present = [m for m in mentions if m.status == "present"]
    texts = [window(words, m) for m in present]
    pools = [candidates(kb, m, _parked(words, m, mentions), _ridden(m, mentions)) for m in present]
    todo = [k for k, pool in enumerate(pools) if len(pool) > 1]
    vectors = names.phrases([texts[k] for k in todo]) if todo else []
    by_k = dict(zip(todo, vectors, strict=True))
    out: list[Grounded] = []
    for k, (found, pool) in enumerate(zip(present, pools, strict=True)):
        ids = tuple(e.id for e in pool)
        if not pool:
            out.append(Grounded(found, CAREFUL))
            continue
        if len(pool) == 1:
            out.append(Grounded(found, Numbers.of(pool[0]), 1.0, ids))
            continue
        query = by_k[k]
        scores = np.array([float(names.vector(e) @ query) + (NAME_MATCH_BONUS if e.id == found.kb_id else 0.0)
                           for e in pool])
        best = int(np.argmax(scores))
        out.append(Grounded(found, Numbers.of(pool[best]), float(scores[best]), ids))
    return out


def most_careful(items: Sequence[Numbers]) -> int:
    """Index of the most careful; the earliest wins a tie (callers put their preferred answer first)."""
    if not items:
        raise ValueError("nothing to choose from")
    best = 0
    for k in range(1, len(items)):
        if care_key(items[k]) > care_key(items[best]):
            best = k
    return best
