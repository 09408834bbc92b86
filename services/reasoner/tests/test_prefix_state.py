"""Evaluated prompt prefixes saved on disk give the same answers as evaluating them."""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

import pytest
from llmland_reasoner import prefix_state
from llmland_reasoner.llm import LlamaCppBackend
from llmland_reasoner.prefix_state import SUFFIX, PrefixStateStore

PREFIX = "<|im_start|>system\nAnswer which obstacle the caption names.<|im_end|>\n<|im_start|>user\n"
SUFFIX_TEXT = "a man walking a dog<|im_end|>\n<|im_start|>assistant\n"
CONTINUATIONS = ["man", "dog", "tree"]


def _evaluations(backend: LlamaCppBackend) -> list[int]:
    """Record the length of every token batch the backend evaluates."""
    seen: list[int] = []
    real = backend._llm.eval

    def counting(tokens: Any) -> None:
        seen.append(len(tokens))
        real(tokens)

    backend._llm.eval = counting  # type: ignore[method-assign]
    return seen


def _prefix_len(backend: LlamaCppBackend) -> int:
    return len(backend._tok(PREFIX))


def test_a_new_process_restores_the_prefix_and_answers_the_same(tmp_path: Path) -> None:
    reference = LlamaCppBackend(n_threads=1).score(PREFIX, SUFFIX_TEXT, CONTINUATIONS)
    first = LlamaCppBackend(n_threads=1, state_dir=tmp_path)
    assert first.score(PREFIX, SUFFIX_TEXT, CONTINUATIONS) == reference
    assert len(list(tmp_path.glob(f"*{SUFFIX}"))) == 1
    second = LlamaCppBackend(n_threads=1, state_dir=tmp_path)  # as a restarted worker would
    evaluated = _evaluations(second)
    assert second.score(PREFIX, SUFFIX_TEXT, CONTINUATIONS) == reference
    assert _prefix_len(second) not in evaluated  # only the suffix was evaluated
    assert second.score(PREFIX, "a red car<|im_end|>\n", CONTINUATIONS) == \
        LlamaCppBackend(n_threads=1).score(PREFIX, "a red car<|im_end|>\n", CONTINUATIONS)


def test_a_damaged_file_is_ignored_removed_and_rewritten(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    reference = LlamaCppBackend(n_threads=1, state_dir=tmp_path).score(PREFIX, SUFFIX_TEXT, CONTINUATIONS)
    (saved,) = tmp_path.glob(f"*{SUFFIX}")
    data = bytearray(saved.read_bytes())
    data[len(data) // 2] ^= 0xFF
    saved.write_bytes(bytes(data))
    backend = LlamaCppBackend(n_threads=1, state_dir=tmp_path)
    evaluated = _evaluations(backend)
    with caplog.at_level(logging.WARNING):
        assert backend.score(PREFIX, SUFFIX_TEXT, CONTINUATIONS) == reference
    assert "damaged" in caplog.text
    assert _prefix_len(backend) in evaluated
    assert saved.exists() and saved.read_bytes() != bytes(data)  # rewritten whole


def test_a_state_that_llama_cpp_refuses_is_evaluated_instead(tmp_path: Path) -> None:
    backend = LlamaCppBackend(n_threads=1, state_dir=tmp_path)
    tokens = backend._tok(PREFIX)
    assert backend._store is not None
    backend._store.save(tokens, b"not a llama.cpp state")  # intact file, wrong content
    reference = LlamaCppBackend(n_threads=1).score(PREFIX, SUFFIX_TEXT, CONTINUATIONS)
    assert backend.score(PREFIX, SUFFIX_TEXT, CONTINUATIONS) == reference


def test_the_key_holds_everything_the_state_depends_on(tmp_path: Path) -> None:
    model = tmp_path / "model.gguf"
    model.write_bytes(b"GGUF one")
    tokens = [1, 2, 3]
    base = PrefixStateStore(tmp_path, model, n_ctx=2048, n_batch=512).path(tokens)
    assert PrefixStateStore(tmp_path, model, n_ctx=2048, n_batch=512).path(tokens) == base
    assert PrefixStateStore(tmp_path, model, n_ctx=4096, n_batch=512).path(tokens) != base
    assert PrefixStateStore(tmp_path, model, n_ctx=2048, n_batch=256).path(tokens) != base
    assert PrefixStateStore(tmp_path, model, n_ctx=2048, n_batch=512).path([1, 2, 4]) != base
    model.write_bytes(b"GGUF two, a new model file")
    assert PrefixStateStore(tmp_path, model, n_ctx=2048, n_batch=512).path(tokens) != base


def test_another_runtime_build_gets_other_files(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    model = tmp_path / "model.gguf"
    model.write_bytes(b"GGUF")
    before = PrefixStateStore(tmp_path, model, 2048, 512).path([1])
    monkeypatch.setattr(prefix_state, "runtime_identity", lambda: "llama-cpp-python 9.9;native build")
    assert PrefixStateStore(tmp_path, model, 2048, 512).path([1]) != before


def test_an_unwritable_folder_only_costs_the_evaluation(tmp_path: Path) -> None:
    blocked = tmp_path / "file-not-folder"
    blocked.write_text("x")
    backend = LlamaCppBackend(n_threads=1, state_dir=blocked / "states")
    assert backend.score(PREFIX, SUFFIX_TEXT, CONTINUATIONS) == \
        LlamaCppBackend(n_threads=1).score(PREFIX, SUFFIX_TEXT, CONTINUATIONS)


def test_only_the_newest_files_are_kept(tmp_path: Path) -> None:
    model = tmp_path / "model.gguf"
    model.write_bytes(b"GGUF")
    store = PrefixStateStore(tmp_path / "states", model, 2048, 512)
    for i in range(prefix_state.MAX_FILES + 5):
        store.save([i], b"state %d" % i)
    kept = list((tmp_path / "states").glob(f"*{SUFFIX}"))
    assert len(kept) == prefix_state.MAX_FILES
    assert store.load([prefix_state.MAX_FILES + 4]) == b"state %d" % (prefix_state.MAX_FILES + 4)
    assert store.load([0]) is None
