"""Prompts (and the JSON grammar of the baseline) for the two ways the LLM is used.

Every prompt is a fixed ``prefix`` (system text, few-shot turns and the opening of the
user turn; its KV cache is reused) plus a short variable ``suffix`` (the caption, the
closing markup and the start of the JSON answer): ~20 tokens for a BLIP caption. The chat
markup is SmolLM2's / Qwen's ChatML; other GGUFs follow it well enough for a few-shot task.

- ``llm`` mode (the LLM-MPC baseline): the paper's typed extractor prompt (appendix),
  caption only, JSON forced by :data:`SPEC_GRAMMAR`. The paper emits two fields; a third,
  ``buffer`` (whole metres), is asked for because the planner needs one and there is no KB
  to supply it.
- ``rag`` mode (LLM-Land): the same typed-extractor style, asking for the obstacle as the
  words of the caption that name it; the answer is read off the LLM's next-token
  distribution over the caption's words (see ``mention.py``), and the retrieved KB entry
  that the mention names supplies the numbers (``grounding.py``). The retrieved labels can
  also be put into the prompt as context (the paper's layout, ``with_context=True``); the
  135M model then copies context words instead of the obstacle, so it is off by default.

None of the few-shot captions appears in the evaluation sets.
"""

from __future__ import annotations

from collections.abc import Sequence

from .llm import plain

_IM = "<|im_start|>{role}\n{text}<|im_end|>\n"


def _turn(role: str, text: str) -> str:
    return _IM.format(role=role, text=text)


# ---------------------------------------------------------------- llm mode (paper prompt)
PAPER_SYSTEM = (
    "You are a drone safety metadata extractor. Do NOT read any free text.\n"
    "From the caption, pull exactly three fields:\n"
    "  - Classification: 'yes' if the obstacle can move by itself (dynamic), else 'no'\n"
    "  - Minimum Altitude: a float in meters (strip 'meters')\n"
    "  - Buffer: the horizontal safety distance, whole meters\n"
    "Return only JSON:\n"
    '{"is_dynamic": "{Classification}", "z_min": {Minimum_Altitude}, "buffer": {Buffer}}'
)
#: (caption, answer after the forced ``{"is_dynamic": "``)
PAPER_SHOTS: tuple[tuple[str, str], ...] = (
    ("a room with tree on the floor?", 'no", "z_min": 0.0, "buffer": 1}'),  # the paper's own example
    ("a brick building with a tree in front of it", 'no", "z_min": 12.0, "buffer": 1}'),
    ("a person pushing a pram along a footpath", 'yes", "z_min": 3.0, "buffer": 3}'),
    ("a pickup truck driving on a gravel road", 'yes", "z_min": 4.0, "buffer": 5}'),
)
_PAPER_ANSWER = '```json\n{"is_dynamic": "'

#: The rest of the answer. SmolLM2 spends a token per digit: with the opening quote in the
#: prompt and a whole-metre buffer the longest answer is 20 tokens (the paper's cap).
SPEC_GRAMMAR = r"""root ::= yn "\", \"z_min\": " num ", \"buffer\": " int "}"
yn ::= "yes" | "no"
num ::= [0-9] [0-9]? "." [0-9]
int ::= [0-9] [0-9]?
"""


def paper_prefix() -> str:
    shots = "".join(
        _turn("user", f"Q: {caption}") + _turn("assistant", _PAPER_ANSWER + answer) for caption, answer in PAPER_SHOTS
    )
    return _turn("system", PAPER_SYSTEM) + shots + "<|im_start|>user\nQ:"


def paper_suffix(caption: str) -> str:
    """The caption is untrusted: it is tokenised as plain text (:func:`~.llm.plain`)."""
    return f"{plain(' ' + caption)}<|im_end|>\n<|im_start|>assistant\n{_PAPER_ANSWER}"


# ------------------------------------------------------------- rag mode (obstacle extraction)
RAG_SYSTEM = (
    "You are a drone safety metadata extractor. Do NOT read any free text.\n"
    "From the caption, pull exactly one field:\n"
    "  - Obstacle: the words of the caption that name the person, animal, vehicle or object "
    "the caption is about; not the ground or place it is in. A statue, picture, toy or figure "
    "of something is the statue, picture, toy or figure.\n"
    'Return only JSON: {"obstacle": "{Obstacle}"}'
)
_RAG_CONTEXT_NOTE = "Context lists knowledge-base entries retrieved for the caption.\n"
RAG_SHOTS: tuple[tuple[str, tuple[str, ...], str], ...] = (
    ("a woman walking her bike across a parking lot", ("parking lot", "pedestrian", "cyclist"), "woman"),
    ("a bronze sculpture of a soldier in a square", ("police officer", "statue", "parking lot"), "bronze sculpture"),
    ("a dog lying on a wooden porch", ("house", "dog", "bench"), "dog"),
    ("a gravel road next to a pond", ("water", "dirt path", "road"), "gravel road"),
    ("a flock of geese on a lake", ("water", "flock of birds", "boat"), "flock of geese"),
    ("there is a old truck parked in the snow", ("snow", "truck", "parked car"), "old truck parked"),
    ("a drawing of a horse on a sign", ("horse", "road sign", "poster"), "drawing"),
    ("a child in a yellow raincoat standing in a puddle", ("water", "child", "person"), "child"),
    ("a courtyard with a fountain in the middle", ("parking lot", "statue", "water"), "fountain"),
    ("a sandy beach with two surfers on it", ("sand", "crowd", "boat"), "surfers"),
)
_RAG_ANSWER = '{"obstacle": "'


def _rag_user(caption: str, labels: Sequence[str] | None) -> str:
    context = f"Context: [{' | '.join(labels)}]\n" if labels is not None else ""
    return f"{context}Caption:{plain(' ' + caption)}"


def rag_prefix(with_context: bool = False) -> str:
    system = RAG_SYSTEM.replace("Return only", _RAG_CONTEXT_NOTE + "Return only") if with_context else RAG_SYSTEM
    shots = "".join(
        _turn("user", _rag_user(caption, labels if with_context else None))
        + _turn("assistant", _RAG_ANSWER + answer + '"}')
        for caption, labels, answer in RAG_SHOTS
    )
    return _turn("system", system) + shots + "<|im_start|>user\n" + ("" if with_context else "Caption:")


def rag_suffix(caption: str, labels: Sequence[str] | None = None) -> str:
    """The variable part; ``labels`` (the retrieved KB labels) only after a context prefix."""
    user = _rag_user(caption, labels) if labels is not None else plain(f" {caption}")
    return f"{user}<|im_end|>\n<|im_start|>assistant\n{_RAG_ANSWER}"
