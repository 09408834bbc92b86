"""Prompts and GBNF grammars for the two LLM steps.

Every prompt is a fixed ``prefix`` (system text + few-shot turns, its KV cache is reused)
plus a short variable ``suffix`` (caption, and for RAG the retrieved labels). The chat
markup is SmolLM2's / Qwen's ChatML; other GGUFs follow it well enough for a few-shot task.

- ``llm`` mode (the LLM-MPC baseline): the paper's typed extractor prompt (appendix),
  caption only, JSON forced by :data:`SPEC_GRAMMAR`. The paper emits two fields; a third,
  ``buffer_m``, is asked for because the planner needs it and there is no KB to supply it.
- ``rag`` mode (LLM-Land): the same typed-extractor style, with the retrieved KB labels as
  context; the LLM extracts the obstacle (the words of the caption that name it), and
  :func:`span_grammar` restricts the answer to spans of the caption, so it cannot invent
  a word. The KB entry grounding that span supplies the numbers (see ``grounding.py``).

None of the few-shot captions appears in the evaluation sets.
"""

from __future__ import annotations

import re
from collections.abc import Sequence

_IM = "<|im_start|>{role}\n{text}<|im_end|>\n"


def _turn(role: str, text: str) -> str:
    return _IM.format(role=role, text=text)


# ---------------------------------------------------------------- llm mode (paper prompt)
PAPER_SYSTEM = (
    "You are a drone safety metadata extractor. Do NOT read any free text.\n"
    "From the caption, pull exactly three fields:\n"
    "  - Classification: 'yes' if the obstacle can move by itself (dynamic), else 'no'\n"
    "  - Minimum Altitude: a float in meters (strip 'meters')\n"
    "  - Buffer: the horizontal safety distance in meters\n"
    "Return only JSON:\n"
    '{"is_dynamic": "{Classification}", "z_min": {Minimum_Altitude}, "buffer_m": {Buffer}}'
)
PAPER_SHOTS: tuple[tuple[str, str], ...] = (
    ("a brick building with a tree in front of it", '"no", "z_min": 12.0, "buffer_m": 1.0}'),
    ("a person pushing a pram along a footpath", '"yes", "z_min": 3.0, "buffer_m": 3.0}'),
    ("a pickup truck driving on a gravel road", '"yes", "z_min": 4.0, "buffer_m": 5.0}'),
)
_PAPER_ANSWER = '```json\n{"is_dynamic": '

SPEC_GRAMMAR = r"""root ::= "\"" yn "\", \"z_min\": " num ", \"buffer_m\": " num "}"
yn ::= "yes" | "no"
num ::= [0-9] [0-9]? "." [0-9]
"""


def paper_prefix() -> str:
    shots = "".join(
        _turn("user", f"Q: {caption}") + _turn("assistant", _PAPER_ANSWER + answer) for caption, answer in PAPER_SHOTS
    )
    return _turn("system", PAPER_SYSTEM) + shots


def paper_suffix(caption: str) -> str:
    return _turn("user", f"Q: {caption}") + "<|im_start|>assistant\n" + _PAPER_ANSWER


# ------------------------------------------------------------- rag mode (obstacle extraction)
RAG_SYSTEM = (
    "You are a drone safety metadata extractor. Do NOT read any free text.\n"
    "From the caption, pull exactly one field:\n"
    "  - Obstacle: the words of the caption that name the person, animal, vehicle or object "
    "the caption is about; not the ground or place it is in. A statue, picture, toy or figure "
    "of something is the statue, picture, toy or figure.\n"
    "Context lists knowledge-base entries retrieved for the caption.\n"
    'Return only JSON: {"obstacle": "{Obstacle}"}'
)
RAG_SHOTS: tuple[tuple[str, tuple[str, ...], str], ...] = (
    ("a woman walking her bike across a parking lot", ("parking lot", "pedestrian", "cyclist"), "woman"),
    ("a bronze sculpture of a soldier in a square", ("police officer", "statue", "parking lot"), "bronze sculpture"),
    ("a dog lying on a wooden porch", ("house", "dog", "bench"), "dog"),
    ("a gravel road next to a pond", ("water", "dirt path", "road"), "gravel road"),
    ("a flock of geese on a lake", ("water", "flock of birds", "boat"), "flock of geese"),
    ("there is a old truck parked in the snow", ("snow", "truck", "parked car"), "old truck parked"),
    ("a drawing of a horse on a sign", ("horse", "road sign", "poster"), "drawing"),
    ("a child in a yellow raincoat standing in a puddle", ("water", "child", "person"), "child"),
)
_RAG_ANSWER = '{"obstacle": "'


def _rag_user(caption: str, labels: Sequence[str]) -> str:
    return f"Context: [{' | '.join(labels)}]\nCaption: {caption}"


def rag_prefix() -> str:
    shots = "".join(
        _turn("user", _rag_user(caption, labels)) + _turn("assistant", _RAG_ANSWER + answer + '"}')
        for caption, labels, answer in RAG_SHOTS
    )
    return _turn("system", RAG_SYSTEM) + shots


def rag_suffix(caption: str, labels: Sequence[str]) -> str:
    return _turn("user", _rag_user(caption, labels)) + "<|im_start|>assistant\n" + _RAG_ANSWER


# --------------------------------------------------------------------------- grammars
MAX_SPAN_WORDS = 4


def caption_words(caption: str) -> list[str]:
    return re.findall(r"[a-z0-9]+", caption.lower())


def caption_spans(caption: str, max_words: int = MAX_SPAN_WORDS) -> list[str]:
    """Every contiguous run of 1..max_words words of the caption, deduplicated, in order."""
    words = caption_words(caption)
    spans: dict[str, None] = {}
    for i in range(len(words)):
        for j in range(i + 1, min(len(words), i + max_words) + 1):
            spans[" ".join(words[i:j])] = None
    return list(spans)


def span_grammar(caption: str) -> str:
    """GBNF: the answer is one span of the caption followed by the closing quote."""
    spans = caption_spans(caption)
    if not spans:
        raise ValueError("caption has no words")
    alternatives = " | ".join(f'"{span}"' for span in spans)
    return f'root ::= ({alternatives}) "\\""\n'
