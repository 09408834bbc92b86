"""Ground the LLM's answer in the knowledge base (the last step of ``rag`` mode).

The LLM points at the obstacle's mention in the caption (``mention.py``: e.g. "man walking
on a", "statue of a woman", "car parked on the"). Each retrieved candidate is scored by the
cosine similarity between that mention and the candidate's names (label + synonyms), plus
a small prior for its retrieval rank; the best candidate's KB fields become the spec. The
LLM thus decides *which* thing in the caption is the obstacle (the man, not the grass field
he walks on; the statue, not the woman it depicts), and the KB supplies the numbers.

``RANK_WEIGHT`` was chosen on ``data/captions_dev.jsonl`` (a plateau for 0.05-0.1), never on
the evaluation set.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from .kb import KbEntry

RANK_WEIGHT = 0.1

EmbedFn = Callable[[list[str]], list[list[float]]]


def names_text(entry: KbEntry) -> str:
    """What the obstacle phrase is compared with: the label and its synonyms."""
    return ", ".join([entry.label, *entry.synonyms])


@dataclass(frozen=True)
class Grounded:
    """The chosen entry and the combined score of every candidate (best first)."""

    entry: KbEntry
    ranked: list[tuple[KbEntry, float]]


#: Phrase vectors kept (captions and mention windows; 384 floats each, ~3 KB).
PHRASE_CACHE_SIZE = 8192


class NameIndex:
    """Cached embeddings of every entry's names, keyed by the entry's content, and of the
    phrases asked about (captions, mention windows), keyed by their text."""

    def __init__(self, embed: EmbedFn, phrase_cache_size: int = PHRASE_CACHE_SIZE) -> None:
        self._embed = embed
        self._vectors: dict[str, np.ndarray] = {}
        self._phrases: OrderedDict[str, np.ndarray] = OrderedDict()
        self._phrase_cache_size = phrase_cache_size
        self._lock = threading.Lock()

    def warm(self, entries: Sequence[KbEntry]) -> None:
        missing = [e for e in entries if names_text(e) not in self._vectors]
        if missing:
            texts = [names_text(e) for e in missing]
            for text, vector in zip(texts, self._embed(texts), strict=True):
                self._vectors[text] = np.asarray(vector, dtype=np.float64)

    def vector(self, entry: KbEntry) -> np.ndarray:
        self.warm([entry])
        return self._vectors[names_text(entry)]

    def phrase(self, text: str) -> np.ndarray:
        return self.phrases([text])[0]

    def phrases(self, texts: list[str]) -> list[np.ndarray]:
        """Several phrases; those not seen before in one embedding call."""
        with self._lock:
            known = {t: self._phrases[t] for t in texts if t in self._phrases}
        missing = list(dict.fromkeys(t for t in texts if t not in known))
        if missing:
            fresh = [np.asarray(v, dtype=np.float64) for v in self._embed(missing)]
            known.update(zip(missing, fresh, strict=True))
            with self._lock:
                for text, vector in zip(missing, fresh, strict=True):
                    self._phrases[text] = vector
                while len(self._phrases) > self._phrase_cache_size:
                    self._phrases.popitem(last=False)
        return [known[t] for t in texts]


def rank_prior(n: int) -> np.ndarray:
    """1 for the first retrieved candidate down to 0 for the last."""
    return np.linspace(1.0, 0.0, n) if n > 1 else np.ones(n)


def ground(
    phrase: str,
    candidates: Sequence[tuple[KbEntry, float]],
    names: NameIndex,
    rank_weight: float = RANK_WEIGHT,
) -> Grounded:
    """Pick the retrieved candidate that the LLM's obstacle phrase names.

    Only the caption's top-k are candidates (the paper's retrieval): adding entries
    retrieved for the phrase itself was tried and lost accuracy (dev 96% -> 94%), because a
    wrong pointer then has nothing to hold it back.
    """
    if not candidates:
        raise ValueError("no candidates to ground the answer in")
    entries = [entry for entry, _ in candidates]
    query = names.phrase(phrase)
    similarity = np.array([float(names.vector(entry) @ query) for entry in entries])
    combined = similarity + rank_weight * rank_prior(len(entries))
    order = np.argsort(-combined, kind="stable")
    ranked = [(entries[i], float(combined[i])) for i in order]
    return Grounded(entry=ranked[0][0], ranked=ranked)
