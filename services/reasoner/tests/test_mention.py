from __future__ import annotations

import math

import pytest
from llmland_reasoner.grounding import NameIndex, ground, rank_prior
from llmland_reasoner.kb import KnowledgeBase
from llmland_reasoner.mention import WINDOW_WORDS, caption_words, choose_mention, content_positions


def test_content_positions_skip_function_words() -> None:
    words = caption_words("There is a statue of a woman in the park.")
    assert words == ["there", "is", "a", "statue", "of", "a", "woman", "in", "the", "park"]
    assert [words[i] for i in content_positions(words)] == ["statue", "woman", "park"]
    assert content_positions(["a", "the"]) == [0, 1]  # nothing else to point at


def test_choose_mention_takes_the_most_likely_word_and_its_window() -> None:
    words = caption_words("a red car parked on the street")
    positions = content_positions(words)  # red car parked street
    mention = choose_mention(words, positions, [-3.0, -0.5, -2.0, -4.0])
    assert mention.word == "car" and mention.window == "car parked on the"
    assert len(mention.window.split()) == WINDOW_WORDS
    assert mention.logprob < 0 and math.isfinite(mention.logprob)
    tie = choose_mention(words, positions, [-1.0, -1.0, -5.0, -5.0])
    assert tie.word == "red"  # earliest on a tie


@pytest.mark.parametrize("bad", [[], [-1.0], [float("nan"), 0.0, 0.0, 0.0]])
def test_choose_mention_rejects_bad_scores(bad: list[float]) -> None:
    words = caption_words("a red car parked on the street")
    with pytest.raises(ValueError):
        choose_mention(words, content_positions(words) if bad else [], bad)


def _toy_embed(texts: list[str]) -> list[list[float]]:
    """Bag of three words: enough to check the arithmetic of the grounding."""
    vocab = ("man", "grass", "statue")
    out = []
    for text in texts:
        vec = [float(word in text) for word in vocab]
        norm = math.sqrt(sum(v * v for v in vec)) or 1.0
        out.append([v / norm for v in vec])
    return out


def test_ground_follows_the_mention_over_the_retrieval_order() -> None:
    kb = KnowledgeBase.load()
    names = NameIndex(_toy_embed)
    candidates = [(kb.get("grass_field"), 0.03), (kb.get("person"), 0.02), (kb.get("statue"), 0.01)]
    grounded = ground("man walking on a", candidates, names)
    assert grounded.entry.id == "person"
    assert [e.id for e, _ in grounded.ranked][0] == "person" and len(grounded.ranked) == 3
    # with nothing in the mention to go on, the retrieval order decides
    assert ground("zzz", candidates, names).entry.id == "grass_field"
    assert list(rank_prior(3)) == [1.0, 0.5, 0.0] and list(rank_prior(1)) == [1.0]
    with pytest.raises(ValueError):
        ground("man", [], names)
