"""One extractor per mode over shared loaded models (the HTTP API may ask for any mode)."""

from __future__ import annotations

import threading
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from llmland_schemas import SafetySpec

from .extractor import SpecExtractor, add_entry_paused
from .kb import KbEntry, KbEntryExistsError, add_to_additions, usable_additions
from .resources import Resources
from .settings import Mode, ReasonerSettings


class ReasonerEngine:
    """Caption → SafetySpec in the configured mode (or another one on request)."""

    def __init__(self, settings: ReasonerSettings, resources: Resources | None = None) -> None:
        self.settings = settings
        self.resources = resources or Resources.load(settings)
        self._lock = threading.Lock()
        self._extractors: dict[str, SpecExtractor] = {}

    def extractor(self, mode: Mode | None = None) -> SpecExtractor:
        m: Mode = mode or self.settings.mode
        with self._lock:
            ex = self._extractors.get(m)
            if ex is None:
                ex = self._extractors[m] = SpecExtractor(m, self.settings, self.resources)
            return ex

    def extract(self, caption: str, mode: Mode | None = None) -> SafetySpec:
        return self.extractor(mode).extract(caption)

    def extract_many(self, captions: Sequence[str], mode: Mode | None = None) -> list[SafetySpec]:
        """Several captions in one batch (the fleet's scenes); each spec as :meth:`extract` gives."""
        return [x.spec for x in self.extractor(mode).extract_many(captions)]

    def cached_specs(self, captions: Sequence[str], mode: Mode | None = None) -> list[SafetySpec] | None:
        """Every caption's spec if all are cached (answered without model work), else None."""
        hits = self.extractor(mode).cached(captions)
        return None if hits is None else [x.spec for x in hits]

    def add_entry(self, entry: KbEntry, *, replace: bool = True) -> KbEntry:
        """Validated KB write, persisted: the whole KB to the configured KB file, else the entry to
        the additions file (``settings.kb_additions_path``); caches cleared (``replace=False``:
        :class:`~.kb.KbEntryExistsError` for an existing id)."""
        if self.settings.kb_path is not None:
            added = self._add(entry, self.settings.kb_path, replace)
        else:
            path = self.settings.kb_additions_path
            with self._lock:  # before the KB changes: a write that cannot be kept changes nothing
                recorded = usable_additions(path)
            if not replace and any(e.id == entry.id for e in recorded):
                raise KbEntryExistsError(f"KB entry {entry.id!r} exists in {path}")  # not loaded here
            added = self._add(entry, None, replace)
            with self._lock:
                add_to_additions(path, added)
        with self._lock:
            for ex in self._extractors.values():
                ex.clear_cache()
        return added

    def _add(self, entry: KbEntry, save_to: str | Path | None, replace: bool) -> KbEntry:
        """The write, put in use with every mode's extractor paused (none straddles the swap; a
        new one waits for it: ``_lock`` is held)."""
        self.extractor()  # the configured mode's, so that there is one to pause
        with self._lock:
            return add_entry_paused(self.resources, list(self._extractors.values()), entry, save_to, replace=replace)

    def models(self) -> dict[str, str]:
        return dict(self.resources.model_names)

    def health(self) -> tuple[str, dict[str, Any] | None]:
        """``("ok" | "degraded", llm worker health or None)``: degraded while the LLM is down."""
        backend = self.resources.backend
        report = getattr(backend, "health", None)
        llm = report() if callable(report) else None
        status = "degraded" if llm is not None and llm.get("state") != "ready" else "ok"
        return status, llm

    def close(self) -> None:
        for ex in self._extractors.values():
            ex.close()
        self.resources.close()
