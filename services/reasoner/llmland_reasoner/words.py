"""Closed word classes of captions, shared by the mention finder (:mod:`.mentions`) and the
verb rules (:mod:`.subjects`), and how a caption's letters are folded to the ones they read."""

from __future__ import annotations

import unicodedata

#: Letters Unicode does not decompose into a base letter and marks, written as English writes
#: them; and typographic apostrophes, quotes and dashes as their ASCII forms.
_FOLDED = str.maketrans({
    "ß": "ss", "æ": "ae", "Æ": "AE", "œ": "oe", "Œ": "OE", "ø": "o", "Ø": "O", "ł": "l", "Ł": "L",
    "đ": "d", "Đ": "D", "ð": "d", "þ": "th", "ı": "i",
    "\u2019": "'", "\u2018": "'", "\u02bc": "'", "\u2032": "'", "\u201c": '"', "\u201d": '"',
    "\u2013": "-", "\u2014": " - ", "\u2212": "-",
})


def fold_text(text: str) -> str:
    """A caption's Latin letters without their accents and its typographic punctuation as ASCII
    ("a café terrace" → "a cafe terrace", "the plaza’s edge" → "the plaza's edge", "a Škoda" →
    "a Skoda"): the words are read a-z (they were cut at the accent: "caf", "fianc" + "e").
    Compatibility forms are decomposed too (NFKD: "ﬁeld" → "field", full-width letters); other
    scripts and emoji are left as they are (still no word the reasoner reads)."""
    decomposed = unicodedata.normalize("NFKD", text.translate(_FOLDED))
    return "".join(ch for ch in decomposed if not unicodedata.combining(ch))

#: Words that open a noun phrase (articles, demonstratives, quantities).
DETERMINERS = frozenset(
    "a an the this that these those some many several few two three four five six seven eight nine ten "
    "dozens lots lot numerous various one another each every other".split()
)
#: Never a mention (articles, pronouns, prepositions, auxiliaries, common adverbs).
FUNCTION_WORDS = frozenset(
    "a an the of on in at to by with and or nor is are was were be been being there here that this these those "
    "its it his her their them they he she we you i my our your some near next over under behind along across "
    "through into onto from for while as up down out off around above below beside between beneath inside "
    "outside toward towards against upon among amongst via per than then also very too no not without "
    "has have had do does did can could will would may might must shall should who whom whose which what "
    "where when why how all both each every any few many much more most other such only own same so just "
    "away back together front top side middle left right far close".split()
)
#: A noun right before one of these is a vehicle, whatever else WordNet says it is ("a beetle parked").
PARKED = frozenset({"parked", "docked", "moored"})
#: Auxiliaries between a subject and its verb ("the kid is grazing").
AUXILIARIES = frozenset("is are was were".split())
#: Verbs between a noun and the adjective that describes it ("the road is congested", "looks busy").
COPULAS = AUXILIARIES | frozenset({"looks", "seems"})
#: Words for a form seen without its kind ("a dark figure in the distance", "a silhouette by the
#: fence", "a blurry shape moving"): a captioner's word for someone or something it could not make out.
FORM_NOUNS = frozenset({"figure", "silhouette", "shape", "blob"})
#: Verbs after which a form noun is the picture itself ("the figure shows a field", "figure 2 shows").
SHOWING_VERBS = frozenset("shows show depicts illustrates presents displays".split())
#: Participles that make a form a picture ("a silhouette painted on the wall", "a figure drawn in chalk").
MADE_PARTICIPLES = frozenset("painted drawn carved printed sprayed etched sculpted engraved stenciled".split())
#: Nouns that name a thing without saying what it is ("an object", "an item").
VAGUE_NOUNS = frozenset("object thing item form".split())
#: Adjectives by which a captioner says it cannot tell what a thing is ("an unidentified object").
UNCERTAIN = frozenset(
    "unknown unidentified unidentifiable unrecognizable unrecognisable indistinct strange mysterious blurry "
    "blurred fuzzy dark shadowy unclear".split()
)
