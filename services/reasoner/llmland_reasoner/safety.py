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

**Other readings.** A mention the rules class as a thing (a KB structure, a WordNet object or
place) may name a living being or a vehicle in a rarer sense: "a white crane flying over the
water" (the KB's crane is the machine), "a seal on the beach" (sealing wax is the common
sense), "a taxi cab". Each such WordNet sense (:func:`other_readings`) becomes an
:class:`Alternative`, grounded in its class like any mention, and offered only when it is
more careful in every respect (:func:`dominates`): so whoever chooses among them (the LLM in
``rag``, ``decide.py``) can only add care, never remove it.

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
from .lexicon import CLASS_WORDS, WordNet
from .mention_cache import CachedGrounding, MentionCache, MentionKey
from .mentions import RIDDEN_IDS, Found, tokenize
from .words import DETERMINERS, FUNCTION_WORDS

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
class Alternative:
    """Another reading of a mention (a rarer WordNet sense), grounded in its own class."""

    word_class: str
    plain: tuple[str, ...]  # what it would be, in plain words ("bird")
    numbers: Numbers


@dataclass(frozen=True)
class Grounded:
    """A mention, the numbers it was given and the entries it could have been given."""

    found: Found
    numbers: Numbers
    score: float = 0.0
    pool: tuple[str, ...] = ()
    #: what the rules' reading is, in plain words ("device"); empty when there is no other reading
    plain: tuple[str, ...] = ()
    alternatives: tuple[Alternative, ...] = ()


def care_key(n: Numbers) -> tuple[bool, bool, bool, float, float]:
    """Larger = more careful: human, living (or unknown), dynamic, buffer, altitude floor."""
    return (n.is_human, n.category in ("person", "animal", "unknown"), n.is_dynamic, n.buffer_m, n.z_min)


def dominates(a: Numbers, b: Numbers) -> bool:
    """Whether ``a`` is at least as careful as ``b`` in every respect (human, moving, buffer) and
    more careful in one: the only change another reading may make."""
    at_least = a.is_human >= b.is_human and a.is_dynamic >= b.is_dynamic and a.buffer_m >= b.buffer_m
    return at_least and (a.is_human, a.is_dynamic, a.buffer_m) != (b.is_human, b.is_dynamic, b.buffer_m)


#: The classes a thing's rarer sense may raise it to. Not person: the person senses WordNet
#: gives thing-nouns are figurative ("a brick": a good fellow, "a head": a chief, "the sun": a
#: person's light), measured on the COCO/Flickr references (``data/SENSES.md``).
RAISE_CLASSES = ("animal", "vehicle")
#: Mention classes that have no other reading: already the careful ones, or depictions by rule.
_SETTLED = frozenset({"person", "animal", "vehicle", "lookalike", "unknown", "abstract"})


def other_readings(found: Found, wordnet: WordNet) -> tuple[tuple[str, ...], dict[str, tuple[str, ...]]]:
    """The plain words of the rules' reading of a thing-mention and, per raise class, of its
    other senses: WordNet senses of the mention (a compound as a whole, "storage tank", else
    its head noun) in an animal or vehicle
    class whose first name is that word ("crane" the bird; not "tower" the tugboat, whose first
    name is "tugboat"), not through a group ("a head of cattle" is one animal, "a team" a group).
    No vehicle reading for a bicycle: whether one is ridden is the rider rule's."""
    if found.status != "present" or found.word_class in _SETTLED:
        return (), {}
    *head, last = found.text.split()
    whole = " ".join([*head, wordnet.lemma(last)])  # "storage tanks" -> "storage tank"
    senses = wordnet.senses(whole) or wordnet.senses(wordnet.lemma(last))
    others: dict[str, list[str]] = {}
    for s in senses:
        if s.word_class in RAISE_CLASSES and s.first_lemma and not s.group:
            if s.word_class == "vehicle" and found.kb_id in RIDDEN_IDS:
                continue
            others.setdefault(s.word_class, [])
            if s.plain not in others[s.word_class]:
                others[s.word_class].append(s.plain)
    if not others:
        return (), {}
    own = [s.plain for s in senses if s.word_class not in (*RAISE_CLASSES, "person", "abstract")]
    plain = tuple(dict.fromkeys(own)) or (CLASS_WORDS.get(found.word_class, "thing"),)
    return plain, {cls: tuple(w for w in words if w not in plain) or tuple(words) for cls, words in others.items()}


def window(words: Sequence[str], found: Found) -> str:
    return " ".join(words[found.start : max(found.end, found.start + WINDOW_WORDS)])


#: Classes whose KB-named mention is its named entry: a static thing the KB names is that thing,
#: whatever the words after it resemble ("a green tree on the grass" was the KB's tall grass,
#: altitude floor 1.5 m against a tree's 12 m: the window's "grass" won the similarity).
STATIC_NAMED_CLASSES = frozenset({"structure", "vegetation"})


def candidates(kb: KnowledgeBase, found: Found, parked: bool = False, ridden: bool = False,
               astride: bool = False) -> list[KbEntry]:
    """The KB entries a mention may be grounded in: its class's; for a vehicle the moving ones,
    or the parked ones when its window says it is parked; for a place the KB does not name,
    plain ground (water and rocks only by name); for a person the riders (a person
    class with a larger buffer: cyclist) only when a vehicle or bicycle is named near it, and
    only the riders when the caption puts the person on it (``astride``: "a boy on a dirt bike")
    or names the person by a rider's KB name ("bikers on the trail"); for a static thing the KB
    names (:data:`STATIC_NAMED_CLASSES`), its named entry."""
    categories = CLASS_CATEGORIES.get(found.word_class, ())
    entries = [e for e in kb.entries if e.category in categories]
    if found.word_class == "terrain" and found.source == "wordnet":
        entries = [e for e in entries if e.buffer_m == 0.0] or entries  # a place the KB lacks is ground
    if found.word_class == "person":
        floor = MIN_BUFFER_M["person"]
        named_rider = any(e.id == found.kb_id and e.buffer_m > floor for e in entries)  # "bikers"
        if astride or named_rider:
            entries = [e for e in entries if e.buffer_m > floor] or entries
        elif not ridden:
            entries = [e for e in entries if e.buffer_m <= floor or e.id == found.kb_id] or entries
    if found.word_class == "vehicle":
        made = _make_entry(kb, found)
        if made is not None and made.is_dynamic != parked:
            return [made]  # "a caterpillar dozer": the make's own vehicle (was the aircraft the window resembled)
        entries = [e for e in entries if e.is_dynamic != parked] or entries
    if found.word_class in STATIC_NAMED_CLASSES:
        entries = [e for e in entries if e.id == found.kb_id] or entries
    return entries


def _make_entry(kb: KnowledgeBase, found: Found) -> KbEntry | None:
    """The KB vehicle a mention names by one of its makes ("a ford mustang", "a caterpillar dozer":
    ``makes.py`` gave the mention that entry), else None."""
    if found.source != "kb" or found.kb_id is None:
        return None
    try:
        entry = kb.get(found.kb_id)
    except KeyError:
        return None
    words = found.text.split()  # the mention's words, as tokenize wrote them; a make's too (as makes.py)
    return entry if any(make and words[: len(make)] == make for make in map(tokenize, entry.makes)) else None


#: The KB's two-wheelers, whose rider is the KB's cyclist (5 m: "a person riding a bicycle or
#: motorbike"); a person on a skateboard, a boat or a bus is not put among the riders by rule.
TWO_WHEELER_IDS = RIDDEN_IDS | {"motorcycle"}
#: Words that put a person on the vehicle or bicycle named after them ("a boy on a dirt bike",
#: "a man riding a moped"): then the person is its rider, whatever the window resembles most.
RIDING_CUES = frozenset("on riding rides ride rode astride atop aboard onboard mounted".split())
#: The riding cues that are verbs: what follows is ridden, even a thing no one knows.
RIDING_VERBS = frozenset("riding rides ride rode".split())
#: How many words may stand between a riding cue and the two-wheeler it puts the person on
#: ("on a motorbike", "riding his old dirt bike").
RIDE_REACH = 3
#: How many words may stand between a person and the riding cue after them: what they wear or
#: carry ("a man in a red helmet riding a motorcycle"), with no other person named in between.
RIDER_TO_CUE_REACH = 5
#: Words that say a two-wheeler is parked when they stand right next to it ("a parked
#: motorcycle", "a moped parked by the road"): nobody rides it. Not "stationary" (stopped at a
#: light with its rider on), nor a cue of a thing named after it ("near a parked van").
PARKED_TWO_WHEELER = frozenset("parked docked abandoned".split())


def _ridden(person: Found, mentions: Sequence[Found]) -> bool:
    """Whether a vehicle or a bicycle is named within the person's window ("a boy riding his bicycle")."""
    return any(person.end <= m.start < person.start + WINDOW_WORDS
               and (m.word_class == "vehicle" or m.kb_id in RIDDEN_IDS) for m in mentions)


#: Words that put a person named right after a two-wheeler on it ("a motorbike with two riders").
CARRYING_CUES = frozenset({"with", "carrying"})
#: Verbs that put the person named before them on a two-wheeler ("a man cycling down the road",
#: "a family biking along the canal"), where they are verbs (:func:`_cycling`).
CYCLING_VERBS = frozenset(
    "cycling cycled bicycling biking biked pedalling pedaling pedalled pedaled motorcycling motorbiking".split())
#: Words after which a cycling word is a noun ("watching the cycling", "talking about cycling").
NOUN_OPENERS = DETERMINERS | frozenset("about of for from after before during into like to".split())


def _carried(words: Sequence[str], person: Found, mentions: Sequence[Found]) -> bool:
    """Whether the person is named right after a two-wheeler (neither negated nor parked right
    there): right after it, the person noun is named by it ("a motorbike rider", "a moped driver",
    "a bicycle courier"; also "a motorcycle officer", "a bicycle repairman", read as its rider:
    the larger buffer), or :data:`CARRYING_CUES` say it carries them, at most :data:`RIDE_REACH`
    words on ("a motorbike with two riders", "a scooter carrying a woman"), no other thing named
    between."""
    prev = max((m for m in mentions if m.end <= person.start), key=lambda m: m.end, default=None)
    if prev is None or not _rideable(words, prev):
        return False
    gap = words[prev.end : person.start]
    return not gap or (gap[0] in CARRYING_CUES and len(gap) <= RIDE_REACH)


def _cycling(words: Sequence[str], j: int, mentions: Sequence[Found]) -> bool:
    """Whether ``words[j]`` is a :data:`CYCLING_VERBS` verb: not a noun (after a
    :data:`NOUN_OPENERS` word: "watching the cycling") nor a modifier of a thing named right after
    it ("the cycling path")."""
    return (words[j] in CYCLING_VERBS and not (j > 0 and words[j - 1] in NOUN_OPENERS)
            and not any(m.start == j + 1 for m in mentions))


def _rideable(words: Sequence[str], m: Found, by_verb: bool = False) -> bool:
    """A two-wheeler (:data:`TWO_WHEELER_IDS`) neither negated nor parked right there (its words and
    one each side, :data:`PARKED_TWO_WHEELER`): someone may be riding it. With ``by_verb`` (a
    riding verb puts the person on it, :data:`RIDING_VERBS`), also a word neither the KB nor
    WordNet knows ("a man riding a bicyle": the rider of an unknown thing takes the rider's larger
    buffer, as an unknown thing takes the careful spec; was a 3 m skateboarder). Not after "on":
    "a man on the sidewlk" is on a place."""
    beside = words[max(0, m.start - 1) : m.end + 1]
    maybe = m.kb_id in TWO_WHEELER_IDS or (by_verb and m.word_class == "unknown")
    return maybe and m.status != "negated" and not PARKED_TWO_WHEELER & set(beside)


def _astride(words: Sequence[str], person: Found, mentions: Sequence[Found]) -> bool:
    """Whether the caption puts the person on a two-wheeler: a :data:`RIDING_CUES` word at most
    :data:`RIDER_TO_CUE_REACH` words after the person whose next thing named, at most
    :data:`RIDE_REACH` words after it, is a two-wheeler (:data:`TWO_WHEELER_IDS`) neither negated
    nor parked right there ("a man on the sidewalk riding a bicycle"; "a child sitting on a parked
    motorcycle" rides nothing, :data:`PARKED_TWO_WHEELER`), with no other person named from the
    person to it ("a man next to a boy on a bike": the boy rides it); or a cycling verb
    (:func:`_cycling`) within those words, the first one deciding, with no other person named
    before it; or a two-wheeler before the person carries them (:func:`_carried`)."""
    if _carried(words, person, mentions):
        return True

    def someone_else_before(end: int) -> bool:  # another person named from this one to ``end``
        return any(m.word_class == "person" for m in mentions if person.end <= m.start < end)

    for j in range(person.end, min(len(words), person.end + RIDER_TO_CUE_REACH + 1)):
        if _cycling(words, j, mentions):
            return not someone_else_before(j)
        if words[j] not in RIDING_CUES:
            continue
        nxt = min((m for m in mentions if m.start > j), key=lambda m: m.start, default=None)
        if nxt is None or nxt.start - j > RIDE_REACH:
            continue
        if someone_else_before(nxt.start + 1):
            return False  # another person comes first: what follows is theirs
        if _rideable(words, nxt, words[j] in RIDING_VERBS):
            return True
    return False


def _parked(words: Sequence[str], vehicle: Found, mentions: Sequence[Found]) -> bool:
    """Whether a stationary cue belongs to this vehicle: within :data:`CUE_REACH` words after it
    ("cars are parked") or before it ("parked with numerous cars"), no other thing in between.
    Not "parking" right after it as a verb ("a truck parking along the curb": it still moves),
    nor a cue right before another thing, which it qualifies ("an SUV leaving the parking
    garage", "a bus passing the parked cars": the garage, the cars)."""
    others = [m for m in mentions if m is not vehicle]
    starts = {m.start: m for m in others}
    for j in range(max(0, vehicle.start - CUE_REACH), min(len(words), vehicle.end + CUE_REACH)):
        if j == vehicle.end and words[j] == "parking" and (j + 1 == len(words) or words[j + 1] in FUNCTION_WORDS):
            continue  # "a truck parking along the curb": still moving, into its space
        if j + 1 in starts and (words[j] == "parking" or starts[j + 1].word_class == "vehicle"):
            continue  # "the parking garage", "the parked cars": another thing's word ("cars parked road": not a road's)
        if words[j] in STATIONARY_CUES and not (vehicle.start <= j < vehicle.end):
            lo, hi = sorted((j, vehicle.start if j < vehicle.start else vehicle.end - 1))
            if not any(lo < m.start <= hi or lo <= m.end - 1 < hi for m in others):
                return True
    return any(w in STATIONARY_CUES for w in words[vehicle.start : vehicle.end])  # "parked car"


def _best(pool: Sequence[KbEntry], query: np.ndarray | None, names: NameIndex, kb_id: str | None) -> tuple[int, float]:
    if len(pool) == 1 or query is None:
        return 0, 1.0
    scores = np.array([float(names.vector(e) @ query) + (NAME_MATCH_BONUS if e.id == kb_id else 0.0) for e in pool])
    best = int(np.argmax(scores))
    return best, float(scores[best])


@dataclass(frozen=True)
class _Context:
    """The present mentions of a caption, each one's window and its parked, ridden and astride flags."""

    present: list[Found]
    texts: list[str]
    parked: list[bool]
    ridden: list[bool]
    astride: list[bool]

    def key(self, cache: MentionCache, kb: KnowledgeBase, k: int) -> MentionKey:
        return cache.key(kb, self.present[k], self.texts[k], self.parked[k], self.ridden[k], self.astride[k])

    def pool(self, kb: KnowledgeBase, k: int) -> list[KbEntry]:
        return candidates(kb, self.present[k], self.parked[k], self.ridden[k], self.astride[k])


def _context(caption: str, mentions: Sequence[Found]) -> _Context:
    words = tokenize(caption)
    present = [m for m in mentions if m.status == "present"]
    return _Context(present, [window(words, m) for m in present], [_parked(words, m, mentions) for m in present],
                    [_ridden(m, mentions) for m in present], [_astride(words, m, mentions) for m in present])


def uncached_windows(caption: str, mentions: Sequence[Found], kb: KnowledgeBase,
                     cache: MentionCache | None) -> list[str]:
    """The windows :func:`ground_mentions` may have to embed (those of mentions not in
    ``cache``): a batch prefetches them in one embedding call."""
    ctx = _context(caption, mentions)
    if cache is None:
        return ctx.texts
    return [ctx.texts[k] for k in range(len(ctx.present)) if not cache.has(ctx.key(cache, kb, k))]


def ground_mentions(
    caption: str, mentions: Sequence[Found], kb: KnowledgeBase, names: NameIndex, wordnet: WordNet | None = None,
    cache: MentionCache | None = None,
) -> list[Grounded]:
    """Ground every present mention, and the other readings of each (when ``wordnet`` is
    given); one batched embedding call for all windows not already grounded in ``cache``."""
    ctx = _context(caption, mentions)
    present, texts, parked = ctx.present, ctx.texts, ctx.parked
    keys = [] if cache is None else [ctx.key(cache, kb, k) for k in range(len(present))]
    known = [None] * len(present) if cache is None else [cache.get(k) for k in keys]
    todo_k = [k for k in range(len(present)) if known[k] is None]
    pools = {k: ctx.pool(kb, k) for k in todo_k}
    readings = {k: other_readings(present[k], wordnet) if wordnet is not None else ((), {}) for k in todo_k}
    todo = [k for k in todo_k if len(pools[k]) > 1 or readings[k][1]]
    vectors = names.phrases([texts[k] for k in todo]) if todo else []
    by_k = dict(zip(todo, vectors, strict=True))
    out: list[Grounded] = []
    for k, found in enumerate(present):
        done = known[k]
        if done is None:
            done = _ground_one(kb, names, found, pools[k], readings[k], by_k.get(k), parked[k])
            if cache is not None:
                cache.put(keys[k], done)
        out.append(Grounded(found, done.numbers, done.score, done.pool, done.plain, done.alternatives))
    return out


def _ground_one(kb: KnowledgeBase, names: NameIndex, found: Found, pool: Sequence[KbEntry],
                readings: tuple[tuple[str, ...], dict[str, tuple[str, ...]]], vector: np.ndarray | None,
                parked: bool) -> CachedGrounding:
    if not pool:
        return CachedGrounding(CAREFUL, 0.0, (), (), ())
    best, score = _best(pool, vector, names, found.kb_id)
    numbers = Numbers.of(pool[best])
    plain, others = readings
    alternatives: list[Alternative] = []
    for cls, words_of in others.items():
        as_cls = Found(found.start, found.end, found.text, cls, "wordnet", None, found.status)
        alt_pool = candidates(kb, as_cls, parked)
        if alt_pool:
            alt = Numbers.of(alt_pool[_best(alt_pool, vector, names, None)[0]])
            if dominates(alt, numbers):
                alternatives.append(Alternative(cls, words_of, alt))
    return CachedGrounding(numbers, score, tuple(e.id for e in pool), plain if alternatives else (),
                           tuple(alternatives))


def most_careful(items: Sequence[Numbers]) -> int:
    """Index of the most careful; the earliest wins a tie (callers put their preferred answer first)."""
    if not items:
        raise ValueError("nothing to choose from")
    best = 0
    for k in range(1, len(items)):
        if care_key(items[k]) > care_key(items[best]):
            best = k
    return best
