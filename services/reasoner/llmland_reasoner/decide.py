"""Which reading a mention has in its caption: the decision the LLM makes in ``rag``.

The rules (``mentions.py``, ``safety.py``) give every mention the class of its KB name or
of its common WordNet senses. A word can also name a living being or a vehicle in a rarer
sense — "a white crane flying over the water", "a seal on the rocks", "a taxi cab" — which
no rule and no sentence embedding tells apart from "a crane lifting beams", "a window seal"
or "the cab of a truck": the caption's other words do. :class:`LlmDecider` asks the LLM.

How: each reading's plain word (``bird``, ``device``; ``lexicon.PLAIN_WORDS``) is put in the
word's place and the LLM scores the caption that results (its log-probability from that word
on, after the caption's own words before it; the prompt prefix, a few plain captions, is
reused): "a white *bird* flying over the water" against "a white *device* flying over the
water". Each reading's score is calibrated by the log-probability of its plain word alone
after "a" (contextual calibration, Zhao et al. 2021, "Calibrate before use", ICML): what
is left is how well the reading fits *this* caption, not how common the word is. A rarer
reading wins by :data:`MARGIN_NATS`; the rules' reading wins ties. Substitution was chosen
over asking "the crane is a kind of ..." on the dev split (``data/SENSES.md``).

The choice can only add care: ``safety.dominates`` keeps only readings more careful in every
respect than the rules' one, so a wrong LLM answer costs accuracy, never safety.
:class:`RetrievalDecider` is the ablation without the LLM: the reading whose KB entry's names
are most similar to the whole caption (MiniLM), as retrieval's top-1 would choose.
"""

from __future__ import annotations

import logging
import threading
from collections import OrderedDict
from collections.abc import Sequence
from typing import Literal, Protocol

import numpy as np

from . import deadline
from .grounding import NameIndex
from .kb import KnowledgeBase
from .lexicon import WordNet
from .llm import LlmBackend, plain
from .mentions import tokenize
from .safety import Alternative, Grounded

log = logging.getLogger(__name__)

#: How much more (nats, calibrated) a rarer reading must score than the rules' reading.
#: Chosen on the dev split of ``data/captions_senses.jsonl`` (54 captions, 8 with the rarer
#: reading): 0.5 finds all 8 and raises 8 of the 45 others; 1.0: 5 and 7 (``SENSES.md``).
MARGIN_NATS = 0.5
#: A plain-text prompt (no chat turn): the model only has to judge which caption reads right.
DECIDE_PREFIX = (
    "Photo captions, one a line.\n"
    "a man throwing a stick for his dog on the beach.\n"
    "an old tractor parked beside a barn."
)
#: How many of the caption's words after the mention are scored (the ones that tell the
#: readings apart come first: "crane *flying*", "cart *is extremely overburdened*").
RIGHT_WORDS = 6
#: The left context the plain words' own log-probabilities are calibrated with.
NEUTRAL = "a"
_CACHE_SIZE = 4096


class Decider(Protocol):
    """Chooses, for each grounded mention, one of its other readings or none (the rules' reading)."""

    name: str
    source: Literal["llm", "retrieval"]  # what a changed mention's result says chose it

    def decide(self, caption: str, grounded: Sequence[Grounded]) -> list[Alternative | None]: ...


def _plural(word: str) -> str:
    last = word.split()[-1]
    return word + ("es" if last.endswith(("s", "x", "ch", "sh")) else "s")


class LlmDecider:
    """The LLM chooses between a mention's readings by calibrated log-probability."""

    def __init__(self, backend: LlmBackend, wordnet: WordNet, margin_nats: float = MARGIN_NATS) -> None:
        self.backend = backend
        self.wordnet = wordnet
        self.margin_nats = margin_nats
        self.name = backend.name
        self.source: Literal["llm", "retrieval"] = "llm"
        self._prior_lp: OrderedDict[str, float] = OrderedDict()
        self._lock = threading.Lock()

    def _prior(self, word: str) -> float:
        with self._lock:
            cached = self._prior_lp.get(word)
        if cached is None:
            cached = self.backend.score(DECIDE_PREFIX, "\n" + NEUTRAL, [f" {word}"])[0]
            with self._lock:
                self._prior_lp[word] = cached
                while len(self._prior_lp) > _CACHE_SIZE:
                    self._prior_lp.popitem(last=False)
        return cached

    def margins(self, caption: str, g: Grounded) -> list[float]:
        """Per other reading: its calibrated score minus the rules' reading's (nats)."""
        words = tokenize(caption)
        left, rest = " ".join(words[: g.found.start]), " ".join(words[g.found.end : g.found.end + RIGHT_WORDS])
        plural = self.wordnet.lemma(g.found.text.split()[-1]) != g.found.text.split()[-1]
        options = [g.plain, *[a.plain for a in g.alternatives]]
        flat = tuple(dict.fromkeys(w for ws in options for w in ws))
        shown = {w: _plural(w) if plural else w for w in flat}
        sep = " " if left else ""
        # the caption is untrusted: its left part is marked plain text (:func:`~.llm.plain`);
        # continuations are always tokenised as plain text by ``score``
        conts = [f"{sep}{shown[w]} {rest}".rstrip() + "." for w in flat]
        joint = self.backend.score(DECIDE_PREFIX, "\n" + plain(left) if left else "\n", conts)
        by_word = {w: lp - self._prior(shown[w]) for w, lp in zip(flat, joint, strict=True)}
        best = [max(by_word[w] for w in ws) for ws in options]
        return [b - best[0] for b in best[1:]]

    def decide(self, caption: str, grounded: Sequence[Grounded]) -> list[Alternative | None]:
        out: list[Alternative | None] = []
        for g in grounded:
            if not g.alternatives:
                out.append(None)
                continue
            deadline.check()  # one LLM scoring per ambiguous mention: stop once the caller gave up
            margins = self.margins(caption, g)
            k = int(np.argmax(margins))
            chosen = g.alternatives[k] if margins[k] > self.margin_nats else None
            log.debug("reading of %r in %r: margins %s -> %s", g.found.text, caption,
                      [round(m, 2) for m in margins], chosen.word_class if chosen else "rules")
            out.append(chosen)
        return out


class RetrievalDecider:
    """The no-LLM ablation: the reading whose KB entry is most similar to the caption."""

    name = "retrieval"
    source: Literal["llm", "retrieval"] = "retrieval"

    def __init__(self, kb: KnowledgeBase, names: NameIndex) -> None:
        self.kb = kb
        self.names = names

    def decide(self, caption: str, grounded: Sequence[Grounded]) -> list[Alternative | None]:
        if not any(g.alternatives for g in grounded):
            return [None] * len(grounded)
        query = self.names.phrase(caption)
        out: list[Alternative | None] = []
        for g in grounded:
            if not g.alternatives or not g.numbers.kb_id:
                out.append(None)
                continue
            ids = [g.numbers.kb_id, *[a.numbers.kb_id for a in g.alternatives]]
            sims = [float(self.names.vector(self.kb.get(i)) @ query) for i in ids]
            k = int(np.argmax(sims))  # the rules' reading wins a tie (first)
            out.append(g.alternatives[k - 1] if k > 0 else None)
        return out
