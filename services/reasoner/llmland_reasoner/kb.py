"""The knowledge base: a versioned JSON list of obstacle classes (DESIGN §5, step 1).

Every entry says whether the class moves, whether it is human, the minimum altitude to
overfly it (``z_min``, metres) and the horizontal keep-out radius (``buffer_m``, metres).
Entries are validated when the file is loaded and again on every :meth:`KnowledgeBase.add`;
``save`` writes atomically (temporary file + rename) so a reader never sees half a file.
"""

from __future__ import annotations

import json
import logging
import os
import stat
import tempfile
from importlib import resources
from pathlib import Path
from typing import Annotated, Literal

from llmland_schemas import ANIMAL_BUFFER_M, PERSON_BUFFER_M, VEHICLE_BUFFER_M
from pydantic import BaseModel, ConfigDict, Field, model_validator

log = logging.getLogger(__name__)

#: Minimum horizontal buffers by category (metres). Person and vehicle: the paper's defaults
#: (pedestrians 3 m, vehicles 5 m); animal: the KB's animal class (they move less predictably
#: than people and ignore the drone).
MIN_BUFFER_M: dict[str, float] = {"person": PERSON_BUFFER_M, "animal": ANIMAL_BUFFER_M, "vehicle": VEHICLE_BUFFER_M}
#: Categories whose members move by themselves.
LIVING = frozenset({"person", "animal"})

Category = Literal["person", "animal", "vehicle", "structure", "vegetation", "terrain", "lookalike"]
EntryId = Annotated[str, Field(pattern=r"^[a-z0-9][a-z0-9_]{0,63}$")]
Metres = Annotated[float, Field(ge=0.0, le=200.0, allow_inf_nan=False)]
Version = Annotated[str, Field(pattern=r"^\d+\.\d+\.\d+$")]


class KbEntry(BaseModel):
    """One obstacle class."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    id: EntryId
    label: Annotated[str, Field(min_length=1, max_length=64)]
    category: Category
    is_dynamic: bool
    is_human: bool
    z_min: Metres
    buffer_m: Metres
    description: Annotated[str, Field(min_length=1, max_length=500)]
    synonyms: list[Annotated[str, Field(min_length=1, max_length=64)]] = []
    #: Makers of this vehicle ("ford", "john deere"): a make and the model after it name this
    #: entry ("a ford mustang"; ``makes.py``). Vehicles only; not indexed for retrieval.
    makes: list[Annotated[str, Field(min_length=1, max_length=64)]] = []

    @model_validator(mode="after")
    def _consistent(self) -> KbEntry:
        """Safety rules by category; a write that breaks one is refused with the reason."""
        problems = category_problems(self)
        if problems:
            raise ValueError(f"{self.id}: " + "; ".join(problems))
        return self

    def chunk_text(self) -> str:
        """The text indexed for retrieval: label, synonyms and description."""
        also = ", ".join(self.synonyms)
        return f"{self.label} ({self.category}). Also: {also}. {self.description}"


def category_problems(entry: KbEntry) -> list[str]:
    """Why an entry is unsafe for its category (empty when it is fine)."""
    problems: list[str] = []
    if entry.category == "person" and not entry.is_human:
        problems.append("an entry in category person must have is_human true")
    if entry.makes and entry.category != "vehicle":
        problems.append(f"only a vehicle has makes (category is {entry.category})")
    if entry.category != "person" and entry.is_human:
        problems.append(f"only category person may be human (category is {entry.category})")
    if entry.category in LIVING and not entry.is_dynamic:
        problems.append(f"category {entry.category} moves by itself: is_dynamic must be true")
    floor = MIN_BUFFER_M.get(entry.category)
    if floor is not None and entry.buffer_m < floor:
        problems.append(f"category {entry.category} needs buffer_m >= {floor} m (got {entry.buffer_m} m)")
    return problems


class KbDocument(BaseModel):
    """The file format: ``{"version": "x.y.z", "entries": [...]}`` with unique ids."""

    model_config = ConfigDict(extra="forbid")

    version: Version
    entries: Annotated[list[KbEntry], Field(min_length=1)]

    @model_validator(mode="after")
    def _unique_ids(self) -> KbDocument:
        seen: set[str] = set()
        for entry in self.entries:
            if entry.id in seen:
                raise ValueError(f"duplicate kb id {entry.id!r}")
            seen.add(entry.id)
        return self


def default_kb_path() -> Path:
    """The knowledge base shipped with the package."""
    return Path(str(resources.files("llmland_reasoner") / "kb" / "knowledge_base.json"))


def _bump(version: str) -> str:
    major, minor, patch = (int(p) for p in version.split("."))
    return f"{major}.{minor}.{patch + 1}"


class KbEntryExistsError(ValueError):
    """An add that would replace an entry with the same id (:meth:`KnowledgeBase.add` with
    ``replace=False``)."""


class KbNameTakenError(ValueError):
    """An add (``replace=False``) whose label or a synonym another entry already has: the new
    entry would take over captions that name the other ("pedestrian" as a bench's name)."""


def _name_key(name: str) -> str:
    return " ".join(name.lower().split())


class KbAdditions(BaseModel):
    """Entries written through the API on top of the shipped KB (``kb_additions.json``): kept
    apart from it, so that a newer shipped KB is loaded with them, never hidden by an old copy."""

    model_config = ConfigDict(extra="forbid")

    entries: list[KbEntry] = []


def read_additions(path: Path) -> list[KbEntry]:
    """The entries of an additions file; none when it is absent."""
    if not path.exists():
        return []
    return KbAdditions.model_validate_json(path.read_text(encoding="utf-8")).entries


def usable_additions(path: Path) -> list[KbEntry]:
    """:func:`read_additions`, and a file that cannot be read moved aside (``.damaged``, logged)
    rather than blocking every later write: what it held stays there to be mended by hand."""
    try:
        return read_additions(path)
    except (OSError, ValueError) as exc:
        aside = path.with_name(path.name + ".damaged")
        try:
            os.replace(path, aside)
        except OSError as moving:  # a read-only folder: the next write says so, not this read
            log.error("KB additions in %s unreadable (%s), and not moved aside: %s", path, exc, moving)
        else:
            log.error("KB additions in %s unreadable (%s): moved to %s", path, exc, aside)
        return []


def add_to_additions(path: Path, entry: KbEntry) -> None:
    """Record ``entry`` in the additions file (replacing one with its id), atomically."""
    kept = [e for e in usable_additions(path) if e.id != entry.id]
    _write_atomically(path, KbAdditions(entries=[*kept, entry]).model_dump_json(indent=1))


def _write_atomically(path: Path, text: str) -> None:
    """A temporary file in the same folder, then rename: a reader never sees half a file. The file
    keeps the permissions it had (a new one gets what the umask gives): ``mkstemp`` makes 0600, so
    a KB file readable by others became readable by its owner only."""
    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        mode = stat.S_IMODE(path.stat().st_mode)
    except FileNotFoundError:
        umask = os.umask(0)
        os.umask(umask)
        mode = 0o666 & ~umask
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    try:
        os.fchmod(fd, mode)
        with os.fdopen(fd, "w", encoding="utf-8") as handle:
            handle.write(text)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


class KnowledgeBase:
    """An in-memory, validated knowledge base."""

    def __init__(self, document: KbDocument) -> None:
        self._doc = document
        self._by_id = {entry.id: entry for entry in document.entries}

    @classmethod
    def load(cls, path: str | Path | None = None) -> KnowledgeBase:
        """Read and validate a KB file (the packaged one by default)."""
        source = Path(path) if path is not None else default_kb_path()
        document = KbDocument.model_validate_json(source.read_text(encoding="utf-8"))
        log.info("loaded kb %s: %d entries from %s", document.version, len(document.entries), source)
        return cls(document)

    def copy(self) -> KnowledgeBase:
        """An independent knowledge base with the same entries and version (an :meth:`add` to
        either leaves the other as it was; the validated document itself is never changed)."""
        return KnowledgeBase(self._doc)

    @property
    def version(self) -> str:
        return self._doc.version

    @property
    def entries(self) -> list[KbEntry]:
        return list(self._doc.entries)

    def __len__(self) -> int:
        return len(self._doc.entries)

    def get(self, kb_id: str) -> KbEntry:
        return self._by_id[kb_id]

    def add(self, entry: KbEntry | dict[str, object], *, replace: bool = True) -> KbEntry:
        """Validate and append an entry (or replace one with the same id); bump the patch version.

        Raises:
            pydantic.ValidationError: the entry breaks the schema or a category rule.
            KbEntryExistsError: ``replace`` is false and an entry with this id exists (checked in
                the same call that writes, so two concurrent adds of one id cannot both succeed
                when the writes are serialised, as ``Resources.write_lock`` does).
        """
        new = entry if isinstance(entry, KbEntry) else KbEntry.model_validate(entry)
        KbEntry.model_validate(new.model_dump())  # re-check even a pre-built model
        if not replace and new.id in self._by_id:
            raise KbEntryExistsError(f"KB entry {new.id!r} exists")
        if not replace and (taken := self._names_taken(new)):
            raise KbNameTakenError(f"KB entry {new.id!r}: " + "; ".join(
                f"{name!r} already names {owner!r}" for name, owner in taken)
                + " (a name says which entry a caption's word is: one entry per name)")
        kept = [e for e in self._doc.entries if e.id != new.id]
        self._doc = KbDocument(version=_bump(self._doc.version), entries=[*kept, new])
        self._by_id = {e.id: e for e in self._doc.entries}
        log.info("kb entry %s added; kb version now %s", new.id, self._doc.version)
        return new

    def _names_taken(self, new: KbEntry) -> list[tuple[str, str]]:
        """The names (label, synonyms) of ``new`` that another entry already has, with its id."""
        owners = {_name_key(n): e.id for e in self._doc.entries if e.id != new.id for n in [e.label, *e.synonyms]}
        return [(n, owners[_name_key(n)]) for n in [new.label, *new.synonyms] if _name_key(n) in owners]

    def to_json(self) -> str:
        return self._doc.model_dump_json(indent=1)

    def save(self, path: str | Path) -> None:
        """Write the KB atomically: a temporary file in the same folder, then rename."""
        target = Path(path)
        _write_atomically(target, json.dumps(json.loads(self.to_json()), indent=1, ensure_ascii=False) + "\n")
        log.info("kb %s saved to %s", self.version, target)
