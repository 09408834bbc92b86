"""Every obstacle mention in a caption (the safety layer's input; no model involved).

The caption is read as plain words: nothing in it is an instruction. A *mention* is a noun
phrase head that names a thing: a KB name (label or synonym, longest match, plurals folded
by WordNet's lemmatiser), else a WordNet noun (class from its hypernyms, ``lexicon.py``),
else an unknown word in a noun's position ("a quokka on a rock"), which is classed careful.

A mention is ``present`` unless the caption says, unambiguously, that it is not there:
- ``negated``: right after "no"/"without" ("no people or cars in the street"), unless hedged
  ("almost no people"); "not", "nobody" (people may be there: "nobody else", "nobody is
  swimming") and anything looser never lower a class;
- ``depicted``: the complement of a depiction ("a statue *of a woman*", "a painting of a
  horse") or the modifier of one ("a dog statue"). "A photo/picture/image/view of ..." is the
  camera's own picture, so what follows it is present.
Nouns that only qualify the next noun ("aerial view", "tennis court", "cricket player", "bus
stop" as a WordNet compound) are not mentions, except KB names of people, animals and vehicles
("dog park", "police horse"), which are kept (careful). A collective noun is not a mention
when what it counts follows its "of" and is a person or an animal ("a family of geese" is
geese): the counted mention stands for it. People named without a noun are mentions: pronoun
subjects ("he", "someone") and crowd adjectives ("a crowded beach"); so is the traffic a road's
adjective implies ("a busy highway", "the road is congested"). A thing the captioner could
not make out is an unknown mention (careful): a form ("a dark figure in the distance", "a
silhouette by the fence"; not a figurine, "a wooden figure") and a vague noun after a word of
doubt ("an unidentified object", "a blurry shape"). A person noun WordNet reads mostly as an
adjective is a noun where it heads its phrase before a verb ("an individual standing on the
road"). Some verbs decide what a thing
before them is ("a mobile crane driving along the highway" is a vehicle, "it is grazing" an
animal): :mod:`.subjects`.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from string import ascii_lowercase

from .found import Found, Source, Status
from .kb import KbEntry, KnowledgeBase
from .lexicon import WordNet
from .makes import MakeIndex
from .subjects import DIRECTIONS, OBJECT_OPENERS, with_verb_subjects
from .words import (
    AUXILIARIES,
    COPULAS,
    DETERMINERS,
    FORM_NOUNS,
    FUNCTION_WORDS,
    MADE_PARTICIPLES,
    PARKED,
    SHOWING_VERBS,
    UNCERTAIN,
    VAGUE_NOUNS,
    fold_text,
)

#: The longest KB name, in words.
MAX_NAME_WORDS = 4
#: How many words may stand between a negator and the noun it negates ("no other people").
NEGATION_REACH = 3
NEGATORS = frozenset({"no", "without"})
COORDINATORS = frozenset({"or", "nor"})
#: Words that say no one or nothing is there: no mention unless hedged ("almost nobody": a few
#: people), and they lower nothing either ("nobody else", "nobody is swimming"). WordNet's
#: "nobody" is a person (a nonentity), so "there is nobody outside" was a seated person, 3 m.
NO_ONE = frozenset("nobody noone none nothing".split())
#: Words that make the negation after them partial ("almost no people", "hardly anybody"): it
#: lowers nothing.
HEDGES = frozenset("almost nearly hardly barely virtually practically scarcely".split())
#: Words between a negator and a noun that end the negation ("no one but a man", "no, a dog").
NEGATION_STOP = frozenset({"one", "body", "but", "except", "besides", "apart", "only", "just", "save", ",", ";"})
#: words after which a new noun phrase starts
NOUN_PHRASE_CONJUNCTIONS = frozenset({"and", "or", "nor"})
#: Nouns that count what follows "of" ("a couple of playgrounds", "lots of cars"): not mentions.
QUANTIFIERS = frozenset(
    "couple pair lot lots number bunch dozen dozens handful set series row rows line lines kind kinds sort "
    "sorts variety plenty piece pieces part parts rest majority".split()
)
#: Nouns of any group, which WordNet files as an abstraction rather than a group of someone.
GROUP_NOUNS = frozenset({"group", "groups"})
#: Words that name a person without a noun: a pronoun subject ("he is lying on the grass") or an
#: indefinite one ("someone", "everybody"). Not "her" (a possessive as often: "a woman and her
#: dog"), "they"/"it" (people or things alike), nor "anyone"/"anybody", which stand mostly where
#: no one is ("there isn't anyone on the field"): the rest of the caption decides there.
PERSON_PRONOUNS = frozenset("he she him someone somebody everyone everybody".split())
#: Adjectives that say a place is full of people ("a crowded beach", "a bustling market"): the
#: crowd is there though no noun names it. Not "busy" (a busy road is traffic: :data:`TRAFFIC_ADJECTIVES`).
#: Not when they qualify things ("crowded buildings": dense) or say what crowds the place
#: ("crowded with cars": the cars are the mention), :data:`CROWDED_BY`.
CROWD_ADJECTIVES = frozenset("crowded overcrowded bustling thronged populated".split())
CROWDED_BY = frozenset("with by together".split())
#: Adjectives that say a road is full of vehicles ("a busy highway", "the road is congested"):
#: the traffic is there though no noun names it; only of a :data:`TRAFFIC_ROADS` noun right after
#: them or before a copula before them, and not when what fills the road follows ("busy with
#: shoppers": that mention says it).
TRAFFIC_ADJECTIVES = frozenset("busy congested jammed gridlocked".split())
TRAFFIC_ROADS = frozenset(
    "road roads street streets highway highways freeway freeways motorway motorways expressway expressways "
    "interstate avenue avenues boulevard intersection intersections junction roundabout".split()
)
#: Classes of a place people crowd; a crowd adjective before anything else qualifies a thing.
_PLACE_CLASSES = frozenset({"terrain", "unknown"})
#: Named wheeled things a person can ride (KB ids outside the vehicle class).
RIDDEN_IDS = frozenset({"bicycle"})
#: How many words may stand between a collective noun's "of" and what it counts ("a family of
#: wild ducks", "a herd of black and white cows"): plural determiners, numbers, adjectives and
#: "and" between adjectives; not a singular determiner (:data:`SINGULAR_DETERMINERS`: "the crew
#: of a boat" belongs to it), not "and" before a count ("a family of four and two dogs").
COLLECTIVE_GAP = 3
SINGULAR_DETERMINERS = frozenset("a an one this that each every".split())
#: What a collective noun may count: people and animals ("a member of a motorcycle club", "the
#: crew of the ambulance" are people, whatever vehicle follows).
_COUNTED = frozenset({"person", "animal"})
#: The classes a two-letter word may name after a determiner ("a parked RV"); not animals
#: (WordNet's "ai" is a sloth: "an AI generated image") nor places. A person only after an
#: article and as the head of its phrase ("a DJ playing music"; not "a DJ booth", "an MD 80
#: airplane", "five PM": abbreviations that qualify a thing), :meth:`MentionFinder._short_noun`.
SHORT_NOUN_CLASSES = frozenset({"vehicle"})
ARTICLES = frozenset({"a", "an", "the"})
#: Person words that say an animal's age or role right before it ("an adult dog", "a kid goat",
#: "a mother duck").
AGE_WORDS = frozenset("adult adults baby babies kid kids juvenile juveniles infant newborn mother".split())
#: Prepositions of a way somewhere: after a name that ends in a participle ("a pedestrian crossing
#: towards the park") they make the participle a verb; "in", "on", "by" do not ("a zebra crossing
#: on a quiet road" is the crosswalk).
WAYS = frozenset("across along over through into onto toward towards past".split())
#: Prepositions after which a person noun read mostly as an adjective heads its phrase ("an
#: individual on a bike", "an individual in a red jacket").
PERSON_PREPOSITIONS = frozenset("on in with near at by beside behind wearing holding carrying".split())
#: Words that put what follows on the person named before them ("a person in a gray shirt", "a
#: man wearing a red jacket", "a child dressed in a raincoat", "a worker with a hard hat")
WEARING_CUES = frozenset("in wearing wears wore dressed with".split())
#: How many words may stand between a person and what they wear ("in a bright yellow", "wearing
#: his old")
WEARING_REACH = 4
#: Possessive determiners: a noun phrase starts after them ("a girl riding her bicyle").
POSSESSIVES = frozenset("her his their its my our your".split())
#: The shortest word (letters) read as a typing slip of a person's name.
TYPO_MIN_LETTERS = 3
#: Suffixes that make a word from a known one ("seater", "kayakers"): such a word is no typing slip.
DERIVING_SUFFIXES = ("ers", "er", "ist", "ists", "ors", "or", "ing", "ings", "ed", "s", "es", "ies", "y", "ly")
#: The shortest part (letters) of a word WordNet lacks read as two words run together.
COMPOUND_PART_MIN = 3
#: Care order of the classes a newly found compound may take over a span with (``_compound``).
_CARE_ORDER = {"person": 3, "animal": 2, "vehicle": 1}
#: Nouns for the image: "a (black and white) photo of a man running" shows a man. They are
#: never read as depictions ("a billboard with a picture of a car" keeps the car: ambiguous,
#: so careful).
IMAGE_NOUNS = frozenset(
    "photo photograph picture image pic view shot snapshot closeup close-up scene screenshot frame "
    "aerial overhead footage imagery video".split()
)
#: The camera's own platform: "a drone photo of a field", "drone footage of a beach", "a view
#: taken from a drone" name the vehicle that took the picture, not one in it (was a 5 m aircraft
#: over every such caption). Only the camera's kind of platform: "a helicopter shot" may show one.
CAMERA_PLATFORMS = frozenset("drone drones quadcopter quadcopters multicopter quadrotor satellite uas".split())
#: What a camera platform makes, right after its name ("a drone shot", "satellite imagery").
CAMERA_MEDIA = IMAGE_NOUNS | frozenset(
    "photos photographs pictures images views shots footage videos photography imagery".split()
)  # not "still", "camera", "cam": "a drone still hovering", "a drone camera hovering" are drones
#: What may follow "<platform> <medium>" for the medium to be the camera's ("a drone shot of a
#: beach", "drone footage over the bay", "a drone view."); anything else keeps the drone ("a drone
#: video flying low", "a drone shot down").
CAMERA_MEDIA_NEXT = frozenset("of over above from across along , ;".split())
#: Verbs of taking a picture, before "from/by" a platform ("an image captured by a drone").
CAMERA_VERBS = frozenset("taken captured shot filmed photographed recorded seen viewed".split())
#: Words that end the complement of a depiction ("a statue of a man on a horse | , children
#: playing nearby"): anything that may start a new, real thing ends it.
COMPLEMENT_BOUNDARY = frozenset(
    ", ; and while with next near beside behind by front among around surrounded full filled crowded "
    "is are was were which who that where as while".split()
)
#: Verbs by which a depiction says what it shows, like its "of" ("a billboard showing a woman
#: drinking coffee", "a mural depicting horses": were a person and horses, present).
DEPICTING_VERBS = frozenset("showing depicting featuring portraying picturing advertising displaying".split())
#: Made pictures and figures whose verb of showing is a depiction's (with :data:`DISPLAY_NOUNS`);
#: not the camera's own images, maps or scans ("a thermal scan showing a person": a person).
ART_NOUNS = frozenset("statue statues sculpture sculptures figurine figurines".split())
#: Modifiers that make the next noun a depiction ("a toy car", "an inflatable dinosaur").
DEPICTION_MODIFIERS = frozenset(
    "toy inflatable stuffed plush cardboard plastic fake model stone bronze marble wooden concrete metal "
    "ceramic porcelain paper cartoon animated painted sculpted carved".split()
)
#: Flat things that show pictures: "a dog on a poster" is a picture of a dog.
DISPLAY_NOUNS = frozenset(
    "poster billboard mural painting sign banner screen television tv advert advertisement graffiti "
    "drawing".split()
)
#: Where a displayed picture is put, after "on the", "in the", "at the" and before "of" ("a poster
#: of a woman on the side of a bus": the bus is real).
PLACEMENT_SURFACES = frozenset("side sides back front wall walls window windows door doors roof top".split())
PLACEMENT_PREPOSITIONS = frozenset({"on", "in", "at"})
#: Shorthand pilots and ground crews type in notes and radio logs ("3 ppl nr pad", "pax boarding
#: the heli", "1 pers at N edge"), written out: WordNet and the KB know none of these, so "ppl"
#: and "pers" were no mention at all (the pad, 0 m). Only forms with no other reading in a
#: caption; each stands for one word, so word positions stay those of the caption.
SHORTHAND = {
    "ppl": "people", "pers": "person", "pax": "passengers", "ped": "pedestrian", "peds": "pedestrians",
    "heli": "helicopter", "helis": "helicopters", "helo": "helicopter", "helos": "helicopters",
    "veh": "vehicle", "vehs": "vehicles", "acft": "aircraft", "uav": "drone", "uavs": "drones",
}
_TOKEN = re.compile(r"[a-z0-9]+(?:[-'][a-z0-9]+)*|[,;]")
_LIVING_OR_VEHICLE = frozenset({"person", "animal", "vehicle"})


def _implied_unit(entry: KbEntry | None, wordnet_class: str) -> tuple[int, str, Source, str | None]:
    """The one-word unit of a thing implied without a noun: its KB entry, else a WordNet class."""
    return (1, entry.category, "kb", entry.id) if entry is not None else (1, wordnet_class, "wordnet", None)


def tokenize(caption: str) -> list[str]:
    """Lower-case words, letters folded (:func:`.words.fold_text`: "café" → "cafe"); possessives
    folded ("people's" → "people"); an operator's shorthand written out (:data:`SHORTHAND`: "2 ppl
    nr pad" → "2 people nr pad"), one word for one."""
    words = (t.removesuffix("'s") for t in _TOKEN.findall(fold_text(caption).lower()))
    return [SHORTHAND.get(w, w) for w in words]


class MentionFinder:
    """Finds the mentions of a caption against one KB version and WordNet."""

    def __init__(self, kb: KnowledgeBase, wordnet: WordNet) -> None:
        self.kb = kb
        self.wordnet = wordnet
        self._surface: dict[tuple[str, ...], KbEntry] = {}
        self._lemmas: dict[tuple[str, ...], KbEntry] = {}
        for entry in kb.entries:
            for name in [entry.label, *entry.synonyms]:
                words = tuple(tokenize(name))
                if words:
                    self._surface.setdefault(words, entry)
                    self._lemmas.setdefault(self._lemma_key(words), entry)
        # the KB entries a pronoun and a crowd adjective stand for (None: a KB without them)
        self._person = self._surface.get(("person",))
        self._crowd = self._surface.get(("crowd",)) or self._person
        self._traffic = self._surface.get(("traffic",))  # the KB entry implied traffic stands for
        self._make_index = MakeIndex(kb, wordnet, tokenize)

    def _lemma_key(self, words: Sequence[str]) -> tuple[str, ...]:
        return (*words[:-1], self.wordnet.lemma(words[-1]))

    # ------------------------------------------------------------------ lexical units
    def _kb_match(self, words: Sequence[str], i: int) -> tuple[int, KbEntry] | None:
        for n in range(min(MAX_NAME_WORDS, len(words) - i), 0, -1):
            span = tuple(words[i : i + n])
            entry = self._surface.get(span) or self._lemmas.get(self._lemma_key(span)) or self._plural_of(span)
            if entry is not None:
                return n, entry
        return None

    def _names_head(self, words: Sequence[str], i: int) -> bool:
        """Whether a KB name of a person or a vehicle starts at ``i``."""
        kb = self._kb_match(words, i)
        return kb is not None and kb[1].category in ("person", "vehicle")

    def _plural_of(self, span: tuple[str, ...]) -> KbEntry | None:
        """A regular plural of a KB name WordNet does not know ("bikers": WordNet 3.0 has no
        "biker", so its lemmatiser leaves the word as it is)."""
        last = span[-1]
        if len(last) < 4 or not last.endswith("s") or self.wordnet.lemma(last) != last:
            return None
        for stem in (last[:-1], last[:-2] if last.endswith("es") else ""):
            entry = self._surface.get((*span[:-1], stem)) if stem else None
            if entry is not None:
                return entry
        return None

    def _is_wn_noun(self, words: Sequence[str], i: int) -> bool:
        word = words[i]
        if word in FUNCTION_WORDS or word in NEGATORS or not word.isalpha():
            return False
        if word in NO_ONE:
            return i > 0 and words[i - 1] in HEDGES  # "almost nobody": a few people are there
        if len(word) < 3:  # "an RV", "a DJ playing"; not "ai", "pa" or "ma"
            return self._short_noun(words, i)
        if word.endswith(("ing", "ed")) and (i == 0 or words[i - 1] not in DETERMINERS):
            return False  # "walking", "parked": verbs and participles, unless "a crossing"
        if self._verb_here(words, i):
            return False  # "the river passes", "a man surfs": verbs, unless "a pass"
        cls = self.wordnet.noun_class(self.wordnet.lemma(word))
        if self.wordnet.is_adjective(word):
            # "lush plants", "a black and white dog", "a young man": adjectives, not nouns; but
            # "an individual standing", "a stray wandering along": the head of its phrase names a
            # person or an animal (not a vehicle: "a local" is WordNet's local train)
            return cls in ("person", "animal") and self._heads_before_verb(words, i)
        return cls is not None

    def _heads_before_verb(self, words: Sequence[str], i: int) -> bool:
        """Whether the word after a determiner ends its noun phrase: an auxiliary, a preposition
        (:data:`PERSON_PREPOSITIONS`) or a present participle with a direction or an object follows
        ("an individual is standing", "an individual on a bike", "an individual crossing the road";
        not "an individual parking space"). A participle that also names a thing needs an object
        after it: "a red building", "the white building on the corner" are buildings, not people
        (WordNet's "white" and "black" are also people)."""
        if i == 0 or words[i - 1] not in DETERMINERS or i + 1 >= len(words):
            return False
        nxt, after = words[i + 1], words[i + 2] if i + 2 < len(words) else ""
        if nxt in AUXILIARIES or nxt in PERSON_PREPOSITIONS:
            return True
        if not (nxt.endswith("ing") and nxt.isalpha() and self.wordnet.is_verb(nxt)):
            return False
        if self.wordnet.noun_class(nxt) not in (None, "abstract"):  # "a red building", "a white building on the corner"
            return after in OBJECT_OPENERS  # ... unless an object follows: "an individual crossing the road"
        return after in DIRECTIONS | OBJECT_OPENERS or after in ("", ",", ";")

    def _phrase_start(self, words: Sequence[str], i: int) -> int:
        """Where the noun phrase of the noun at ``i`` starts: back over adjectives, commas and "and"
        between them, and its determiner."""
        j = i
        while j > 0 and (words[j - 1] in (",", "and") or (words[j - 1].isalpha() and words[j - 1] not in FUNCTION_WORDS
                                                             and self.wordnet.is_adjective(words[j - 1]))):
            j -= 1
        return j - 1 if j > 0 and words[j - 1] in DETERMINERS else j

    def _made_form(self, words: Sequence[str], i: int) -> bool:
        """A form noun that is a picture or a thing made: after a depiction modifier ("a wooden
        figure") or a noun that is no person, animal or vehicle ("a straw figure", "an action
        figure"), before a participle of making ("a silhouette painted on the wall")."""
        prev = words[i - 1] if i > 0 else ""
        nxt = words[i + 1] if i + 1 < len(words) else ""
        if prev in DEPICTION_MODIFIERS or nxt in MADE_PARTICIPLES:
            return True
        if not prev.isalpha() or prev in FUNCTION_WORDS or prev in DETERMINERS or self.wordnet.is_adjective(prev):
            return False
        cls = self.wordnet.noun_class(self.wordnet.lemma(prev))
        return cls is not None and cls not in _LIVING_OR_VEHICLE

    def _unmade_out(self, words: Sequence[str], i: int) -> bool:
        """A thing the captioner could not make out: a form (:data:`~.words.FORM_NOUNS`: "a dark
        figure in the distance", "a blurry shape") or a vague noun (:data:`~.words.VAGUE_NOUNS`)
        qualified by a word of doubt (:data:`~.words.UNCERTAIN`: "an unidentified object", "a
        strange, dark object"). Its mention is an unknown one: the careful spec. Not a picture or
        a thing made (:meth:`_made_form`; "the figure shows...", "figure 2 shows"), a manner ("a
        building in a strange shape"), nor a form or thing of something: "a silhouette of a
        dog" is the dog, "a figure of speech" nothing, so the words after "of" decide."""
        lemma = self.wordnet.lemma(words[i])
        if lemma not in FORM_NOUNS and lemma not in VAGUE_NOUNS:
            return False
        rest = words[i + 1 : i + 3]
        of_something = rest[:1] == ["of"] and words[i + 2 : i + 4] not in (["some", "kind"], ["some", "sort"])
        numbered = rest[:1] != [] and rest[0].isdigit() and bool(SHOWING_VERBS.intersection(words[i + 2 : i + 4]))
        if of_something or numbered or SHOWING_VERBS.intersection(rest):
            return False
        start = self._phrase_start(words, i)
        if start > 0 and words[start - 1] == "in":
            return False  # "in a strange shape": how a thing is, not a thing
        if lemma in FORM_NOUNS:
            return not self._made_form(words, i)
        return bool(UNCERTAIN.intersection(words[start:i]))

    def _short_noun(self, words: Sequence[str], i: int) -> bool:
        """A two-letter word after a determiner that names a vehicle (:data:`SHORT_NOUN_CLASSES`),
        or a person when an article precedes it and nothing follows that it could qualify: the
        caption ends, or a function word, punctuation or a participle comes next."""
        if i == 0 or words[i - 1] not in DETERMINERS:
            return False
        cls = self.wordnet.noun_class(self.wordnet.lemma(words[i]))
        if cls in SHORT_NOUN_CLASSES:
            return True
        if cls != "person" or words[i - 1] not in ARTICLES:
            return False
        nxt = words[i + 1] if i + 1 < len(words) else ""
        return nxt == "" or nxt in FUNCTION_WORDS or nxt in (",", ";") or nxt.endswith(("ing", "ed"))

    def _verb_here(self, words: Sequence[str], i: int) -> bool:
        """A word used mostly as a verb, right after a noun: "a player swings", "a man surfs"."""
        if i == 0 or not self.wordnet.mostly_verb(words[i]):
            return False
        prev = words[i - 1]
        if prev in PERSON_PRONOUNS:
            return True  # "she walks her dog"
        if prev in FUNCTION_WORDS or prev in DETERMINERS or not prev.isalpha():
            return False
        return self._kb_match(words, i - 1) is not None or (
            self.wordnet.is_noun(self.wordnet.lemma(prev)) and not self.wordnet.is_adjective(prev))

    def _unit(self, words: Sequence[str], i: int) -> tuple[int, str, Source, str | None] | None:
        """The lexical unit starting at ``i``: (length, class, source, kb id), or None."""
        if words[i] in IMAGE_NOUNS or self._camera_platform(words, i):
            return None
        if words[i] in PERSON_PRONOUNS:
            return self._implied_person(words[i])
        made = self._make_index.unit(words, i, self._names_head)
        if made is not None:  # "a ford mustang": the make's vehicle; "a ford truck": the truck
            n, entry = made
            return (n, entry.category, "kb", entry.id) if entry is not None else (n, "abstract", "wordnet", None)
        kb = self._kb_match(words, i)
        if kb is None and words[i] in QUANTIFIERS and i + 1 < len(words) and words[i + 1] == "of":
            return None
        compound = self._compound(words, i)
        if kb is not None and self._ends_in_a_verb(words, i, kb[0], kb[1].category):
            kb = self._kb_match(words[: i + kb[0] - 1], i)  # "a pedestrian crossing the street": a person
        if compound is not None and self._ends_in_a_verb(words, i, compound[0], compound[1]):
            compound = None
        if compound is None and self._unmade_out(words, i):  # before the KB's "object": what it is is unknown
            return 1, "unknown", "unknown", None
        if kb is not None and kb[0] == 1 and kb[1].category not in _LIVING_OR_VEHICLE and self._verb_here(words, i):
            kb = None  # "a player swings": a verb, though "swing" is a KB name
        if kb is not None and (compound is None or compound[0] <= kb[0] or kb[1].category not in _LIVING_OR_VEHICLE):
            n, entry = kb
            return n, entry.category, "kb", entry.id
        if compound is not None:
            return compound[0], compound[1], "wordnet", None
        if self._is_wn_noun(words, i):
            cls = self.wordnet.noun_class(self.wordnet.lemma(words[i])) or "abstract"
            if i + 1 < len(words) and words[i + 1] in PARKED:
                cls = "vehicle"  # only vehicles are parked: the WordNet sense was another one
            return 1, cls, "wordnet", None
        return self._hyphenated(words, i) if "-" in words[i] else None

    @staticmethod
    def _camera_platform(words: Sequence[str], i: int) -> bool:
        """Whether ``words[i]`` names the camera's own platform (:data:`CAMERA_PLATFORMS`): before
        what it makes ("a drone photo of", "drone footage"), or after "from"/"by" right after a
        camera verb or medium ("a view from a drone", "an image captured by a drone"; not "a man
        hit by a drone", nor "a photo of a man hit by a drone")."""
        if words[i] not in CAMERA_PLATFORMS:
            return False
        if i + 1 < len(words) and words[i + 1] in CAMERA_MEDIA:
            return i + 2 == len(words) or words[i + 2] in CAMERA_MEDIA_NEXT
        j = i - 1
        if j >= 0 and words[j] in DETERMINERS:
            j -= 1
        if j < 0 or words[j] not in ("from", "by"):
            return False
        return j > 0 and (words[j - 1] in CAMERA_VERBS or words[j - 1] in CAMERA_MEDIA)

    def _hyphenated(self, words: Sequence[str], i: int) -> tuple[int, str, Source, str | None] | None:
        """The unit of a hyphenated word the KB and WordNet lack as written: as they write it,
        spaced ("go-kart": the KB's go kart) or joined ("pick-up": a pickup); else, where it
        ends its noun phrase, by its last part, which names what it is (English compounds are
        right-headed: an "e-bike" is a bike, an "18-wheeler" a wheeler, which moves in every
        WordNet sense).
        Before a noun it only qualifies it ("a single-family home", "a two-lane road", "an
        e-bike rider", "a bird's-eye view"), and a number or a letter names nothing. Was: no
        mention at all ("an 18-wheeler on the highway" was the highway, 0 m)."""
        if self._qualifies_next(words, i):
            return None
        parts = words[i].split("-")
        spaced = self._unit([*words[:i], *parts, *words[i + 1 :]], i)
        if spaced is not None and spaced[0] == len(parts):
            return 1, *spaced[1:]
        whole = self.wordnet.noun_class(" ".join(parts))  # "cul-de-sac": WordNet's cul de sac, not a sac
        if whole is not None:
            return 1, whole, "wordnet", None
        for word in ("".join(parts), parts[-1]):
            if not word.isalpha() or len(word) < 3:
                continue
            unit = self._unit([*words[:i], word, *words[i + 1 :]], i)
            if unit is not None and unit[0] == 1:
                return unit
        return None

    def _qualifies_next(self, words: Sequence[str], i: int) -> bool:
        """Whether the word after ``i`` is a noun that ``words[i]`` qualifies (not a function word,
        a participle or a word used mostly as a verb)."""
        nxt = words[i + 1] if i + 1 < len(words) else ""
        if not nxt.isalpha() or nxt in FUNCTION_WORDS or nxt.endswith(("ing", "ed")) or self.wordnet.mostly_verb(nxt):
            return False
        return self._kb_match(words, i + 1) is not None or self.wordnet.is_noun(self.wordnet.lemma(nxt))

    def _ends_in_a_verb(self, words: Sequence[str], i: int, n: int, cls: str) -> bool:
        """Whether a name of ``n`` words at ``i`` (of class ``cls``) ends in a participle that is
        the verb of the words before it, not the name's last word: when an object or a way
        (:data:`WAYS`) follows ("a pedestrian crossing the street", "a zebra crossing the road";
        the crosswalks: "a zebra crossing on a quiet road"), or when the name is a thing, a word
        before the participle names a person and a preposition follows ("a pedestrian crossing
        at the intersection": the crosswalk or a person crossing there; read as the person, whom
        the other reading would give no buffer at all)."""
        if n < 2 or i + n >= len(words) or not words[i + n - 1].endswith("ing"):
            return False
        after = words[i + n]
        if after in WAYS | OBJECT_OPENERS:
            return True
        return (after in PERSON_PREPOSITIONS and cls not in _LIVING_OR_VEHICLE
                and any(self._care_of_word(w) == _CARE_ORDER["person"] for w in words[i : i + n - 1]))

    def _implied_person(self, word: str) -> tuple[int, str, Source, str | None]:
        """The unit of a person named by a pronoun (:data:`PERSON_PRONOUNS`) or a crowd adjective
        (:data:`CROWD_ADJECTIVES`): the KB's person or crowd entry, else WordNet's person class."""
        return _implied_unit(self._person if word in PERSON_PRONOUNS else self._crowd, "person")

    def _implied_animal(self) -> tuple[str, Source, str | None]:
        """An animal no noun names ("it is grazing"): the KB's animal entry, else WordNet's class."""
        _, cls, source, kb_id = _implied_unit(self._surface.get(("animal",)), "animal")
        return cls, source, kb_id

    def _compound(self, words: Sequence[str], i: int) -> tuple[int, str] | None:
        """A WordNet noun of two words ("bus stop", "car park") that names a physical thing; or
        one of three words, or one WordNet hyphenates and captions do not ("four wheel drive",
        "hot air balloon": the hot-air balloon), only when it names a person, animal or
        vehicle at least as careful as any of its words ("a two year old" stays a child, not
        WordNet's racehorse; "a used car lot" keeps its car). Longest first."""
        for n in (3, 2):
            span = words[i : i + n]
            if len(span) < n or any(w in FUNCTION_WORDS for w in span):
                continue
            *head, last = span
            last = self.wordnet.lemma(last)
            spaced = " ".join([*head, last])
            if n == 2:
                cls = self.wordnet.noun_class(spaced)
                if cls is not None and cls != "abstract":  # "horse race", "car crash": events keep their nouns
                    return n, cls
                if cls == "abstract" and self.wordnet.names_artifact(spaced) and not any(
                        self._names_head(span, k) or self._care_of_word(w) == _CARE_ORDER["animal"]
                        for k, w in enumerate(span) if self._kb_match([w], 0) is not None):
                    return n, "object"  # "a conveyor belt": a made thing, not a conveyer (a person) and a belt
            names = ["-".join([*head, last])]  # "go-kart"; three words: also "hot-air balloon"
            if n == 3:
                names += [spaced, "-".join(head) + " " + last]
            cls = next((c for c in map(self.wordnet.noun_class, names) if c is not None), None)
            if cls in _CARE_ORDER and _CARE_ORDER[cls] >= max(self._care_of_word(w) for w in span):
                return n, cls
        return None

    def _care_of_word(self, word: str) -> int:
        """:data:`_CARE_ORDER` of a word alone: its KB name's category, else its WordNet class; a
        word neither knows ranks as an animal, as careful as the unknown spec it would get ("a
        two seater" stays unknown, not WordNet's two-seater)."""
        if (self._kb_match([word], 0) is None and word.isalpha() and word not in FUNCTION_WORDS
                and not self.wordnet.is_known(word)):
            return _CARE_ORDER["animal"]
        return _CARE_ORDER.get(self._class_of_word(word) or "", 0)

    def _class_of_word(self, word: str) -> str | None:
        """A word alone's class: its KB name's category ("people": the KB's), else the WordNet class
        of its lemma; None where neither knows it."""
        kb = self._kb_match([word], 0)
        return kb[1].category if kb is not None else self.wordnet.noun_class(self.wordnet.lemma(word))

    def _closed_compound(self, word: str) -> str | None:
        """The class of a word WordNet lacks, written as two words it knows run together, by its
        last part ("zookeeper": a keeper, "groundskeeper", "birdwatchers"), only where that names
        a person: human, as the hard limit needs ("a zookeeper spreading food" was unknown), and
        only where every way of cutting the word says so. Otherwise None: the word stays unknown,
        5 m ("mudflat"; "bareland" is bare land as well as a bar and an eland; "snowcat" is a
        machine, though its last part is an animal: an animal's 4 m would be less careful)."""
        readings: list[str | None] = []
        for k in range(COMPOUND_PART_MIN, len(word) - COMPOUND_PART_MIN + 1):
            head, tail = word[:k], word[k:]
            if tail in DERIVING_SUFFIXES or not (self.wordnet.is_known(head)
                                                 and self.wordnet.is_known(self.wordnet.lemma(tail))):
                continue  # "birdwatch|ers": a suffix, not WordNet's "ers" (a vetch)
            cls = self.wordnet.noun_class(self.wordnet.lemma(tail))
            ok = cls == "person" and _CARE_ORDER[cls] >= self._care_of_word(head)
            readings.append(cls if ok else None)
        if not readings or None in readings:
            return None
        return max((r for r in readings if r is not None), key=_CARE_ORDER.__getitem__)

    def _misspelt_person(self, word: str) -> str | None:
        """``"person"`` for a word no one knows that is one typing slip (a letter dropped, added,
        changed, or two swapped: Damerau distance 1) from a noun, the one WordNet's tagged corpus
        uses most, when that names a person ("a wman walkng her dog", "peopel sitting on the
        grass", "two mne fishing": were unknown, not human). Only people, whom the care order puts
        above the unknown spec; a slip from an animal's name stays unknown ("a dgo": 5 m, more
        than a dog's 4 m), as does one from anything else ("a smal shed behnd the hous")."""
        if len(word) < TYPO_MIN_LETTERS or self._derived(word):
            return None
        nouns = self.wordnet.noun_lemmas()
        best, best_count = None, 0
        for candidate in sorted(_one_slip(word)):
            if candidate not in nouns and candidate.removesuffix("s") not in nouns \
                    and candidate.removesuffix("es") not in nouns:
                continue  # no noun, nor a regular plural of one ("peopel": "people" is one)
            lemma = self.wordnet.lemma(candidate)
            count = self.wordnet.noun_count(lemma)
            if count > best_count:
                best, best_count = lemma, count
        if best is None:
            return None
        return "person" if self._class_of_word(best) == "person" else None

    def _derived(self, word: str) -> bool:
        """Whether ``word`` is a known word with a suffix (:data:`DERIVING_SUFFIXES`): a word the
        captioner made, not a slip ("a two seater": a seat's, not a skater; "a kayaker")."""
        return any(word.endswith(suffix) and len(word) - len(suffix) >= TYPO_MIN_LETTERS
                   and self.wordnet.is_known(word[: -len(suffix)]) for suffix in DERIVING_SUFFIXES)

    def _is_unknown_head(self, words: Sequence[str], i: int) -> bool:
        word = words[i]
        if word in FUNCTION_WORDS or word in NEGATORS or not word.isalpha() or len(word) < 3:
            return False
        if word.endswith(("ing", "ed", "ly")) or self.wordnet.is_known(word):
            return False
        # a noun phrase starts there: the caption's start ("Quokka sitting in a parking lot"),
        # after a determiner ("a quokka") or a possessive ("riding her bicyle"), a conjunction
        # ("a road and quokkas") or the "of" of a quantity ("a pair of birdwatchers", "a group
        # of quokkas": what it counts); elsewhere an unknown word is more likely a modifier or a
        # misspelling of the head that follows ("a field of dandylions": a place's "of" is left
        # to that rule)
        prev = words[i - 1] if i > 0 else ""
        return i == 0 or prev in DETERMINERS or prev in POSSESSIVES or prev in NOUN_PHRASE_CONJUNCTIONS \
            or (i >= 2 and prev == "of" and self._counts(words[i - 2]))

    def _counts(self, word: str) -> bool:
        """Whether a noun before "of" counts what follows: a quantity (:data:`QUANTIFIERS`, "group")
        or a collective noun ("a crowd of", "a herd of")."""
        return word in QUANTIFIERS or word in GROUP_NOUNS or (word.isalpha() and self._mostly_group(word))

    # ------------------------------------------------------------------ mentions
    def find(self, caption: str) -> list[Found]:
        words = tokenize(caption)
        units: list[Found] = []
        i = 0
        while i < len(words):
            unit = self._unit(words, i)
            if unit is not None:
                n, cls, source, kb_id = unit
                units.append(Found(i, i + n, " ".join(words[i : i + n]), cls, source, kb_id))
                i += n
            elif self._is_unknown_head(words, i):
                being = self._closed_compound(words[i]) or self._misspelt_person(words[i])
                units.append(Found(i, i + 1, words[i], being, "wordnet") if being else
                             Found(i, i + 1, words[i], "unknown", "unknown"))
                i += 1
            else:
                i += 1
        mentions = self._with_implied(words, self._without_collectives(words, self._heads(units)))
        mentions = with_verb_subjects(words, mentions, self.wordnet, self._implied_animal)
        mentions = self._without_worn(words, self._without_parts(words, self._mark_depicted(words, mentions)))
        mentions = sorted(self._mark_depiction_modifiers(words, mentions), key=lambda m: (m.start, m.end))
        return self._mark_negated(words, mentions)

    def _without_parts(self, words: Sequence[str], mentions: list[Found]) -> list[Found]:
        """Drop a one-word mention that names a part of the thing named after its "of" ("a cat on
        the hood of a car": WordNet's car has a hood, so not its first sense, a hoodlum, 3 m; "the
        deck of a boat", "the head of a horse"). The whole stays, so the caption keeps its care."""
        kept: list[Found] = []
        for k, m in enumerate(mentions):
            whole = mentions[k + 1] if k + 1 < len(mentions) else None
            between = words[m.end : whole.start] if whole is not None else []
            if (whole is not None and m.end - m.start == 1 and between[:1] == ["of"] and len(between) <= 3
                    and all(w in DETERMINERS or w == "of" for w in between)
                    and self.wordnet.part_of(self.wordnet.lemma(m.text), self.wordnet.lemma(whole.text.split()[-1]))):
                continue
            kept.append(m)
        return kept

    def _without_worn(self, words: Sequence[str], mentions: list[Found]) -> list[Found]:
        """Drop what a person named just before wears ("a person in a gray shirt walking on the
        grass": the shirt was a thing of its own, grounded as the KB's nearest static entry, a
        playground). A :data:`WEARING_CUES` word right after the person, at most
        :data:`WEARING_REACH` words to the worn thing, nothing named between; never a person,
        animal or vehicle ("a man in a car", "a woman with a dog" stay). The person stays, so the
        caption keeps its care: what is dropped is static and the person's class is the more
        careful."""
        kept: list[Found] = []
        for m in mentions:
            wearer = kept[-1] if kept else None
            gap = words[wearer.end : m.start] if wearer is not None else []
            if (wearer is not None and wearer.word_class == "person" and m.word_class not in _LIVING_OR_VEHICLE
                    and gap[:1] and gap[0] in WEARING_CUES and len(gap) <= WEARING_REACH
                    and self._worn(m.text)):
                continue
            kept.append(m)
        return kept

    def _worn(self, text: str) -> bool:
        """Whether a mention's words, or its last word's lemma, name something worn."""
        return self.wordnet.wearable(text) or self.wordnet.wearable(self.wordnet.lemma(text.split()[-1]))

    def _heads(self, units: list[Found]) -> list[Found]:
        """Drop units that only qualify the next noun, keeping people, animals and vehicles."""
        kept: list[Found] = []
        for k, unit in enumerate(units):
            nxt = units[k + 1] if k + 1 < len(units) else None
            if nxt is not None and nxt.start == unit.end and nxt.word_class != "abstract" \
                    and nxt.text not in PERSON_PRONOUNS:  # "the mule he rides": the mule is there
                if nxt.word_class == "lookalike" and unit.word_class in _LIVING_OR_VEHICLE \
                        and not self.wordnet.is_verb(nxt.text):
                    kept.append(_with(unit, "depicted"))  # "a dog statue"
                    continue
                if nxt.word_class in _LIVING_OR_VEHICLE and unit.text in DEPICTION_MODIFIERS:
                    continue  # "inflatable dinosaur": the pair becomes one depiction below
                rides = unit.kb_id in RIDDEN_IDS and nxt.word_class == "person"  # "an e-bike rider": named
                if not rides and (unit.word_class not in _LIVING_OR_VEHICLE or (
                        unit.source == "wordnet" and nxt.word_class in (*_LIVING_OR_VEHICLE, "unknown"))):
                    continue  # "tennis court", "aerial view", "cricket player": the last noun is the head
            if unit.word_class == "unknown" and nxt is not None and nxt.start == unit.end:
                continue  # "arafed man": an unknown word before a noun qualifies it
            if (unit.word_class == "person" and nxt is not None and nxt.start == unit.end and unit.text in AGE_WORDS
                    and nxt.word_class == "animal"):
                continue  # "an adult dog", "a kid goat": the word says the animal's age (not "a man horse riding")
            if unit.word_class == "abstract":
                continue
            kept.append(unit)
        return kept

    def _without_collectives(self, words: Sequence[str], mentions: list[Found]) -> list[Found]:
        """Drop a collective noun that counts what follows its "of" ("a family of geese", "a mob of
        kangaroos", "a crew of workers"): the counted mention says what is there, while the
        collective's own classes (a family, a mob: people) would misname it. Only a WordNet noun,
        or a KB one counting animals ("a crowd of geese", "a team of horses"; "a crowd of
        children" stays the KB's crowd, a group of people), whose most frequent WordNet sense is a
        group ("members of ..." are people), only when a
        person or an animal follows within :data:`COLLECTIVE_GAP` words of plural determiners,
        numbers or adjectives, and heads its noun phrase ("a family of four having a picnic",
        "the crew of a fishing boat", "the crew of the cattle truck", "members of the pony club"
        keep their people)."""
        out: list[Found] = []
        for k, m in enumerate(mentions):
            nxt = mentions[k + 1] if k + 1 < len(mentions) else None
            if (nxt is not None and (nxt.word_class in _COUNTED if m.source == "wordnet"
                                     else m.source == "kb" and nxt.word_class == "animal")
                    and m.end < len(words) and words[m.end] == "of"
                    and 0 <= nxt.start - m.end - 1 <= COLLECTIVE_GAP
                    and self._counting_gap(words[m.end + 1 : nxt.start])
                    and self._heads_phrase(words, nxt)
                    and self._mostly_group(m.text.split()[-1])):
                continue
            out.append(m)
        return out

    def _counting_gap(self, gap: Sequence[str]) -> bool:
        """Words between "of" and the counted noun that only qualify it (:data:`COLLECTIVE_GAP`)."""
        for j, w in enumerate(gap):
            if w == "and":
                after = gap[j + 1] if j + 1 < len(gap) else ""
                if after in DETERMINERS or not after.isalpha() or not self.wordnet.is_adjective(after):
                    return False  # "of four and two dogs": two things counted
            elif w in SINGULAR_DETERMINERS or not self._modifier(w):
                return False
        return True

    def _heads_phrase(self, words: Sequence[str], m: Found) -> bool:
        """Whether ``m`` ends its noun phrase: after any participles ("a family of ducks
        swimming") the caption ends, or a function word or punctuation follows. Any other word
        may be the head ``m`` only qualifies ("the pony club", "a crew of horse groomers": the
        club, the groomers are what is counted), so the collective stays (careful)."""
        j = m.end
        while j < len(words) and words[j].endswith(("ing", "ed")) and words[j] not in FUNCTION_WORDS:
            j += 1
        return j == len(words) or words[j] in FUNCTION_WORDS or not words[j].isalpha()

    def _mostly_group(self, word: str) -> bool:
        senses = self.wordnet.senses(self.wordnet.lemma(word))
        return bool(senses) and senses[0].group

    def _with_implied(self, words: Sequence[str], mentions: list[Found]) -> list[Found]:
        """Add what an adjective implies though no noun names it: the crowd of a
        :data:`CROWD_ADJECTIVES` word ("a crowded beach", "the square is bustling";
        :meth:`_crowds_a_place`) and the traffic of a :data:`TRAFFIC_ADJECTIVES` word ("a busy
        highway", "the road is congested"; :meth:`_fills_a_road`). Neither when what fills the
        place follows it ("crowded with cars", "busy with shoppers": that mention says it) nor
        when a mention holds the adjective ("a populated area": one unit)."""
        at = {m.start: m for m in mentions}
        added: list[Found] = []
        for j, word in enumerate(words):
            if (j + 1 < len(words) and words[j + 1] in CROWDED_BY) or any(m.start <= j < m.end for m in mentions):
                continue
            if word in CROWD_ADJECTIVES and self._crowds_a_place(words, j, at):
                _, cls, source, kb_id = self._implied_person(word)
            elif word in TRAFFIC_ADJECTIVES and self._fills_a_road(words, j, at):
                _, cls, source, kb_id = _implied_unit(self._traffic, "vehicle")
            else:
                continue
            added.append(Found(j, j + 1, word, cls, source, kb_id))
        return sorted([*mentions, *added], key=lambda m: (m.start, m.end)) if added else mentions

    def _crowds_a_place(self, words: Sequence[str], j: int, at: dict[int, Found]) -> bool:
        """Not when the adjective qualifies things, not a place: a plural noun other than a place
        ("crowded buildings", "crowded houses": dense)."""
        nxt = at.get(j + 1)
        return nxt is None or nxt.word_class in _PLACE_CLASSES or not self._plural(nxt.text)

    @staticmethod
    def _fills_a_road(words: Sequence[str], j: int, at: dict[int, Found]) -> bool:
        """A :data:`TRAFFIC_ROADS` noun right after the adjective (read as a place), or before a
        copula before it."""
        if j + 1 < len(words) and words[j + 1] in TRAFFIC_ROADS:
            return j + 1 not in at or at[j + 1].word_class == "terrain"
        return j >= 2 and words[j - 1] in COPULAS and words[j - 2] in TRAFFIC_ROADS

    def _plural(self, text: str) -> bool:
        last = text.split()[-1]
        return self.wordnet.lemma(last) != last

    def _modifier(self, word: str) -> bool:
        return word in DETERMINERS or word.isdigit() or self.wordnet.is_adjective(word)

    def _mark_depiction_modifiers(self, words: Sequence[str], mentions: list[Found]) -> list[Found]:
        """"a toy car", "an inflatable dinosaur"; "a dog on a poster", "a man in a painting"."""
        out: list[Found] = []
        for m in mentions:
            before = words[m.start - 1] if m.start > 0 else ""
            on_display = m.end + 1 < len(words) and words[m.end] in ("on", "in") and any(
                w in DISPLAY_NOUNS for w in words[m.end + 1 : m.end + 3])
            if m.status == "present" and m.word_class in _LIVING_OR_VEHICLE and (
                    before in DEPICTION_MODIFIERS or on_display):
                out.append(_with(m, "depicted"))
                if before in DEPICTION_MODIFIERS:  # the toy, the inflatable itself is there
                    m = Found(m.start - 1, m.end, f"{before} {m.text}", "lookalike", m.source)
                else:
                    continue
            out.append(m)
        return out

    def _mark_depicted(self, words: Sequence[str], mentions: list[Found]) -> list[Found]:
        """Mark what a depiction's "of" (or a verb of showing, :data:`DEPICTING_VERBS`: "a billboard
        showing a woman") names as depicted, up to :data:`COMPLEMENT_BOUNDARY`; for a
        flat thing put up somewhere (:data:`DISPLAY_NOUNS`), also up to where it is put: "a poster
        of a woman | on the side of a bus" (:data:`PLACEMENT_SURFACES`; the bus was depicted: 1 m)."""
        out = list(mentions)
        for m in mentions:
            if m.word_class != "lookalike" or m.status != "present" or m.end >= len(words):
                continue
            displayed = m.text.split()[-1] in DISPLAY_NOUNS
            shows = words[m.end] in DEPICTING_VERBS and (displayed or m.text.split()[-1] in ART_NOUNS)
            if words[m.end] != "of" and not shows:
                continue  # "a thermal scan showing a person", "photos showing people": what the camera saw
            stop = next((j for j in range(m.end + 1, len(words)) if words[j] in COMPLEMENT_BOUNDARY
                         or (displayed and _placed_at(words, j))), len(words))
            out = [_with(x, "depicted") if m.end < x.start < stop and x.status == "present" else x for x in out]
        return out

    def _mark_negated(self, words: Sequence[str], mentions: list[Found]) -> list[Found]:
        out = list(mentions)
        for p, word in enumerate(words):
            if word not in NEGATORS or (p > 0 and words[p - 1] in HEDGES):
                continue
            k = next((k for k, m in enumerate(out) if m.start > p), None)
            between = words[p + 1 : out[k].start] if k is not None else []
            if k is None or out[k].start - p > NEGATION_REACH or NEGATION_STOP.intersection(between):
                continue  # too far, or "no one but a man": the negation is not about that mention
            for j in _negated_list(words, out, k):
                out[j] = _with(out[j], "negated")
        return out


def _negated_list(words: Sequence[str], mentions: Sequence[Found], k: int) -> range:
    """The mentions a negation of mention ``k`` reaches: ``k`` and those coordinated with it by
    "or"/"nor" ("no people or cars"), also across commas when "or"/"nor" closes the list ("no
    buildings, people or animals": was only the buildings, so the people were present). A comma
    list that no "or" closes ends the negation at its first comma ("no cars, a man walking"), and so
    does one that a participle follows: it says what the last items do ("a field with no trees, cows
    or horses grazing")."""
    last, j = k, k
    while j + 1 < len(mentions):
        link = words[mentions[j].end : mentions[j + 1].start]
        if link and link[-1] in COORDINATORS and link[:1] in ([","], [link[-1]]) and len(link) <= 2:
            last = j = j + 1  # "or", ", or", "nor": the list goes on and what is before it is in
        elif link and link[0] in COORDINATORS and len(link) == 2 and link[1] in DETERMINERS:
            last = j = j + 1  # "no cars or any people"
        elif link == [","]:
            j += 1  # in the list only if an "or" closes it further on
        else:
            break
    after = words[mentions[last].end] if mentions[last].end < len(words) else ""
    commas = any(w == "," for w in words[mentions[k].end : mentions[last].start])
    if commas and after.endswith(("ing", "ed")):
        return range(k, k + 1)  # "no trees, cows or horses grazing": the cows and horses are there
    return range(k, last + 1)


def _one_slip(word: str) -> set[str]:
    """Every string one typing slip from ``word`` (Damerau-Levenshtein distance 1 over a-z)."""
    splits = [(word[:k], word[k:]) for k in range(len(word) + 1)]
    out = {a + b[1:] for a, b in splits if b}
    out |= {a + b[1] + b[0] + b[2:] for a, b in splits if len(b) > 1}
    out |= {a + c + b[1:] for a, b in splits if b for c in ascii_lowercase}
    out |= {a + c + b for a, b in splits for c in ascii_lowercase}
    out.discard(word)
    return out


def _placed_at(words: Sequence[str], j: int) -> bool:
    """Whether ``words[j:]`` say where a displayed picture is put: "on the side of", "in the
    window of" (a preposition, a determiner, a :data:`PLACEMENT_SURFACES` noun, "of")."""
    return (words[j] in PLACEMENT_PREPOSITIONS and words[j + 1 : j + 2] != [] and words[j + 1] in DETERMINERS
            and words[j + 2 : j + 3] != [] and words[j + 2] in PLACEMENT_SURFACES and words[j + 3 : j + 4] == ["of"])


def _with(found: Found, status: Status) -> Found:
    return Found(found.start, found.end, found.text, found.word_class, found.source, found.kb_id, status)

