"""Hybrid retrieval over the knowledge base with llama-index (DESIGN §5, step 2).

One ``TextNode`` per KB entry; a ``VectorStoreIndex`` (local sentence embeddings) and a
``BM25Retriever`` (keywords) fused by reciprocal rank with ``QueryFusionRetriever``
(``num_queries=1``: no LLM query rewriting), top 3. The index is built once and persisted
under ``index_dir/<kb version>-<content hash>``; a later start with the same KB reloads it.
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import logging
import os
import re
import shutil
import threading
import time
from collections.abc import Sequence
from pathlib import Path

from llama_index.core import Settings, StorageContext, VectorStoreIndex, load_index_from_storage
from llama_index.core.base.embeddings.base import BaseEmbedding
from llama_index.core.retrievers import QueryFusionRetriever
from llama_index.core.retrievers.fusion_retriever import FUSION_MODES
from llama_index.core.schema import QueryBundle, TextNode
from llama_index.retrievers.bm25 import BM25Retriever

from .kb import KbEntry, KnowledgeBase

log = logging.getLogger(__name__)
#: a builder's temporary index folder older than this (s) was left by a killed process
STALE_TMP_S = 3600.0

TOP_K = 3
_SUB_TOP_K = 6  # each retriever looks a little deeper so that the fusion can break ties


def configure_llama_index(embed_model: BaseEmbedding) -> None:
    """Point llama-index at our local embedding and at no LLM, so nothing reaches a hosted API."""
    with contextlib.redirect_stdout(io.StringIO()):  # llama-index print()s a notice about the MockLLM
        Settings.llm = None
    Settings.embed_model = embed_model


def _nodes(kb: KnowledgeBase) -> list[TextNode]:
    return [
        TextNode(
            id_=f"kb:{entry.id}",
            text=entry.chunk_text(),
            metadata={"kb_id": entry.id},
            excluded_embed_metadata_keys=["kb_id"],
            excluded_llm_metadata_keys=["kb_id"],
        )
        for entry in kb.entries
    ]


def index_key(kb: KnowledgeBase, embed_name: str) -> str:
    """Folder name for a persisted index: KB version plus a hash of its content and embedder."""
    digest = hashlib.sha256((kb.to_json() + embed_name).encode()).hexdigest()[:12]
    return f"{kb.version}-{digest}"


class Retriever:
    """Hybrid (dense + BM25) retriever returning ``(entry, fused score)`` pairs, best first."""

    def __init__(
        self,
        kb: KnowledgeBase,
        embed_model: BaseEmbedding,
        index_dir: str | Path | None = None,
        top_k: int = TOP_K,
    ) -> None:
        configure_llama_index(embed_model)
        self.kb = kb
        self.top_k = top_k
        self.embed_model = embed_model
        self.loaded_from_disk = False
        self._lock = threading.Lock()
        started = time.perf_counter()
        folder = Path(index_dir) / index_key(kb, embed_model.model_name) if index_dir else None
        if folder is not None and (folder / "done").exists():
            self._load(folder)
            self.loaded_from_disk = True
        else:
            self._build(folder)
        self._fusion = QueryFusionRetriever(
            [self._index.as_retriever(similarity_top_k=_SUB_TOP_K), self._bm25],
            similarity_top_k=top_k,
            num_queries=1,
            mode=FUSION_MODES.RECIPROCAL_RANK,
            use_async=False,
        )
        log.info(
            "retriever ready (kb %s, %s) in %.0f ms",
            kb.version,
            "reloaded" if self.loaded_from_disk else "built",
            1e3 * (time.perf_counter() - started),
        )

    def _build(self, folder: Path | None) -> None:
        nodes = _nodes(self.kb)
        self._index = VectorStoreIndex(nodes, embed_model=self.embed_model)
        self._bm25 = BM25Retriever.from_defaults(nodes=nodes, similarity_top_k=_SUB_TOP_K)
        if folder is None:
            return
        self._persist(folder)

    def _persist(self, folder: Path) -> None:
        """Write the index to ``folder`` atomically: into a folder of this process's own, renamed
        into place. Several reasoners may build the same index at once (``--jobs``, a fleet, a
        fresh machine): each writes its own copy, the first rename wins and the others discard
        theirs, so no reasoner ever reads a half-written or deleted index."""
        for stale in folder.parent.glob(f"{folder.name}.tmp-*"):  # of builders killed mid-write
            with contextlib.suppress(OSError):
                if time.time() - stale.stat().st_mtime > STALE_TMP_S:
                    shutil.rmtree(stale, ignore_errors=True)
        tmp = folder.with_name(f"{folder.name}.tmp-{os.getpid()}-{threading.get_ident()}")
        shutil.rmtree(tmp, ignore_errors=True)
        try:
            self._index.storage_context.persist(persist_dir=str(tmp / "vector"))
            self._bm25.persist(str(tmp / "bm25"))
            (tmp / "done").write_text(self.kb.version + "\n", encoding="utf-8")
            if folder.exists() and not (folder / "done").exists():
                shutil.rmtree(folder, ignore_errors=True)  # left incomplete by an older version
            try:
                tmp.rename(folder)
            except OSError:  # another process's rename came first: its index is this one
                log.info("index already persisted to %s by another process", folder)
                return
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
        log.info("index persisted to %s", folder)

    def _load(self, folder: Path) -> None:
        storage = StorageContext.from_defaults(persist_dir=str(folder / "vector"))
        index = load_index_from_storage(storage, embed_model=self.embed_model)
        assert isinstance(index, VectorStoreIndex)
        self._index = index
        self._bm25 = BM25Retriever.from_persist_dir(str(folder / "bm25"))
        self._bm25.similarity_top_k = _SUB_TOP_K
        log.info("index reloaded from %s", folder)

    def retrieve(self, caption: str, embedding: list[float] | None = None) -> list[tuple[KbEntry, float]]:
        """The ``top_k`` KB entries for a caption, best first, with their fused scores
        (``embedding``: the caption's vector when the caller already has it)."""
        query = re.sub(r"\s+", " ", caption).strip()
        if not query:
            return []
        with self._lock:
            hits = self._fusion.retrieve(QueryBundle(query_str=query, embedding=embedding))
        out: list[tuple[KbEntry, float]] = []
        for hit in hits[: self.top_k]:
            kb_id = str(hit.node.metadata.get("kb_id", ""))
            if kb_id:
                out.append((self.kb.get(kb_id), float(hit.score or 0.0)))
        return out

    def retrieve_many(self, captions: Sequence[str]) -> list[list[tuple[KbEntry, float]]]:
        """:meth:`retrieve` for several captions, their query vectors in one embedding call."""
        queries = [re.sub(r"\s+", " ", c).strip() for c in captions]
        todo = list(dict.fromkeys(q for q in queries if q))
        vectors = dict(zip(todo, self.embed_model.get_text_embedding_batch(todo), strict=True)) if todo else {}
        return [self.retrieve(q, vectors[q]) if q else [] for q in queries]
