"""What a verb says its subject is, when the noun's most frequent sense is a thing.

Some verbs have one kind of subject. Only animals graze, bark, neigh, moo, bleat, peck, purr or
wag (their tails): "a ram grazing on the slope" is the sheep, not the tool, and "it is grazing
alone in a meadow" is an animal no noun names. Only vehicles drive down a road: "a mobile crane
driving along the highway" is a vehicle, not a lifting device. Things that speed are vehicles
when WordNet gives them a vehicle sense, and "a yellow tuk-tuk speeding down a street" names a
vehicle no lexicon knows. This is the rule the mention finder already applies to "parked"
(:data:`.mentions.PARKED`): the verb decides the class.

Only a *thing* is ever read again (a structure, an object, a place, a plant...): people, animals,
vehicles and unknown words keep their class, because each is already at least as careful as
what the verb could make of it by the caption order of :func:`.safety.care_key` (human first,
then living, then moving and buffer). A review of the first version (fa364bd; 267 probe captions)
showed why: WordNet gives "man", "worker", "baby" an animal sense (genus *Homo*), so "a man
barking into a phone", "men pecking at keyboards", "a man grazing the goats" lost their person;
"a truck grazing the guardrail", "a sports car purring" became animals (5 m → 4 m); "a horse
driving down the road pulling a buggy" lost its animal. And a thing is raised by an animal verb
or "speeding" only to a sense WordNet gives the word ("a ball grazing the net", "a smoke detector
chirping", "a wave speeding toward the shore" stay what they are); "driving" down or along a
road raises any thing, since only vehicles do it. A mention the verb raises keeps its status
(negated, depicted).

Verbs of going somewhere under one's own power (:data:`AGENT_VERBS`: walking, moving,
approaching...) have an agent for a subject. A thing doing one ("an object moving fast", "a red
umbrella moving along the sidewalk", "a moving object"), or a noun no rule reads ("a blurry shape
moving across the field"), is someone or something the captioner could not name: an ``unknown``
mention, the careful spec; after a vague noun ("an object crossing the road", "an object rolling
across the road") any verb of motion counts. Not a place, a plant or an idea (:data:`STILL_CLASSES`:
"leaves moving in the wind", "time moving slowly"), a thing the wind moves ("a flag moving in the
wind") or that swings ("back and forth"), one said to be absent ("none of the objects are moving"),
what a person before it wears ("a person in a red shirt walking"), a participle naming a use ("a
walking cane", "a local walking trail"), nor the verbs a still thing does in captions ("a bridge
crossing the river", "a fence running along the road").

A pronoun that may stand for anyone or anything (:data:`AGENT_PRONOUNS`: "they", "it",
"something", "these", "those", "them", "we", and "they're", "we're" written as one word) as the
subject of a verb of action ("they are setting up tents", "it is moving toward the camera",
"something is crossing the road", "those are parked near the gate") names an agent no noun
does: a person, an animal or a vehicle, nobody can tell which.
Its mention is an ``unknown`` one, which the spec answers with the careful fallback (moving,
the largest buffer), as it does an unknown noun; the animal verbs still imply an animal. Not
the impersonal "it" ("it is raining", "it is getting dark", "it is surprising that...", "it is
going to rain"), nor a verb whose first WordNet sense is of weather, emotion or thought ("they
are amazing"), nor a compound noun WordNet knows ("they are sleeping bags"). A caption that
opens with a participle and its object or direction has the same unnamed agent ("jogging along
the river at dawn", "crossing the road"); not a participle before a noun ("parking lot",
"running water"). The rule still over-reads stative verbs of a place ("it is overlooking the
city", "surrounding the lake are trees") and a pronoun that points back at a named thing ("a
statue, it is standing in the square"): more careful, never less (a review of 358 probe
captions found no answer less careful, and about one changed answer in five plainly
over-careful before the weather, emotion, thought and compound guards).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import replace

from .found import Found, Source
from .lexicon import WordNet
from .words import AUXILIARIES, DETERMINERS, FUNCTION_WORDS, PARKED, VAGUE_NOUNS

#: Verbs, as captions write them, that only animals do: their subject is an animal. Not the ones
#: people do too ("sniffing a flower", "roaming", "howling", "trotting").
ANIMAL_VERBS = frozenset(
    "grazing barking neighing mooing bleating braying pecking wagging purring quacking chirping clucking".split()
)
#: Verbs that only a vehicle does when a direction follows ("driving down the road"; "driving a
#: tractor" is transitive and says nothing of its subject).
DRIVING_VERBS = frozenset({"driving"})
#: Verbs a vehicle does though other things may too ("speeding"): a thing is raised only to a
#: vehicle sense WordNet gives it.
MOVING_VERBS = frozenset({"speeding"})
#: Verbs of going somewhere under one's own power, as captions write them: their subject is an
#: agent. A thing doing one ("an object moving fast", "a red umbrella moving along the sidewalk",
#: "a box walking") is someone or something no noun names. Not the verbs a still thing does in
#: captions ("a bridge crossing the river", "a fence running along the road", "a path heading into
#: the woods", "waves rolling in").
AGENT_VERBS = frozenset(
    "walking moving approaching travelling traveling advancing strolling marching hurrying rushing racing "
    "fleeing jogging crawling creeping sneaking".split()
)
VERBS = ANIMAL_VERBS | DRIVING_VERBS | MOVING_VERBS | AGENT_VERBS
#: Agent verbs that qualify the noun after them as a thing that moves ("a moving object"); not
#: the ones that name a use ("a walking cane", "a racing bike", "a travelling circus").
PRENOMINAL_AGENT_VERBS = frozenset({"moving", "approaching", "advancing"})
#: What moves a thing that is no agent ("a flag moving in the wind", "a buoy moving in the
#: waves"); looked for this many words on. Not "air" ("an object moving through the air" flies).
WIND_WORDS = frozenset("wind winds breeze gust gusts waves".split())
WIND_REACH = 6
#: Words after a verb of motion that make it a swing, not a way somewhere ("back and forth").
OSCILLATION_STARTS = frozenset({("back", "and"), ("to", "and"), ("round", "and")})
#: Nouns after a verb of motion that say where to, not what the participle qualifies ("moving north").
WHITHER_NOUNS = frozenset("north south east west home forward forwards backward backwards ahead".split())
#: How far before a thing (words) a negator may stand ("none of the objects are moving", "not a
#: single thing moving").
NEGATION_BEFORE = 3
#: Words that make "driving" intransitive: a direction or a place follows.
DIRECTIONS = frozenset(
    "down along up across through past into onto toward towards around over on in away off by out under "
    "uphill downhill".split()
)
#: Subjects that name no thing: an animal verb after one implies an animal ("it is grazing").
PRONOUNS = frozenset("it they something".split())
#: Pronouns that may stand for a person, an animal or a vehicle: the subject of a verb of action
#: after one is an agent no noun names (module docstring).
AGENT_PRONOUNS = PRONOUNS | frozenset("these those them we they're we're".split())
#: Words that open a verb's object ("crossing the road"), unlike a noun after an adjective in
#: -ing ("parking lot", "running water").
OBJECT_OPENERS = frozenset("a an the this that these those his her their its".split())
#: Verbs of the impersonal "it" ("it is raining", "it is getting dark"): no agent.
IMPERSONAL_VERBS = frozenset("raining snowing drizzling hailing sleeting pouring freezing getting becoming".split())
#: WordNet verb fields (of the most frequent sense) that are no action of an agent a drone must
#: avoid: "it is amazing", "they are interesting", "it is drizzling".
NO_ACTION_FIELDS = frozenset({"weather", "emotion", "cognition"})
#: After "it is ...ing", these open the clause the "it" stands for ("it is surprising that...",
#: "it is going to rain"): the "it" is no agent.
EXTRAPOSED = frozenset("that to how what whether why".split())
#: The shortest word read as a verb in -ing ("sing" is not one: "bring" has 5 letters).
MIN_ING_VERB_LETTERS = 5
#: Words before an implied subject that say nothing is there ("no longer grazing" is not this).
NOTHING = frozenset("no nothing none without".split())
#: Words before a thing that say it is not there, for the agent verbs (a wider window: "not a single thing").
NOT_THERE = NOTHING | {"not"}
#: Classes a verb never changes: each is at least as careful as any reading a verb could give
#: (people, animals: living; vehicles: 5 m; unknown: the careful spec).
SETTLED = frozenset({"person", "animal", "vehicle", "unknown"})
#: Classes an agent verb does not make an agent of: places and plants "move" in the wind and
#: water "rushes", and a path "creeps" up a hill.
STILL_CLASSES = frozenset({"terrain", "vegetation"})
#: Words that make a thing part of what a mention before it wears, carries or pushes ("a person in
#: a red shirt walking", "a dog with a collar moving"): the agent is that mention, not the thing.
ATTRIBUTE_WORDS = frozenset("in with wearing carrying holding pushing pulling".split())
#: How far before the thing (words) the attribute word, and before that word its owner, may stand.
ATTRIBUTE_REACH = 3
#: Words between a subject and its verb that a relative clause puts there ("a box that is moving").
RELATIVE_PRONOUNS = frozenset("that which who".split())
#: Pronouns an adjective may follow before the verb ("something large moving").
INDEFINITE_THINGS = frozenset({"something", "anything"})

Implied = Callable[[], tuple[str, Source, str | None]]


def _subject(words: Sequence[str], j: int, at_end: dict[int, Found], wordnet: WordNet) -> tuple[Found | None, int]:
    """The mention right before the verb at ``j`` (an auxiliary may stand between, and a relative
    pronoun before it: "a box that is moving"), and where the subject's last word is. An
    adjective after "something" belongs to it ("something large moving")."""
    k = j - 1 if j >= 1 and words[j - 1] not in AUXILIARIES else j - 2
    if k >= 1 and words[k] in RELATIVE_PRONOUNS and words[k + 1] in AUXILIARIES:
        k -= 1
    if k >= 1 and at_end.get(k + 1) is None and words[k - 1] in INDEFINITE_THINGS and wordnet.is_adjective(words[k]):
        k -= 1
    return at_end.get(k + 1), k


def _has_sense(wordnet: WordNet, text: str, word_class: str) -> bool:
    """Whether WordNet gives the mention's head word a sense of ``word_class`` (not a group)."""
    senses = wordnet.senses(wordnet.lemma(text.split()[-1]))
    return any(s.word_class == word_class and not s.group for s in senses)


def with_verb_subjects(words: Sequence[str], mentions: list[Found], wordnet: WordNet, animal: Implied) -> list[Found]:
    """``mentions`` with the subjects of :data:`ANIMAL_VERBS`, :data:`DRIVING_VERBS`,
    :data:`MOVING_VERBS` and :data:`AGENT_VERBS` read as the verb says (see the module docstring). ``animal()``: the
    (class, source, kb id) of an animal no noun names. After a determiner the verb qualifies a
    noun ("a grazing field", "a speeding car")."""
    at_end = {m.end: m for m in mentions}
    out = {m.start: m for m in mentions}
    added: list[Found] = []
    for j, verb in enumerate(words):
        if verb not in VERBS and not _acting(wordnet, verb):
            continue
        nxt = words[j + 1] if j + 1 < len(words) else ""
        subject, k = _subject(words, j, at_end, wordnet)
        before = words[k] if k >= 0 else ""
        if before in DETERMINERS and k == j - 1:  # "a grazing field", "a speeding car": the verb qualifies a noun
            qualified = out.get(j + 1)
            if (verb in PRENOMINAL_AGENT_VERBS and qualified is not None and qualified.end == j + 2
                    and qualified.word_class not in SETTLED | STILL_CLASSES and not _compound(wordnet, verb, nxt)):
                out[j + 1] = replace(qualified, word_class="unknown", source="unknown", kb_id=None)  # "a moving object"
            continue
        nothing_there = any(w in NOTHING for w in words[max(0, k - 1) : j])
        if verb in ANIMAL_VERBS:
            if subject is None:
                if before and before not in FUNCTION_WORDS and before not in PRONOUNS:
                    continue  # a word no rule reads as a noun: its own mention, if any, decides
                if nothing_there:
                    continue
                cls, source, kb_id = animal()
                added.append(Found(j, j + 1, verb, cls, source, kb_id))
            elif subject.word_class not in SETTLED and _has_sense(wordnet, subject.text, "animal"):
                out[subject.start] = replace(subject, word_class="animal", source="wordnet", kb_id=None)
            continue
        if (verb in DRIVING_VERBS and nxt in DIRECTIONS) or verb in MOVING_VERBS:
            if subject is not None:
                if subject.word_class not in SETTLED and (
                        verb in DRIVING_VERBS or _has_sense(wordnet, subject.text, "vehicle")):
                    out[subject.start] = replace(subject, word_class="vehicle", source="wordnet", kb_id=None)
                continue
            if _unread_noun(wordnet, before, verb in DRIVING_VERBS) and not any(m.start <= k < m.end for m in mentions):
                added.append(Found(k, k + 1, before, "vehicle", "wordnet"))  # "a yellow tuk-tuk speeding"
                continue
        if _goes_somewhere(words, j, k, subject, wordnet):
            if subject is not None:
                if not _worn(words, subject, mentions):  # "an object moving fast", not "a man in a red shirt walking"
                    out[subject.start] = replace(subject, word_class="unknown", source="unknown", kb_id=None)
                continue
            if _concrete_unread(wordnet, before) and not any(m.start <= k < m.end for m in mentions):
                added.append(Found(k, k + 1, before, "unknown", "unknown"))  # "a robot vacuum moving", unread
                continue
        pronoun = before in AGENT_PRONOUNS and not (before == "it" and (verb in IMPERSONAL_VERBS or nxt in EXTRAPOSED))
        subjectless = j == 0 and verb not in PARKED and nxt in DIRECTIONS | OBJECT_OPENERS  # "crossing the road"
        if subject is None and (pronoun or subjectless) and not nothing_there and not _compound(wordnet, verb, nxt):
            added.append(Found(j, j + 1, verb, "unknown", "unknown"))  # "they are setting up tents"
    return sorted([*out.values(), *added], key=lambda m: (m.start, m.end))


def _goes_somewhere(words: Sequence[str], j: int, k: int, subject: Found | None, wordnet: WordNet) -> bool:
    """Whether the verb at ``j`` says its subject (ending at ``k``) goes somewhere under its own
    power: an :data:`AGENT_VERBS` verb, or any verb of motion after a vague noun ("an object
    crossing the road", "an object rolling across the road"), whose subject is a thing that may be
    an agent (not a person, animal, vehicle or unknown, nor a place or a plant, except a vague
    noun), not blown by the wind, not swinging ("back and forth"), not said to be absent, and not
    a participle before the noun it qualifies ("a local walking trail")."""
    verb = words[j]
    vague = subject is not None and wordnet.lemma(subject.text.split()[-1]) in VAGUE_NOUNS
    if verb not in AGENT_VERBS and not (vague and wordnet.verb_field(verb) == "motion"):
        return False
    if subject is not None and subject.word_class in SETTLED | (frozenset() if vague else STILL_CLASSES):
        return False
    if WIND_WORDS.intersection(words[j + 1 : j + 1 + WIND_REACH]) or tuple(words[j + 1 : j + 3]) in OSCILLATION_STARTS:
        return False
    nxt = words[j + 1] if j + 1 < len(words) else ""
    if (nxt.isalpha() and nxt not in FUNCTION_WORDS and nxt not in WHITHER_NOUNS and not wordnet.is_adjective(nxt)
            and wordnet.noun_class(wordnet.lemma(nxt)) not in (None, "abstract")):
        return False  # "a local walking trail": the participle qualifies the thing after it
    return not NOT_THERE.intersection(words[max(0, k - NEGATION_BEFORE) : j])


def _concrete_unread(wordnet: WordNet, word: str) -> bool:
    """A word in a noun's place that no rule read and that names a thing: WordNet lacks it, or its
    class is no idea, place or plant ("time moving slowly", "prices moving up", "the tide
    approaching" are no agents)."""
    if not _unread_noun(wordnet, word, True):
        return False
    cls = wordnet.noun_class(wordnet.lemma(word))
    return not wordnet.is_known(word) or cls not in (None, "abstract", *STILL_CLASSES)


def _worn(words: Sequence[str], thing: Found, mentions: Sequence[Found]) -> bool:
    """Whether ``thing`` is what a person, animal or vehicle named just before it wears, carries or
    pushes (:data:`ATTRIBUTE_WORDS`): "a person in a red shirt walking" walks, not the shirt."""
    for p in range(thing.start - 1, max(-1, thing.start - 1 - ATTRIBUTE_REACH), -1):
        if words[p] in ATTRIBUTE_WORDS:
            return any(p - ATTRIBUTE_REACH <= m.end <= p and m.word_class in SETTLED for m in mentions)
    return False


def _acting(wordnet: WordNet, word: str) -> bool:
    """A verb of action as captions write it: a present participle ("crossing", "setting") not
    of weather, emotion or thought (:data:`NO_ACTION_FIELDS`), or "parked"
    (:data:`~.words.PARKED`)."""
    if word in PARKED:
        return True
    return len(word) >= MIN_ING_VERB_LETTERS and word.endswith("ing") and word.isalpha() \
        and wordnet.verb_field(word) not in (None, *NO_ACTION_FIELDS)


def _compound(wordnet: WordNet, verb: str, nxt: str) -> bool:
    """The participle and the next word are one noun WordNet knows ("sleeping bags", "fishing
    boats", "parking spaces"): no verb at all."""
    return (bool(nxt) and nxt.isalpha() and nxt not in FUNCTION_WORDS
            and wordnet.is_noun(f"{verb} {wordnet.lemma(nxt)}"))  # not "moving in": a preposition follows


def _unread_noun(wordnet: WordNet, word: str, any_noun: bool) -> bool:
    """A word in a noun's place that no rule read: one WordNet lacks ("tuk-tuk"), or with
    ``any_noun`` (a thing driving down a road) also a WordNet noun."""
    if not word or word in FUNCTION_WORDS or word in PRONOUNS or not word.replace("-", "").isalpha():
        return False
    return not wordnet.is_known(word) or (any_noun and wordnet.is_noun(wordnet.lemma(word)))
