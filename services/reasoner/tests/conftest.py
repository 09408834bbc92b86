"""Shared, session-scoped models: loading the embedder and the GGUF once keeps the suite fast."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from llmland_reasoner.resources import Resources
from llmland_reasoner.settings import ReasonerSettings


@pytest.fixture(scope="session")
def index_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("index")


@pytest.fixture(scope="session")
def settings(index_dir: Path) -> ReasonerSettings:
    return ReasonerSettings(index_dir=index_dir, n_threads=1, timeout_s=30.0)


@pytest.fixture(scope="session")
def resources(settings: ReasonerSettings) -> Iterator[Resources]:
    yield Resources.load(settings, retrieval=True, llm=True)
