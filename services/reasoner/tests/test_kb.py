from __future__ import annotations

import json
import stat
from pathlib import Path

import pytest
from llmland_reasoner.kb import (
    KbEntry,
    KbEntryExistsError,
    KbNameTakenError,
    KnowledgeBase,
    add_to_additions,
    category_problems,
    default_kb_path,
    read_additions,
)
from pydantic import ValidationError


def _write(path: Path, entries: list[dict[str, object]], version: str = "1.0.0") -> Path:
    path.write_text(json.dumps({"version": version, "entries": entries}), encoding="utf-8")
    return path


def test_packaged_kb_is_valid_and_has_the_paper_defaults() -> None:
    kb = KnowledgeBase.load()
    assert len(kb) >= 60
    categories = {e.category for e in kb.entries}
    assert categories == {"person", "animal", "vehicle", "structure", "vegetation", "terrain", "lookalike"}
    assert kb.get("pedestrian").buffer_m == 3.0 and kb.get("pedestrian").is_human
    assert kb.get("car").buffer_m == 5.0 and kb.get("car").is_dynamic
    for entry in kb.entries:
        if entry.is_dynamic:
            assert entry.z_min >= 1.5, entry.id  # height plus margin
    assert not kb.get("statue").is_dynamic and not kb.get("scarecrow").is_human


@pytest.mark.parametrize(
    "change",
    [
        {"buffer_m": -1.0},
        {"z_min": float("nan")},
        {"category": "spaceship"},
        {"id": "Bad Id!"},
        {"is_human": True, "is_dynamic": False, "category": "person", "buffer_m": 3.0},
        {"buffer_m": 2.0},  # a moving vehicle needs 5 m
        {"colour": "red"},  # unknown field
        {"description": ""},
    ],
)
def test_bad_entries_are_rejected_on_load_and_on_add(
    tmp_path: Path, change: dict[str, object], robot_mower: dict[str, object]
) -> None:
    bad = {**robot_mower, **change}
    with pytest.raises(ValidationError):
        KnowledgeBase.load(_write(tmp_path / "kb.json", [bad]))
    kb = KnowledgeBase.load()
    before = (kb.version, len(kb))
    with pytest.raises(ValidationError):
        kb.add(bad)
    assert (kb.version, len(kb)) == before


def test_file_level_errors_are_rejected(tmp_path: Path, robot_mower: dict[str, object]) -> None:
    with pytest.raises(ValidationError):
        KnowledgeBase.load(_write(tmp_path / "dup.json", [robot_mower, robot_mower]))
    with pytest.raises(ValidationError):
        KnowledgeBase.load(_write(tmp_path / "ver.json", [robot_mower], version="latest"))
    with pytest.raises(ValidationError):
        KnowledgeBase.load(_write(tmp_path / "empty.json", []))
    (tmp_path / "broken.json").write_text("{not json", encoding="utf-8")
    with pytest.raises(ValidationError):
        KnowledgeBase.load(tmp_path / "broken.json")


def test_add_bumps_version_and_save_load_round_trips(tmp_path: Path, robot_mower: dict[str, object]) -> None:
    kb = KnowledgeBase.load()
    n, version = len(kb), kb.version
    added = kb.add(robot_mower)
    assert isinstance(added, KbEntry)
    assert kb.version != version and kb.version.split(".")[:2] == version.split(".")[:2]
    assert len(kb) == n + 1 and kb.get("robot_mower").buffer_m == 5.0
    kb.add({**robot_mower, "z_min": 2.0})  # same id replaces
    assert len(kb) == n + 1 and kb.get("robot_mower").z_min == 2.0
    before = kb.version
    with pytest.raises(KbEntryExistsError):
        kb.add({**robot_mower, "z_min": 3.0}, replace=False)
    assert kb.version == before and kb.get("robot_mower").z_min == 2.0  # nothing written
    target = tmp_path / "sub" / "kb.json"
    kb.save(target)
    assert [p.name for p in target.parent.iterdir()] == ["kb.json"]  # no temporary left behind
    again = KnowledgeBase.load(target)
    assert again.version == kb.version
    assert again.entries == kb.entries


def test_a_saved_kb_keeps_its_file_permissions(tmp_path: Path) -> None:
    """A write through the API made a 0644 KB file 0600 (the temporary file's mode)."""
    kb = KnowledgeBase.load()
    target = tmp_path / "kb.json"
    kb.save(target)
    target.chmod(0o644)
    kb.save(target)
    assert stat.S_IMODE(target.stat().st_mode) == 0o644


def test_default_path_is_inside_the_package() -> None:
    assert default_kb_path().is_file()
    assert default_kb_path().parent.name == "kb"


@pytest.mark.parametrize(
    ("change", "reason"),
    [
        ({"category": "person", "is_human": False, "is_dynamic": True, "buffer_m": 3.0}, "is_human true"),
        ({"category": "person", "is_human": True, "is_dynamic": False, "buffer_m": 3.0}, "is_dynamic must be true"),
        ({"category": "person", "is_human": True, "is_dynamic": True, "buffer_m": 2.0}, "buffer_m >= 3.0"),
        ({"category": "animal", "is_dynamic": False, "buffer_m": 0.0}, "is_dynamic must be true"),
        ({"category": "animal", "is_dynamic": True, "buffer_m": 3.0}, "buffer_m >= 4.0"),
        ({"category": "vehicle", "is_dynamic": False, "buffer_m": 1.0}, "buffer_m >= 5.0"),  # parked ones too
        ({"category": "lookalike", "is_human": True, "is_dynamic": True, "buffer_m": 3.0}, "only category person"),
        ({"category": "animal", "is_dynamic": True, "buffer_m": 4.0, "makes": ["ford"]}, "only a vehicle has makes"),
    ],
)
def test_category_rules_refuse_unsafe_entries_and_say_why(
    change: dict[str, object], reason: str, robot_mower: dict[str, object]
) -> None:
    """The issue's cases: a non-human static 0 m "person", a static 0 m "dog" (each failed before)."""
    with pytest.raises(ValidationError, match=reason):
        KbEntry.model_validate({**robot_mower, **change})


def test_every_shipped_entry_meets_its_category_minimum() -> None:
    for entry in KnowledgeBase.load().entries:
        assert category_problems(entry) == [], entry.id
        if entry.category in ("person", "animal"):
            assert entry.is_dynamic and entry.is_human == (entry.category == "person")


def test_api_additions_load_on_top_of_a_newer_shipped_kb(tmp_path: Path, robot_mower: dict[str, object]) -> None:
    """Entries written through the API are kept apart from the shipped KB and load on top of it:
    an update of the shipped KB is never hidden by an old whole copy (as it was: a write saved the
    whole KB under the cache, loaded instead of the package's on every later start, every checkout)."""
    from llmland_reasoner.resources import _load_kb
    from llmland_reasoner.settings import ReasonerSettings

    path = tmp_path / "kb_additions.json"
    add_to_additions(path, KbEntry.model_validate(robot_mower))
    add_to_additions(path, KbEntry.model_validate({**robot_mower, "buffer_m": 7.0}))  # replaced, not doubled
    assert [e.buffer_m for e in read_additions(path)] == [7.0]
    shipped = KnowledgeBase.load()
    kb = _load_kb(ReasonerSettings(index_dir=tmp_path))
    assert len(kb) == len(shipped) + 1 and kb.get(str(robot_mower["id"])).buffer_m == 7.0
    assert all(kb.get(e.id) == e for e in shipped.entries)  # every shipped entry as shipped
    assert len(_load_kb(ReasonerSettings(index_dir=tmp_path, kb_additions=False))) == len(shipped)
    path.write_text("{not json")
    assert len(_load_kb(ReasonerSettings(index_dir=tmp_path))) == len(shipped)  # damaged: left out, logged


def test_an_addition_never_replaces_a_shipped_entry(tmp_path: Path) -> None:
    """An entry added when the shipped KB lacked its id, which a newer shipped KB then names, is
    left out: the shipped, reviewed entry wins (review: an old 'quarry' addition hid KB 1.4.1's)."""
    from llmland_reasoner.resources import _load_kb
    from llmland_reasoner.settings import ReasonerSettings

    shipped = KnowledgeBase.load()
    pedestrian = shipped.get("pedestrian")
    add_to_additions(tmp_path / "kb_additions.json", pedestrian.model_copy(update={"buffer_m": 9.0}))
    kb = _load_kb(ReasonerSettings(index_dir=tmp_path))
    assert kb.get("pedestrian") == pedestrian and kb.version == shipped.version


def test_a_damaged_additions_file_is_moved_aside_not_a_block(tmp_path: Path, robot_mower: dict[str, object]) -> None:
    path = tmp_path / "kb_additions.json"
    path.write_text("{not json")
    add_to_additions(path, KbEntry.model_validate(robot_mower))  # was: every later write refused
    assert [e.id for e in read_additions(path)] == [robot_mower["id"]]
    assert (tmp_path / "kb_additions.json.damaged").read_text() == "{not json"


def test_an_added_entry_may_not_take_another_entrys_name(robot_mower: dict[str, object]) -> None:
    """A second newcomer added a static 1 m structure named "pedestrian", with "man" and "child"
    as synonyms, and an animal named "puppy" (201): a name says which entry a caption's word is."""
    kb = KnowledgeBase.load()
    for taken in ({"label": "Pedestrian"}, {"synonyms": ["lawn robot", "man"]}):
        with pytest.raises(KbNameTakenError, match="already names"):
            kb.add({**robot_mower, **taken}, replace=False)
    kb.add(robot_mower, replace=False)  # its own names are free
    kb.add({**robot_mower, "buffer_m": 6.0})  # a replacement (a file edit) keeps its names
