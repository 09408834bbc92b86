"""Load the reasoner's models once: knowledge base, embedder + retriever, LLM backend.

A mode only loads what it uses (``llm`` needs no embedder, ``retrieval`` no LLM). The
resources can be shared by several :class:`~llmland_reasoner.extractor.SpecExtractor`
instances (the evaluation runs all three modes on one set of loaded models).
"""

from __future__ import annotations

import logging
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

from . import prompts
from .embedding import DEFAULT_EMBED_NAME, LocalSentenceEmbedding, force_offline, load_sentence_model
from .grounding import NameIndex
from .kb import KbEntry, KnowledgeBase, usable_additions
from .lexicon import WordNet
from .llm import LlamaCppBackend, LlmBackend
from .llm_worker import WorkerLlmBackend
from .mention_cache import MentionCache
from .mentions import MentionFinder
from .retrieval import Retriever
from .safety import NAME_MATCH_BONUS, WINDOW_WORDS
from .settings import ReasonerSettings

log = logging.getLogger(__name__)


def make_backend(settings: ReasonerSettings, *, wait: bool = True) -> LlmBackend:
    """The LLM backend named by ``settings.llm_backend``. ``wait=False`` returns a worker-process
    backend before its model has loaded (call its ``wait_ready()`` before use); an in-process
    backend is always loaded."""
    state_dir = settings.llm_state_dir if settings.llm_prefix_cache else None
    if settings.llm_backend == "llama_cpp" and settings.llm_isolation == "process":
        return WorkerLlmBackend(settings.llm_model_path, n_threads=settings.n_threads, n_ctx=settings.n_ctx,
                                call_timeout_s=2.0 * settings.timeout_s,
                                restart_backoff_s=settings.llm_restart_backoff_s, wait=wait,
                                warm_prefixes=warm_prefixes(settings), state_dir=state_dir)
    if settings.llm_backend == "llama_cpp":
        return LlamaCppBackend(settings.llm_model_path, n_threads=settings.n_threads, n_ctx=settings.n_ctx,
                               state_dir=state_dir)
    raise ValueError(f"unknown llm backend {settings.llm_backend!r}")


def warm_prefixes(settings: ReasonerSettings) -> list[str]:
    """The prompt prefix the configured mode asks the LLM with (none for ``retrieval``, or for
    ``rag`` without the LLM's pointer): a worker evaluates it while the other models load."""
    if settings.mode == "llm":
        return [prompts.paper_prefix()]
    if settings.mode == "rag" and settings.rag_pointer == "llm":
        return [prompts.rag_prefix(settings.rag_context_in_prompt)]
    return []


def _load_kb(settings: ReasonerSettings) -> KnowledgeBase:
    """The configured KB file, else the shipped KB with the entries written through the API on
    this machine (``settings.kb_additions``; said at WARNING: they change its answers). A damaged
    additions file is moved aside and logged (:func:`~.kb.usable_additions`): the shipped KB
    still loads."""
    kb = KnowledgeBase.load(settings.kb_path)
    if settings.kb_path is not None or not settings.kb_additions:
        return kb
    path = settings.kb_additions_path
    shipped = {e.id for e in kb.entries}
    added: list[KbEntry] = []
    for entry in usable_additions(path):
        if entry.id in shipped:  # the shipped KB has it now: the newer, reviewed entry wins
            log.warning("KB addition %r left out: the shipped KB %s has an entry with that id", entry.id, kb.version)
        else:
            added.append(kb.add(entry))
    if added:
        log.warning("KB %s: the shipped KB with %d entries written through the API (%s) from %s; "
                    "LLMLAND_REASONER_KB_ADDITIONS=false leaves them out", kb.version, len(added),
                    ", ".join(e.id for e in added), path)
    return kb


@dataclass(frozen=True)
class KbParts:
    """A KB version and what is built from it, swapped in together (:meth:`Resources.install`)."""

    kb: KnowledgeBase
    retriever: Retriever
    names: NameIndex
    finder: MentionFinder | None
    mention_cache: MentionCache


@dataclass
class Resources:
    """Loaded models; ``None`` for a part the chosen mode(s) do not need."""

    settings: ReasonerSettings
    kb: KnowledgeBase
    embed: LocalSentenceEmbedding | None = None
    retriever: Retriever | None = None
    names: NameIndex | None = None
    wordnet: WordNet | None = None
    finder: MentionFinder | None = None
    backend: LlmBackend | None = None
    #: grounded mentions (``mention_cache.py``); a new one for every KB version
    mention_cache: MentionCache | None = None
    load_s: dict[str, float] = field(default_factory=dict)
    #: held through a KB write (:meth:`prepare_entry` to :meth:`install`): one write at a time
    write_lock: threading.Lock = field(default_factory=threading.Lock, repr=False)

    @classmethod
    def load(cls, settings: ReasonerSettings, *, retrieval: bool = True, llm: bool = True) -> Resources:
        force_offline()
        started = time.perf_counter()
        res = cls(settings=settings, kb=_load_kb(settings))
        # A worker process loads its model on the other core while this one loads the embedder.
        t0 = time.perf_counter()
        res.backend = make_backend(settings, wait=False) if llm else None
        llm_s = time.perf_counter() - t0
        try:
            res._load_retrieval(settings, retrieval)
            if isinstance(res.backend, WorkerLlmBackend):
                t0 = time.perf_counter()
                res.backend.wait_ready()
                llm_s += time.perf_counter() - t0  # what was left to wait for
        except BaseException:
            res.close()
            raise
        if llm:
            res.load_s["llm"] = llm_s
        res.load_s["total"] = time.perf_counter() - started
        log.info("reasoner resources loaded: %s", {k: round(v, 2) for k, v in res.load_s.items()})
        return res

    def _load_retrieval(self, settings: ReasonerSettings, retrieval: bool) -> None:
        """The embedder, WordNet and the index (when ``retrieval``)."""
        if not retrieval:
            return
        t0 = time.perf_counter()
        name = Path(settings.embed_model_path).name if settings.embed_model_path else DEFAULT_EMBED_NAME
        model = load_sentence_model(settings.embed_model_path, n_threads=settings.embed_threads,
                                    backend=settings.embed_backend)
        self.embed = LocalSentenceEmbedding(model, model_name=name)
        self.load_s["embedder"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        self.wordnet = WordNet(settings.wordnet_dir)
        self.load_s["wordnet"] = time.perf_counter() - t0
        self.rebuild_retriever()

    def rebuild_retriever(self) -> None:
        """(Re)build or reload the index for the current KB version."""
        if self.embed is not None:
            with self.write_lock:
                self.install(self.build_for(self.kb))

    def build_for(self, kb: KnowledgeBase) -> KbParts:
        """Everything that depends on the KB, built for ``kb`` without touching what is in use
        (seconds: every entry embedded for the index and for the names); :meth:`install` then
        puts it in place at once."""
        assert self.embed is not None
        t0 = time.perf_counter()
        retriever = Retriever(kb, self.embed, index_dir=self.settings.index_dir, top_k=self.settings.top_k)
        names = NameIndex(self.embed.get_text_embedding_batch)
        names.warm(kb.entries)
        finder = MentionFinder(kb, self.wordnet) if self.wordnet is not None else None
        parts = KbParts(kb, retriever, names, finder, MentionCache(self.grounding_settings_key()))
        self.load_s["index"] = time.perf_counter() - t0
        return parts

    def install(self, parts: KbParts) -> None:
        """Put a KB and what :meth:`build_for` built for it in use (attribute swaps only)."""
        self.kb, self.retriever, self.names = parts.kb, parts.retriever, parts.names
        self.finder, self.mention_cache = parts.finder, parts.mention_cache

    def grounding_settings_key(self) -> str:
        """What a mention's grounding depends on besides the KB and the mention (see
        ``mention_cache.py``): the embedder, WordNet readings on or off, the grounding constants."""
        embed = self.embed.model_name if self.embed is not None else "-"
        return f"embed={embed};wordnet={self.wordnet is not None};window={WINDOW_WORDS};bonus={NAME_MATCH_BONUS}"

    def prepare_entry(self, entry: KbEntry | dict[str, object], save_to: str | Path | None = None,
                      *, replace: bool = True) -> tuple[KbEntry, KbParts | None]:
        """The KB with ``entry`` added (to a copy: the KB object in use is never changed) and what
        depends on it, built, and the new KB saved to ``save_to``; the caller installs the parts
        (:meth:`install`) holding :attr:`write_lock` from this call on, so two writes cannot both
        start from one version. Without retrieval nothing depends on the KB: the new one is put
        in use here and ``None`` returned for the parts.
        An invalid entry (``pydantic.ValidationError``, :class:`~.kb.KbEntryExistsError`,
        :class:`~.kb.KbNameTakenError`) raises before anything is built or saved."""
        kb = self.kb.copy()
        added = kb.add(entry, replace=replace)
        parts = self.build_for(kb) if self.embed is not None else None
        if save_to is not None:
            kb.save(save_to)
        if parts is None:
            self.kb = kb
        return added, parts

    def close(self) -> None:
        """Stop what runs outside this process (the LLM worker)."""
        close = getattr(self.backend, "close", None)
        if callable(close):
            close()

    @property
    def model_names(self) -> dict[str, str]:
        names = {"kb": self.kb.version}
        if self.embed is not None:
            names["embedder"] = self.embed.model_name
        if self.backend is not None:
            names["llm"] = self.backend.name
        return names
