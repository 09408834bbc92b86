"""What a verb says its subject is (``subjects.py``): each kind, and the readings it must leave alone."""

from __future__ import annotations

import pytest
from llmland_reasoner.found import Found
from llmland_reasoner.mentions import MentionFinder


def classes(found: list[Found]) -> dict[str, str]:
    return {f.text: f.word_class for f in found if f.status == "present"}


@pytest.mark.parametrize(("caption", "word", "expected"), [
    # only animals graze, bark, neigh...: a person word with an animal sense is that animal
    ("a kid grazing next to its mother in the pen", "kid", "animal"),
    ("a boxer barking at a passing cyclist", "boxer", "animal"),
    ("the kid is grazing on the hillside", "kid", "animal"),
    # a thing that grazes is an animal, whatever its first sense
    ("a ram grazing on the slope", "ram", "animal"),
    # only vehicles drive down a road: a thing or an animal word that does is a vehicle
    ("a mobile crane driving along the highway", "crane", "vehicle"),
    ("a red mustang driving down the coastal highway", "mustang", "vehicle"),
    ("a jaguar driving through the city centre", "jaguar", "vehicle"),
    # a word no lexicon reads, before a vehicle verb, is the vehicle
    ("a yellow tuk-tuk speeding down a narrow street", "tuk-tuk", "vehicle"),
    ("a crane speeding along the rails", "crane", "vehicle"),
])
def test_the_verb_decides_its_subject(finder: MentionFinder, caption: str, word: str, expected: str) -> None:
    assert classes(finder.find(caption))[word] == expected


@pytest.mark.parametrize("caption", ["it is grazing alone in a fenced meadow",
                                     "grazing quietly at the edge of the wood"])
def test_an_animal_verb_with_no_noun_implies_an_animal(finder: MentionFinder, caption: str) -> None:
    assert "animal" in classes(finder.find(caption)).values()


@pytest.mark.parametrize(("caption", "word", "expected"), [
    ("a man grazing his knee on the pavement", "man", "person"),  # transitive: a person's own knee
    ("a boxer barking orders at the sparring partner", "boxer", "person"),  # an object: the person's sense
    ("a man driving down the road", "man", "person"),  # a driver is still a person (human first)
    ("a boy speeding down the hill", "boy", "person"),
    ("a cheetah speeding across the plain", "cheetah", "animal"),  # living things may speed
    ("a man driving a tractor", "man", "person"),  # transitive: the tractor is the vehicle
    ("a hrose grazing next to a barn", "hrose", "unknown"),  # unknown stays careful (5 m), not animal (4 m)
])
def test_readings_the_verbs_leave_alone(finder: MentionFinder, caption: str, word: str, expected: str) -> None:
    assert classes(finder.find(caption))[word] == expected


@pytest.mark.parametrize("caption", [
    "a grazing field next to a barn",  # the verb qualifies a noun
    "a speeding ticket on the windshield",
    "no animals grazing in the pasture",  # the subject is negated: nothing is there
    "a golf driving range",  # no direction after "driving"
])
def test_no_animal_or_vehicle_where_the_verb_names_none(finder: MentionFinder, caption: str) -> None:
    found = classes(finder.find(caption))
    assert not {"animal", "vehicle"} & set(found.values()), found


def test_a_negated_subject_stays_negated(finder: MentionFinder) -> None:
    statuses = {f.text: (f.word_class, f.status) for f in finder.find("no kid grazing in the field")}
    assert statuses["kid"][1] == "negated"
