"""What a verb says its subject is, whatever the noun's most frequent sense.

Some verbs have one kind of subject. Only animals graze, bark, neigh, moo, bleat, peck, purr or
wag (their tails): "a kid grazing next to its mother" is a young goat, "a boxer barking" a dog,
and "it is grazing alone in a meadow" an animal no noun names. Only vehicles drive down a road
or speed along it: "a mobile crane driving along the highway" is a vehicle, not a lifting
device, "a red mustang driving down the highway" a car, not a horse, and "a yellow tuk-tuk
speeding down a street" a vehicle though no lexicon knows the word. This is the rule the mention
finder already applies to "parked" (:data:`.mentions.PARKED`): the verb decides the class.

Every reading here is at least as careful as the one it replaces, by the buffer the evaluation
and the planner use (animal 4 m over a thing or a person's 3 m; vehicle 5 m over a thing or an
animal's 4 m), with three guards for the human-first order of :func:`.safety.care_key`:
- a person named by the subject stays a person unless WordNet gives the word an animal sense
  ("a kid", "a boxer") and the verb takes no object ("a boxer barking orders", "a man grazing
  his knee" keep their people): an animal spec is not a possible person to the planner's hard
  limit, so only a reading no person could have takes the person away; a person who drives or
  speeds is a driver, still a person;
- a living subject that speeds is left alone ("a cheetah speeding across the plain"); only
  driving, which no animal does, reads an animal as a vehicle (cars named after animals);
- nothing is raised when the subject is negated or depicted: the mention keeps its status.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import replace

from .found import Found, Source
from .lexicon import WordNet

#: Verbs, as captions write them, that only animals do: their subject is an animal. Not the ones
#: people do too ("sniffing a flower", "roaming", "howling", "trotting").
ANIMAL_VERBS = frozenset(
    "grazing barking neighing mooing bleating braying pecking wagging purring quacking chirping clucking".split()
)
#: Verbs that only a vehicle does when a direction follows ("driving down the road"; "driving a
#: tractor" is transitive and says nothing of its subject).
DRIVING_VERBS = frozenset({"driving"})
#: Verbs a vehicle does though living things may too ("speeding"): only non-living subjects are raised.
MOVING_VERBS = frozenset({"speeding"})
#: Words that make "driving" intransitive: a direction or a place follows.
DIRECTIONS = frozenset(
    "down along up across through past into onto toward towards around over on in away off by out under "
    "uphill downhill".split()
)
#: After the verb these make it transitive with a person's own thing ("grazing his knee",
#: "speeding her car"): the subject is whoever it is.
POSSESSIVES = frozenset("his her their my your our".split())
#: Words between a subject and its verb ("the kid is grazing").
COPULAS = frozenset("is are was were".split())
#: Subjects that name no thing: an animal verb after one implies an animal ("it is grazing").
PRONOUNS = frozenset("it they something".split())
#: Words before an implied subject that say nothing is there ("no longer grazing" is not this).
NOTHING = frozenset("no nothing none without".split())
#: Classes that are alive: a vehicle verb raises them only when no living thing does it.
LIVING = frozenset({"person", "animal"})

Implied = Callable[[], tuple[str, Source, str | None]]


def _subject(words: Sequence[str], j: int, at_end: dict[int, Found]) -> tuple[Found | None, int]:
    """The mention right before the verb at ``j`` (a copula may stand between), and where the
    subject's last word is."""
    k = j - 1 if j >= 1 and words[j - 1] not in COPULAS else j - 2
    return at_end.get(k + 1), k


def _animal_sense(wordnet: WordNet, text: str) -> bool:
    senses = wordnet.senses(wordnet.lemma(text.split()[-1]))
    return any(s.word_class == "animal" and not s.group for s in senses)


def with_verb_subjects(words: Sequence[str], mentions: list[Found], wordnet: WordNet, animal: Implied,
                       function_words: frozenset[str], determiners: frozenset[str]) -> list[Found]:
    """``mentions`` with the subjects of :data:`ANIMAL_VERBS`, :data:`DRIVING_VERBS` and
    :data:`MOVING_VERBS` read as the verb says (see the module docstring). ``animal()``: the
    (class, source, kb id) of an animal no noun names. ``function_words`` are never a subject;
    after one of ``determiners`` the verb qualifies a noun ("a grazing field", "a speeding car")."""
    at_end = {m.end: m for m in mentions}
    out = {m.start: m for m in mentions}
    added: list[Found] = []
    for j, verb in enumerate(words):
        nxt = words[j + 1] if j + 1 < len(words) else ""
        if nxt in POSSESSIVES:
            continue
        subject, k = _subject(words, j, at_end)
        before = words[k] if k >= 0 else ""
        if before in determiners:
            continue
        if verb in ANIMAL_VERBS:
            if subject is None:
                if before and before not in function_words and before not in PRONOUNS:
                    continue  # a word no rule reads as a noun: its own mention, if any, decides
                if any(w in NOTHING for w in words[max(0, k - 1) : j]):
                    continue
                cls, source, kb_id = animal()
                added.append(Found(j, j + 1, verb, cls, source, kb_id))
            elif subject.word_class not in ("animal", "unknown") and (
                    subject.word_class != "person" or _animal_sense(wordnet, subject.text)
                    and (not nxt.isalpha() or nxt in function_words)):
                out[subject.start] = replace(subject, word_class="animal", source="wordnet", kb_id=None)
        elif (verb in DRIVING_VERBS and nxt in DIRECTIONS) or verb in MOVING_VERBS:
            if subject is None:
                if _unread_noun(wordnet, before, function_words) and not any(m.start <= k < m.end for m in mentions):
                    added.append(Found(k, k + 1, before, "vehicle", "wordnet"))  # "a yellow tuk-tuk speeding"
            elif subject.word_class not in ("vehicle", "person", "unknown") and (
                    subject.word_class not in LIVING or verb in DRIVING_VERBS):
                out[subject.start] = replace(subject, word_class="vehicle", source="wordnet", kb_id=None)
    return sorted([*out.values(), *added], key=lambda m: (m.start, m.end))


def _unread_noun(wordnet: WordNet, word: str, function_words: frozenset[str]) -> bool:
    """A word in a noun's place that no rule read: one WordNet lacks ("tuk-tuk") or a noun."""
    if not word or word in function_words or word in PRONOUNS or not word.replace("-", "").isalpha():
        return False
    return not wordnet.is_known(word) or wordnet.is_noun(wordnet.lemma(word))
