"""What a verb says its subject is (``subjects.py``): each kind, and the readings it must leave alone."""

from __future__ import annotations

import pytest
from llmland_reasoner.found import Found
from llmland_reasoner.mentions import MentionFinder


def classes(found: list[Found]) -> dict[str, str]:
    return {f.text: f.word_class for f in found if f.status == "present"}


@pytest.mark.parametrize(("caption", "word", "expected"), [
    # only animals graze, peck...: a thing with an animal sense that does is that animal
    ("a ram grazing on the slope", "ram", "animal"),  # the sheep, not the tool
    ("a crane pecking at fish in the shallows", "crane", "animal"),
    # only vehicles drive down a road: a thing that does is a vehicle
    ("a mobile crane driving along the highway", "crane", "vehicle"),
    # a word no lexicon reads, before a vehicle verb, is the vehicle
    ("a yellow tuk-tuk speeding down a narrow street", "tuk-tuk", "vehicle"),
])
def test_the_verb_decides_its_subject(finder: MentionFinder, caption: str, word: str, expected: str) -> None:
    assert classes(finder.find(caption))[word] == expected


@pytest.mark.parametrize("caption", ["it is grazing alone in a fenced meadow",
                                     "grazing quietly at the edge of the wood"])
def test_an_animal_verb_with_no_noun_implies_an_animal(finder: MentionFinder, caption: str) -> None:
    assert "animal" in classes(finder.find(caption)).values()


@pytest.mark.parametrize(("caption", "word", "expected"), [
    # people stay people: WordNet gives "man", "worker", "baby" an animal sense (genus Homo), and a
    # person is more careful than any animal by the caption order (a review found these)
    ("a man barking into a phone on a busy sidewalk", "man", "person"),
    ("a man barking at his dog in the park", "man", "person"),
    ("men pecking away at keyboards in an office", "men", "person"),
    ("a construction worker barking into a radio", "construction worker", "person"),
    ("an old man grazing the sheep on the hillside", "old man", "person"),
    ("a baby chirping in a crib", "baby", "person"),
    ("a man grazing his knee on the pavement", "man", "person"),
    ("a man driving down the road", "man", "person"),  # a driver is still a person
    ("a boy speeding down the hill", "boy", "person"),
    # vehicles stay vehicles (5 m), animals stay animals (living first)
    ("a truck grazing the guardrail on a highway", "truck", "vehicle"),
    ("a sports car purring at a red light", "sports car", "vehicle"),
    ("a horse driving down the road pulling a buggy", "horse", "animal"),
    ("a cheetah speeding across the plain", "cheetah", "animal"),
    ("a man driving a tractor", "man", "person"),  # transitive: the tractor is the vehicle
    ("a hrose grazing next to a barn", "hrose", "unknown"),  # unknown stays careful (5 m), not animal (4 m)
    # a thing is raised only to a sense WordNet gives it
    ("a ball grazing the net", "ball", "structure"),
    ("a wave speeding toward the shore", "wave", "terrain"),
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


@pytest.mark.parametrize(("caption", "verb"), [
    # a pronoun that may be anyone or anything, as the subject of a verb of action: an agent no
    # noun names (person, animal or vehicle: nobody can tell), the careful unknown mention
    ("they are setting up tents at the campsite near the river", "setting"),
    ("something is crossing the road", "crossing"),
    ("they are walking along the path", "walking"),
    ("it is moving toward the camera", "moving"),
    ("it is driving down the street", "driving"),
    ("those are parked near the gate", "parked"),
    ("these are docked at the pier", "docked"),
    ("they are sitting on the grass", "sitting"),
    ("something crossing the road at dusk", "crossing"),
    ("they're walking on the sidewalk", "walking"),  # the auxiliary inside the pronoun
    ("we are walking on the beach", "walking"),
    ("a photo of them walking on the street", "walking"),
    # a caption that opens with a participle and its object or direction: the same unnamed agent
    ("jogging along the river at dawn", "jogging"),
    ("crossing the road near a bus stop", "crossing"),
])
def test_a_pronoun_doing_something_is_an_unknown_agent(finder: MentionFinder, caption: str, verb: str) -> None:
    assert classes(finder.find(caption)).get(verb) == "unknown"


@pytest.mark.parametrize("caption", [
    "it is raining over the field",  # the impersonal "it": no agent
    "it is getting dark near the road",
    "it is going to rain on the field",
    "it is surprising that this yard is located along the railway",  # the "it" stands for the clause
    "they are amazing",  # emotion and thought are no action (WordNet's verb fields)
    "it is interesting to see",
    "they are sleeping bags",  # one noun WordNet knows
    "they are parking spaces near the mall",
    "parking lot next to a mall",  # a participle before a noun qualifies it
    "running water in a stream",
    "nothing is crossing the road",  # nothing is there
    "they are stacked near the wall",  # a state, not an action
    "a road crossing the field",  # a noun is the subject: its own class decides
    "a grazing field next to a road",
])
def test_no_unknown_agent_where_no_pronoun_acts(finder: MentionFinder, caption: str) -> None:
    assert "unknown" not in classes(finder.find(caption)).values()


def test_an_animal_verb_after_a_pronoun_still_implies_an_animal(finder: MentionFinder) -> None:
    found = classes(finder.find("they are grazing near the fence"))
    assert "animal" in found.values() and "unknown" not in found.values()


@pytest.mark.parametrize(("caption", "word"), [
    # a thing going somewhere under its own power is an agent no noun names: the careful unknown
    ("an object moving fast across the field", "object"),
    ("a red umbrella moving along the sidewalk", "umbrella"),
    ("a box that is moving along the road", "box"),  # through a relative clause
    ("a mannequin walking down the street", "mannequin"),
    ("a moving object near the landing pad", "object"),  # the participle before the thing
    ("a blurry shape moving across the field", "shape"),  # a noun no rule reads
    ("something large moving near the trees", "moving"),  # an adjective after "something"
    ("something moving in the bushes", "moving"),  # "moving in" is no compound noun
    ("an object crossing the road", "object"),  # a vague noun: any verb of motion
    ("an object rolling across the road", "object"),
    ("an object moving north across the field", "object"),  # where to, not what it qualifies (review)
    ("a red umbrella moving up and down the sidewalk", "umbrella"),  # travel, not a swing
    ("an object moving through the air above the trees", "object"),  # flying, not blown
])
def test_a_thing_going_somewhere_is_an_unknown_agent(finder: MentionFinder, caption: str, word: str) -> None:
    assert classes(finder.find(caption)).get(word) == "unknown"


@pytest.mark.parametrize("caption", [
    "a bridge crossing the river",  # what still things do in captions
    "a fence running along the road",
    "a path heading into the woods",
    "leaves moving in the wind",  # places and plants
    "a flag moving in the wind",  # the wind moves it
    "a tent moving in the strong wind",
    "a walking path through the park",  # the participle qualifies a place
    "no object moving on the road",  # nothing is there
    "a person in a red shirt walking on the grass",  # the person walks, not the shirt
    "a flag moving back and forth in the wind",  # a swing, and the wind six words on
    "a swing moving back and forth",
    "none of the objects are moving",  # said to be absent (review)
    "not a single thing moving on the street",
    "time moving slowly on a quiet street",  # an idea is no agent
    "the tide approaching the rocks",
    "a walking cane leaning on the bench",  # participles that name a use
    "a local walking trail",
    "a dog with a red collar walking on the path",
])
def test_no_unknown_agent_where_a_still_thing_is_described(finder: MentionFinder, caption: str) -> None:
    assert "unknown" not in classes(finder.find(caption)).values()


def test_a_thing_that_stops_being_there_stays_negated(finder: MentionFinder) -> None:
    found = {f.text: (f.word_class, f.status) for f in finder.find("no object moving on the road")}
    assert found["object"][1] == "negated"
