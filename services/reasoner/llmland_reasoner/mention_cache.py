"""Grounded mentions, cached: mentions repeat across captions far more than captions repeat.

"a man walking on a grass field" and "a man walking on a grass field near a dog" are two
captions (two caption-cache misses) but share the mention "man walking on a": its grounding
(the KB entry among its class's, its pool, its other readings) is computed once. A cached
grounding is keyed by everything it depends on:

- the knowledge base: its version and a digest of its content (a KB write bumps the version;
  :meth:`MentionCache.clear` is also called on every write);
- the settings the grounding reads: the embedding model's name (similarities), whether WordNet
  readings are looked up, and the grounding constants (window length, name-match bonus);
- the mention itself: its window (the words that ground it), its text, class, source and KB id
  (what named it), and the three context flags taken from the rest of the caption: parked
  (a stationary cue belongs to it), ridden (a vehicle or bicycle is named next to a person) and
  astride (the caption puts the person on it: "a boy on a dirt bike").

What a mention is *in its caption* (present, negated, depicted) is decided before the cache
(only present mentions are grounded), and what the LLM decides about its readings is decided
after it, per caption. Grounding does not depend on the mode, so ``rag`` and ``retrieval``
may share a cache.
"""

from __future__ import annotations

import hashlib
import threading
from collections import OrderedDict
from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from .kb import KnowledgeBase
    from .mentions import Found
    from .safety import Alternative, Numbers

#: Cached groundings kept (least recently used dropped first); a few hundred bytes each.
DEFAULT_MENTION_CACHE_SIZE = 16384

MentionKey = tuple[str, str, str, str, str, str, str, bool, bool, bool]


@dataclass(frozen=True)
class CachedGrounding:
    """What grounding gave a mention, without where it stands in its caption."""

    numbers: Numbers
    score: float
    pool: tuple[str, ...]
    plain: tuple[str, ...]
    alternatives: tuple[Alternative, ...]


def kb_digest(kb: KnowledgeBase) -> str:
    """The KB's version and a hash of its content."""
    return f"{kb.version}:{hashlib.sha256(kb.to_json().encode()).hexdigest()[:16]}"


class MentionCache:
    """Thread-safe LRU of :class:`CachedGrounding` by :data:`MentionKey`."""

    def __init__(self, settings_key: str, max_size: int = DEFAULT_MENTION_CACHE_SIZE) -> None:
        self.settings_key = settings_key
        self.max_size = max_size
        self._items: OrderedDict[MentionKey, CachedGrounding] = OrderedDict()
        self._lock = threading.Lock()
        self._digests: dict[tuple[int, str], str] = {}
        self.hits = 0
        self.misses = 0

    def key(self, kb: KnowledgeBase, found: Found, window: str, parked: bool, ridden: bool,
            astride: bool = False) -> MentionKey:
        ident = (id(kb), kb.version)
        digest = self._digests.get(ident)
        if digest is None:
            digest = self._digests[ident] = kb_digest(kb)
        return (digest, self.settings_key, window, found.text, found.word_class, found.source,
                found.kb_id or "", parked, ridden, astride)

    def get(self, key: MentionKey) -> CachedGrounding | None:
        with self._lock:
            hit = self._items.get(key)
            if hit is None:
                self.misses += 1
                return None
            self.hits += 1
            self._items.move_to_end(key)
            return hit

    def has(self, key: MentionKey) -> bool:
        """Whether ``key`` is cached (not counted as a hit or a miss)."""
        with self._lock:
            return key in self._items

    def put(self, key: MentionKey, value: CachedGrounding) -> None:
        if self.max_size <= 0:
            return
        with self._lock:
            self._items[key] = value
            self._items.move_to_end(key)
            while len(self._items) > self.max_size:
                self._items.popitem(last=False)

    def clear(self) -> None:
        with self._lock:
            self._items.clear()
            self._digests.clear()

    def __len__(self) -> int:
        with self._lock:
            return len(self._items)
