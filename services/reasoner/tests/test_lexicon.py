"""WordNet 3.0 classes for nouns beyond the KB (the beyond-KB source, measured)."""

from __future__ import annotations

from pathlib import Path

import pytest
from llmland_reasoner.kb import KnowledgeBase
from llmland_reasoner.lexicon import WordNet, packaged_wordnet_dir
from llmland_reasoner.mentions import tokenize

#: Nouns none of which is a KB name, and the class a careful person gives them.
BEYOND_KB: dict[str, str] = {
    # living beings
    "giraffe": "animal", "zebra": "animal", "elephant": "animal", "alpaca": "animal", "camel": "animal",
    "kangaroo": "animal", "squirrel": "animal", "llama": "animal", "ostrich": "animal", "beetle": "animal",
    "skier": "person", "surfer": "person", "lifeguard": "person", "nurse": "person", "tourist": "person",
    "shepherd": "person", "bride": "person", "golfer": "person", "pilot": "person", "referee": "person",
    # operators of machines: WordNet files them under causal agents, not persons (were terrain)
    "driver": "person", "motorist": "person", "trucker": "person", "chauffeur": "person", "jockey": "person",
    # vehicles
    "pram": "vehicle", "jeep": "vehicle", "limousine": "vehicle", "hovercraft": "vehicle", "jet": "vehicle",
    "sled": "vehicle", "wheelbarrow": "vehicle", "rickshaw": "vehicle", "caravan": "vehicle", "snowmobile": "vehicle",
    # things and places
    "effigy": "lookalike", "photograph": "lookalike", "fountain": "structure", "windmill": "structure",
    "pavilion": "structure", "shovel": "object", "kite": "animal", "cactus": "vegetation", "valley": "terrain",
    "cliff": "terrain", "view": "abstract", "sunset": "abstract", "tiger": "animal",
}


@pytest.fixture(scope="module")
def wordnet(tmp_path_factory: pytest.TempPathFactory) -> WordNet:
    return WordNet(tmp_path_factory.mktemp("wordnet"))


def test_the_database_ships_in_a_package_and_is_normalised_once(tmp_path: Path) -> None:
    source = packaged_wordnet_dir()
    assert (source / "data.noun").is_file()
    first = WordNet(tmp_path)
    copies = list(tmp_path.glob("wordnet-3.0-*"))
    assert len(copies) == 1 and b"\r\n" not in (copies[0] / "index.noun").read_bytes()[:100_000]
    WordNet(tmp_path)  # reuses the normalised copy
    assert list(tmp_path.glob("wordnet-3.0-*")) == copies
    assert first.noun_class("giraffe") == "animal"


def test_the_lemma_index_is_parsed_once_and_read_back_the_same(tmp_path: Path) -> None:
    parsed = WordNet(tmp_path)
    (saved,) = tmp_path.glob("wordnet-3.0-*/lemma-index-*.marshal")
    again = WordNet(tmp_path)  # reads the saved index instead of the four index files
    assert again._wn._lemma_pos_offset_map == parsed._wn._lemma_pos_offset_map
    assert again.noun_class("giraffe") == "animal" and again.lemma("geese") == "goose"
    for damage in (b"\x00damaged", saved.read_bytes()[:-1000]):  # garbage; a truncated file
        saved.write_bytes(damage)
        rebuilt = WordNet(tmp_path)  # parsed again and rewritten
        assert rebuilt._wn._lemma_pos_offset_map == parsed._wn._lemma_pos_offset_map
        assert saved.stat().st_size > 1_000_000


def test_beyond_kb_nouns_are_not_kb_names() -> None:
    names = {tuple(tokenize(n)) for e in KnowledgeBase.load().entries for n in [e.label, *e.synonyms]}
    assert not names & {(w,) for w in BEYOND_KB}


def test_wordnet_classes_nouns_the_kb_lacks(wordnet: WordNet) -> None:
    got = {word: wordnet.noun_class(wordnet.lemma(word)) for word in BEYOND_KB}
    right = [w for w, cls in BEYOND_KB.items() if got[w] == cls]
    print(f"WordNet classes {len(right)}/{len(BEYOND_KB)} beyond-KB nouns right;",
          {w: got[w] for w in BEYOND_KB if got[w] != BEYOND_KB[w]})
    living = [w for w, c in BEYOND_KB.items() if c in ("person", "animal")]
    assert all(got[w] in ("person", "animal") for w in living)  # a living being is never a thing
    vehicles = [w for w, c in BEYOND_KB.items() if c == "vehicle"]
    assert sum(got[w] == "vehicle" for w in vehicles) >= len(vehicles) - 1  # "caravan": a procession first
    assert len(right) / len(BEYOND_KB) >= 0.9


@pytest.mark.parametrize(("word", "lemma"), [("geese", "goose"), ("men", "man"), ("fields", "field"),
                                             ("people", "people"), ("children", "child"), ("quokka", "quokka")])
def test_plurals_fold_to_their_lemma(wordnet: WordNet, word: str, lemma: str) -> None:
    assert wordnet.lemma(word) == lemma


@pytest.mark.parametrize(("word", "cls"), [("siamese", "animal"), ("jersey", "animal"), ("brownie", "person")])
def test_a_sense_named_only_capitalised_still_counts(wordnet: WordNet, word: str, cls: str) -> None:
    """Captions come lower case: "a siamese on the sofa", "two jerseys grazing", "a group of
    brownies hiking" may mean the cat, the cows, the girl scouts, so those senses keep their care
    (skipping them was tried: a bench, a bench, a dirt path)."""
    assert wordnet.noun_class(word) == cls


def test_unknown_and_part_of_speech(wordnet: WordNet) -> None:
    assert wordnet.noun_class("quokka") is None and not wordnet.is_known("arafed")
    assert wordnet.is_adjective("green") and wordnet.is_adjective("lush") and not wordnet.is_adjective("beetle")
    assert wordnet.mostly_verb("stands") and wordnet.mostly_verb("swings") and not wordnet.mostly_verb("dog")


def test_part_of_speech_tests_are_cached_per_word(wordnet: WordNet) -> None:
    """SemCor counts are a file search per call in NLTK: a word's second test must not repeat it."""
    for test in (wordnet.is_adjective, wordnet.mostly_verb, wordnet.is_known, wordnet.is_verb):
        first = test("surfs")
        hits = test.cache_info().hits  # type: ignore[attr-defined]
        assert test("surfs") == first
        assert test.cache_info().hits == hits + 1  # type: ignore[attr-defined]
