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


class NameIndex:
    """Cached embeddings of every entry's names, keyed by the entry's content."""

    def __init__(self, embed: EmbedFn) -> None:
        self._embed = embed
        self._vectors: dict[str, np.ndarray] = {}

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
        return np.asarray(self._embed([text])[0], dtype=np.float64)

    def phrases(self, texts: list[str]) -> list[np.ndarray]:
        """Several phrases in one embedding call."""
        return [np.asarray(v, dtype=np.float64) for v in self._embed(texts)]


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
