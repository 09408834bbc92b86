"""Shared, session-scoped models: loading the embedder and the GGUF once keeps the suite fast."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from llmland_reasoner.kb import KnowledgeBase
from llmland_reasoner.lexicon import WordNet
from llmland_reasoner.mentions import MentionFinder
from llmland_reasoner.resources import Resources
from llmland_reasoner.settings import ReasonerSettings


@pytest.fixture(scope="session")
def index_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("index")


@pytest.fixture(scope="session")
def settings(index_dir: Path) -> ReasonerSettings:
    # inline: the model in the test process (the worker process has its own tests, test_llm_worker.py)
    return ReasonerSettings(index_dir=index_dir, n_threads=1, timeout_s=30.0, llm_isolation="inline")


@pytest.fixture(scope="session")
def resources(settings: ReasonerSettings) -> Iterator[Resources]:
    yield Resources.load(settings, retrieval=True, llm=True)


@pytest.fixture(scope="module")
def finder(tmp_path_factory: pytest.TempPathFactory) -> MentionFinder:
    """The mention finder on the shipped KB and WordNet (no models)."""
    return MentionFinder(KnowledgeBase.load(), WordNet(tmp_path_factory.mktemp("wordnet")))


@pytest.fixture()
def robot_mower() -> dict[str, object]:
    """A valid KB entry the shipped KB lacks (a fresh dict per test)."""
    return {
        "id": "robot_mower",
        "label": "robot lawn mower",
        "category": "vehicle",
        "is_dynamic": True,
        "is_human": False,
        "z_min": 1.5,
        "buffer_m": 5.0,
        "description": "A small autonomous lawn mower driving over a lawn.",
        "synonyms": ["lawn robot", "robotic mower", "robot mower"],
    }
