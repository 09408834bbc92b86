"""Vehicle makes and the model names after them: "a Ford Mustang" is a car, not a horse.

A make names a maker of vehicles (``KbEntry.makes``: Ford, Jeep, John Deere, Cessna); the words
right after it name its model, whatever they mean alone: the Mustang and the Bronco are horses,
the Wrangler and the Explorer people, the Ram and the Impala animals in WordNet, so "a Jeep
Wrangler driving on a trail" was a hiker (3 m) and "a Ford Mustang speeding down the highway" a
horse (4 m). The make and its model are one mention of the make's vehicle entry.

What stops a model name: a function word, punctuation, a participle or a word used mostly as a
verb ("a ford mustang *speeding*"), a KB name of a person or a vehicle (that noun is the head:
"a ford truck" is only the truck), and the nouns for what belongs to a make rather than a model
of it (:data:`MAKE_ROLES`: "a harley rider" is a harley and its rider). A make with no model
after it ("a harley parked outside", "a man on a yamaha", "a zamboni") names its vehicle only
where WordNet names nothing but vehicles by the word as a common noun: "a jaguar" and "a ram"
stay animals, "a ford" a river crossing, as their other rules read them. After a make that names a living being, only a
code, an unknown word or a vehicle noun is a model: "a jaguar cub", "a cat toy" stay the animal;
after any make a person's noun is a person ("a toyota employee"), but for a few model names
(:data:`PERSON_MODELS`: "a jeep wrangler"), and a number before a unit a distance.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

from .kb import KbEntry, KnowledgeBase
from .lexicon import WordNet
from .words import DETERMINERS, FUNCTION_WORDS

#: How many words after a make may name its model ("a tesla model 3", "a toyota land cruiser").
MODEL_WORDS = 2
#: WordNet classes of a living being: after such a make, only codes and vehicle nouns are models.
LIVING = frozenset({"person", "animal"})
#: Model names that are also people's nouns in WordNet, by make: after it they are the model ("a
#: jeep wrangler", "a ford explorer", "a honda pilot", "a tesla model 3"); any other person noun
#: after a make is a person ("a toyota employee", "a cessna pilot": was a 5 m vehicle, not human,
#: so outside the planner's hard limit).
PERSON_MODELS: dict[str, frozenset[str]] = {
    "jeep": frozenset({"wrangler", "cherokee", "patriot", "commander"}), "ford": frozenset({"explorer", "ranger"}),
    "nissan": frozenset({"pathfinder"}), "land rover": frozenset({"defender"}), "honda": frozenset({"pilot"}),
    "tesla": frozenset({"model"}),
}
#: Units after a number: "a cat 2 meters from the pad" is a distance, not a model "cat 2".
UNIT_WORDS = frozenset(
    "m cm km meter meters metre metres kilometer kilometers ft foot feet yard yards yd mile miles inch inches "
    "s sec second seconds min minute minutes hour hours year years month months week weeks percent".split()
)
#: Nouns after a make that name what belongs to it, not a model of it: its people, its places,
#: its signs. The make is then its vehicle and the noun its own mention ("a harley rider": a
#: harley and the person on it).
MAKE_ROLES = frozenset(
    "driver drivers rider riders owner owners dealer dealers dealership dealerships mechanic mechanics "
    "enthusiast enthusiasts fan fans club salesman salesmen factory plant showroom store garage logo "
    "badge emblem sign ad advert advertisement billboard poster".split()
)


class MakeIndex:
    """The KB's makes, and the mention a make and its model make together."""

    def __init__(self, kb: KnowledgeBase, wordnet: WordNet, tokenize: Callable[[str], list[str]]) -> None:
        self.wordnet = wordnet
        self._makes: dict[tuple[str, ...], KbEntry] = {}
        for entry in kb.entries:
            for name in entry.makes:
                words = tuple(tokenize(name))
                if words:
                    self._makes.setdefault(words, entry)
        self._longest = max((len(k) for k in self._makes), default=0)

    def unit(self, words: Sequence[str], i: int, names_head: Callable[[Sequence[str], int], bool]
             ) -> tuple[int, KbEntry | None] | None:
        """The make at ``i`` with its model words: (length, the make's entry); (length, None) for a
        make that only qualifies the noun after it ("a cat excavator": not the animal); None where
        no make starts or one alone that WordNet reads otherwise ("a jaguar in the zoo").
        ``names_head(words, j)``: whether a KB person or vehicle name starts at ``j``."""
        for n in range(min(self._longest, len(words) - i), 0, -1):
            entry = self._makes.get(tuple(words[i : i + n]))
            if entry is None:
                continue
            make = " ".join(words[i : i + n])
            senses = self.wordnet.senses(make)  # its common-noun senses
            living = any(sense.word_class in LIVING for sense in senses)
            model = 0
            people_models = PERSON_MODELS.get(make, frozenset())
            while model < MODEL_WORDS and i + n + model < len(words) and \
                    self._model_word(words, i + n + model, names_head, living, people_models):
                model += 1
            nxt = words[i + n] if i + n < len(words) else ""
            if model:
                return n + model, entry
            if nxt and names_head(words, i + n):
                return n, None  # "a ford truck", "a cat excavator": the KB's noun after it is the head
            if nxt in MAKE_ROLES or self._person_noun(nxt):
                return n, entry  # "a harley rider", "a toyota employee": the make's vehicle and its person
            # alone, a make names its vehicle where WordNet names nothing else by the word ("a
            # zamboni", "a harley", "a jeep"; not "a ram", "a ford", "a tesla", "a jaguar")
            return (n, entry) if all(sense.word_class == "vehicle" for sense in senses) else None
        return None

    def _model_word(self, words: Sequence[str], j: int, names_head: Callable[[Sequence[str], int], bool],
                    living: bool, people_models: frozenset[str]) -> bool:
        """Whether ``words[j]`` may name a model. After a make that is also a living being's name
        ("jaguar", "cat", "ram"), only a code ("f-type", "1500"), a word WordNet lacks or a
        vehicle's noun ("a ram pickup"): "a jaguar cub", "a cat toy" are not cars."""
        word = words[j]
        if not word[0].isalnum() or word in FUNCTION_WORDS or word in DETERMINERS or word in MAKE_ROLES:
            return False
        if word.isalpha() and (word.endswith(("ing", "ed")) or self.wordnet.mostly_verb(word)):
            return False  # "a ford mustang speeding", "a jeep parked": the verb, not a model
        if not word.isalpha() and j + 1 < len(words) and words[j + 1] in UNIT_WORDS:
            return False  # "a cat 2 meters from the pad": a distance, not a model
        if word not in people_models and self._person_noun(word):
            return False  # "a toyota employee", "a cessna pilot": a person (the make is theirs)
        if living and word.isalpha() and self.wordnet.is_known(word) and \
                self.wordnet.noun_class(self.wordnet.lemma(word)) != "vehicle":
            return False
        return not names_head(words, j)

    def _person_noun(self, word: str) -> bool:
        """A noun whose WordNet class is a person's ("employee", "pilot", "crew", "gang"); not a
        participle or a word used mostly as a verb ("a cat sitting": WordNet's "sitting" is a
        person's, a sitter's)."""
        return (word.isalpha() and word not in FUNCTION_WORDS and not word.endswith(("ing", "ed"))
                and not self.wordnet.mostly_verb(word)
                and self.wordnet.noun_class(self.wordnet.lemma(word)) == "person")
