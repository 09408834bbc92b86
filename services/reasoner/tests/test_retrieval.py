from __future__ import annotations

import math
from pathlib import Path

import pytest
from llama_index.core import Settings
from llmland_reasoner.embedding import LocalSentenceEmbedding
from llmland_reasoner.kb import KnowledgeBase
from llmland_reasoner.resources import Resources
from llmland_reasoner.retrieval import Retriever, index_key


@pytest.mark.parametrize(
    ("caption", "expected"),
    [
        ("a woman crossing the street on foot", "pedestrian"),
        ("a big yellow bulldozer", "excavator"),
        ("a scarecrow with a straw hat", "scarecrow"),
        ("an oak tree with wide branches", "tree"),
        ("a stack of wooden pallets", "container"),
    ],
)
def test_hybrid_retrieval_returns_the_right_entry(resources: Resources, caption: str, expected: str) -> None:
    assert resources.retriever is not None
    hits = resources.retriever.retrieve(caption)
    assert len(hits) == 3
    assert hits[0][0].id == expected
    scores = [score for _, score in hits]
    assert scores == sorted(scores, reverse=True) and all(math.isfinite(s) and s > 0 for s in scores)


def test_llama_index_uses_no_hosted_models(resources: Resources) -> None:
    assert isinstance(Settings.embed_model, LocalSentenceEmbedding)
    assert type(Settings.llm).__name__ == "MockLLM"


def test_empty_query_returns_nothing(resources: Resources) -> None:
    assert resources.retriever is not None
    assert resources.retriever.retrieve("   ") == []


def test_embedding_is_normalised(resources: Resources) -> None:
    assert resources.embed is not None
    vec = resources.embed.get_query_embedding("a dog")
    assert len(vec) == 384
    assert abs(sum(x * x for x in vec) - 1.0) < 1e-4


def test_index_is_persisted_and_reloaded_by_kb_version(
    resources: Resources, tmp_path: Path, robot_mower: dict[str, object]
) -> None:
    assert resources.embed is not None
    kb = KnowledgeBase.load()
    built = Retriever(kb, resources.embed, index_dir=tmp_path)
    assert not built.loaded_from_disk
    folder = tmp_path / index_key(kb, resources.embed.model_name)
    assert folder.name.startswith(kb.version + "-") and (folder / "done").is_file()
    reloaded = Retriever(kb, resources.embed, index_dir=tmp_path)
    assert reloaded.loaded_from_disk
    caption = "a man walking a dog in a park"
    assert [(e.id, round(s, 6)) for e, s in reloaded.retrieve(caption)] == [
        (e.id, round(s, 6)) for e, s in built.retrieve(caption)
    ]
    kb.add(robot_mower)
    extended = Retriever(kb, resources.embed, index_dir=tmp_path)
    assert not extended.loaded_from_disk  # new version, new index
    assert extended.retrieve("a robotic mower cutting grass")[0][0].id == "robot_mower"
    assert len([p for p in tmp_path.iterdir() if p.is_dir()]) == 2


def test_builders_racing_for_one_index_folder_never_break_it(resources: Resources, tmp_path: Path) -> None:
    """Two reasoners building the same index at once (``--jobs 2`` on a fresh machine): the second
    to finish keeps the first one's folder (it may be in use) and leaves no temporary folder."""
    assert resources.embed is not None
    kb = KnowledgeBase.load()
    first = Retriever(kb, resources.embed, index_dir=tmp_path)
    folder = tmp_path / index_key(kb, resources.embed.model_name)
    done = (folder / "done").stat()
    first._build(folder)  # a second builder finishing after the first
    assert (folder / "done").stat().st_ino == done.st_ino  # the folder in use was not replaced
    assert [p.name for p in tmp_path.iterdir()] == [folder.name]
    assert Retriever(kb, resources.embed, index_dir=tmp_path).loaded_from_disk
