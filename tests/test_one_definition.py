"""Each shared concept has one definition, in ``llmland_schemas``, and every package uses it.

The concepts: the pinhole camera model (intrinsics and the projection arithmetic), the array
aliases, the list of worlds and methods, and the buffers of the paper and the hard limit.
Two checks: the names the packages expose are the very objects of the schemas (imports from
one place), and no source file outside the home defines them again (an AST scan, so a copy
added later fails here).
"""

from __future__ import annotations

import ast
from pathlib import Path
from typing import get_args

import llmland_schemas
import pytest
from llmland_schemas import arrays, camera, messages

ROOT = Path(__file__).resolve().parents[1]
SOURCE_DIRS = [ROOT / "llmland", ROOT / "shared" / "schemas" / "llmland_schemas",
               *sorted(p for p in (ROOT / "services").glob("*/llmland_*") if p.is_dir())]
CAMERA_HOME = ROOT / "shared/schemas/llmland_schemas/camera.py"
ARRAYS_HOME = ROOT / "shared/schemas/llmland_schemas/arrays.py"
MESSAGES_HOME = ROOT / "shared/schemas/llmland_schemas/messages.py"
ARRAY_ALIASES = {"FloatArray", "BoolArray", "VecLike"}
INTRINSIC_ATTRS = {"fx", "fy", "cx", "cy"}


def _sources() -> list[Path]:
    files = [f for d in SOURCE_DIRS for f in d.rglob("*.py")]
    assert len(files) > 100, SOURCE_DIRS  # the scan sees the whole code base
    return files


def _assigned_names(node: ast.AST) -> list[str]:
    if isinstance(node, ast.Assign):
        return [t.id for t in node.targets if isinstance(t, ast.Name)]
    if isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name) and node.value is not None:
        return [node.target.id]
    return []


def _intrinsics_arithmetic(node: ast.AST) -> bool:
    """A binary operation on pinhole intrinsics (``fx * x / z + cx`` and the like)."""
    return isinstance(node, ast.BinOp) and any(
        isinstance(n, ast.Attribute) and n.attr in INTRINSIC_ATTRS for n in ast.walk(node))


def _redefinitions(path: Path, root: Path = ROOT) -> list[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    worlds = set(get_args(messages.WorldName))
    found: list[str] = []
    for node in ast.walk(tree):
        where = f"{path.relative_to(root)}:{getattr(node, 'lineno', '?')}"
        if isinstance(node, ast.ClassDef) and node.name == "CameraIntrinsics" and path != CAMERA_HOME:
            found.append(f"{where}: class CameraIntrinsics")
        if _intrinsics_arithmetic(node) and path != CAMERA_HOME:
            found.append(f"{where}: pinhole arithmetic on fx/fy/cx/cy")
        for name in _assigned_names(node):
            if name in ARRAY_ALIASES and path != ARRAYS_HOME:
                found.append(f"{where}: {name} =")
            value = getattr(node, "value", None)
            is_number = isinstance(value, ast.Constant) and isinstance(value.value, float | int)
            if (name.endswith("_BUFFER_M") or name.endswith("HARD_LIMIT_M")) and is_number and path != MESSAGES_HOME:
                found.append(f"{where}: {name} = {value.value}")  # type: ignore[union-attr]
        if isinstance(node, ast.Tuple | ast.List | ast.Set) and path != MESSAGES_HOME:
            strings = {e.value for e in node.elts if isinstance(e, ast.Constant) and isinstance(e.value, str)}
            if worlds <= strings:
                found.append(f"{where}: a literal list of the worlds")
    return sorted(set(found))  # nested operations report their line once


def test_no_package_defines_a_shared_concept_again() -> None:
    found = [f for path in _sources() for f in _redefinitions(path)]
    assert not found, "defined again outside llmland_schemas:\n" + "\n".join(found)


def test_the_scan_catches_a_copy(tmp_path: Path) -> None:
    copy = tmp_path / "copy.py"
    copy.write_text("import numpy as np\nFloatArray = np.ndarray\nPERSON_BUFFER_M = 3.0\n"
                    "WORLDS = ('open_field', 'urban', 'forest_edge')\n"
                    "def u(k, x, z):\n    return k.fx * x / z + k.cx\n"
                    "class CameraIntrinsics:\n    pass\n", encoding="utf-8")
    found = _redefinitions(copy, root=tmp_path)
    assert len(found) == 5, found


@pytest.mark.parametrize(("module", "name", "home"), [
    ("llmland_sim.camera", "CameraIntrinsics", camera.CameraIntrinsics),
    ("llmland_schemas.messages", "CameraIntrinsics", camera.CameraIntrinsics),
    ("llmland_schemas.depth", "FloatArray", arrays.FloatArray),
    ("llmland_planner.search", "FloatArray", arrays.FloatArray),
    ("llmland_planner.search", "BoolArray", arrays.BoolArray),
    ("llmland_sim.world.geometry", "FloatArray", arrays.FloatArray),
    ("llmland_sim.world.geometry", "VecLike", arrays.VecLike),
    ("llmland_vle.training.poses", "FloatArray", arrays.FloatArray),
    ("llmland_sim.world", "WORLD_NAMES", messages.WORLD_NAMES),
    ("llmland_vle.training.data", "WORLD_NAMES", messages.WORLD_NAMES),
    ("llmland.experiment.plan", "ALL_WORLDS", messages.WORLD_NAMES),
    ("llmland_sim.scoring", "PERSON_HARD_LIMIT_M", messages.PERSON_HARD_LIMIT_M),
    ("llmland_planner.hard_limit", "PERSON_HARD_LIMIT_M", messages.PERSON_HARD_LIMIT_M),
    ("llmland.experiment.plots", "PERSON_HARD_LIMIT_M", messages.PERSON_HARD_LIMIT_M),
])
def test_packages_use_the_schemas_definition(module: str, name: str, home: object) -> None:
    mod = pytest.importorskip(module)
    assert getattr(mod, name) is home


def test_buffers_come_from_the_schemas() -> None:
    from llmland_reasoner.evaluation import BUFFER_CLASSES
    from llmland_reasoner.kb import MIN_BUFFER_M

    from llmland.oracle_specs import DEFAULT_SPECS

    assert DEFAULT_SPECS["person"].buffer_m == llmland_schemas.PERSON_BUFFER_M
    assert DEFAULT_SPECS["vehicle"].buffer_m == llmland_schemas.VEHICLE_BUFFER_M
    assert DEFAULT_SPECS["building"].buffer_m == llmland_schemas.STATIC_BUFFER_M
    assert MIN_BUFFER_M == {"person": llmland_schemas.PERSON_BUFFER_M, "animal": llmland_schemas.ANIMAL_BUFFER_M,
                            "vehicle": llmland_schemas.VEHICLE_BUFFER_M}
    assert BUFFER_CLASSES["static"] == llmland_schemas.STATIC_BUFFER_M
    fallback = llmland_schemas.SafetySpec.conservative()
    assert fallback.buffer_m == llmland_schemas.CONSERVATIVE_BUFFER_M
    assert fallback.z_min == llmland_schemas.CONSERVATIVE_Z_MIN_M
