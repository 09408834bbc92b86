"""Grounded mentions cached across captions: keyed by everything they depend on."""

from __future__ import annotations

from dataclasses import replace

from llmland_reasoner.engine import ReasonerEngine
from llmland_reasoner.kb import KbEntry, KnowledgeBase
from llmland_reasoner.mention_cache import MentionCache
from llmland_reasoner.mentions import Found
from llmland_reasoner.resources import Resources
from llmland_reasoner.safety import ground_mentions

MAN = Found(1, 2, "man", "person", "kb", "pedestrian")


def test_key_holds_kb_content_settings_mention_and_context(robot_mower: dict[str, object]) -> None:
    kb = KnowledgeBase.load()
    cache = MentionCache("embed=a")
    base = cache.key(kb, MAN, "man walking on a", parked=False, ridden=False)
    assert base == cache.key(kb, MAN, "man walking on a", parked=False, ridden=False)
    assert base != MentionCache("embed=b").key(kb, MAN, "man walking on a", False, False)  # settings
    assert base != cache.key(kb, MAN, "man riding a bike", False, False)  # window
    assert base != cache.key(kb, MAN, "man walking on a", False, True)  # ridden
    assert cache.key(kb, MAN, "man on a moped", False, True) != cache.key(kb, MAN, "man on a moped", False, True,
                                                                          astride=True)
    assert base != cache.key(kb, replace(MAN, word_class="animal"), "man walking on a", False, False)
    version = kb.version
    kb.add(robot_mower)  # a KB write: new version and content
    assert kb.version != version
    assert base != cache.key(kb, MAN, "man walking on a", False, False)


def test_same_mention_in_two_captions_is_grounded_once_and_equally(resources: Resources) -> None:
    assert resources.finder is not None and resources.names is not None
    cache = MentionCache(resources.grounding_settings_key())
    first, second = "a man walking on a grass field", "a man walking on a road near a tree"

    def grounded(caption: str, c: MentionCache | None) -> list[tuple[str, object]]:
        found = resources.finder.find(caption)  # type: ignore[union-attr]
        out = ground_mentions(caption, found, resources.kb, resources.names, resources.wordnet, c)  # type: ignore[arg-type]
        return [(g.found.text, (g.numbers, g.pool, g.alternatives)) for g in out]

    assert grounded(first, cache) == grounded(first, None)
    misses = cache.misses
    again = grounded(second, cache)
    assert cache.hits >= 1 and cache.misses > misses - 1  # "man walking on a" hit; the rest missed
    assert again == grounded(second, None)
    cache.clear()
    assert len(cache) == 0


def test_kb_write_invalidates_cached_mentions(resources: Resources, robot_mower: dict[str, object]) -> None:
    """A KB write gives the resources a new mention cache and clears every extractor's caches."""
    own = Resources(settings=resources.settings, kb=KnowledgeBase.load(), embed=resources.embed,
                    wordnet=resources.wordnet)  # shares the loaded models, not the KB
    own.rebuild_retriever()
    engine = ReasonerEngine(resources.settings.model_copy(update={"mode": "retrieval"}), own)
    caption = "a robot mower driving over a lawn"
    engine.extract(caption)
    before = own.mention_cache
    assert before is not None and len(before) > 0
    engine.add_entry(KbEntry.model_validate(robot_mower))
    assert own.mention_cache is not before and own.mention_cache is not None  # the old one is dropped
    spec = engine.extract(caption)
    assert spec.label == "robot lawn mower" and spec.buffer_m == 5.0 and spec.source == "retrieval"
