"""One mention of a caption (:mod:`.mentions` finds them; :mod:`.subjects` reads their verbs)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

Status = Literal["present", "negated", "depicted"]
Source = Literal["kb", "wordnet", "unknown"]


@dataclass(frozen=True)
class Found:
    """One mention: a word span, what names it and whether it is there."""

    start: int
    end: int  # exclusive
    text: str
    word_class: str  # a KB category, a WordNet class, or "unknown"
    source: Source
    kb_id: str | None = None
    status: Status = "present"
