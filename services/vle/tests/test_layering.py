"""The VLE's dependency on the simulator runs one way, through ``llmland_vle.simrender`` only."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "llmland_vle"


def test_the_service_never_imports_the_simulator() -> None:
    code = (
        "import sys, llmland_vle.main, llmland_vle.service, llmland_vle.backends, llmland_vle.pipeline\n"
        "llmland_vle.main.build_parser()\n"
        "print(sorted(m for m in sys.modules if m.startswith('llmland_sim')))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_only_simrender_imports_the_simulator() -> None:
    importers = sorted(
        str(p.relative_to(PACKAGE)) for p in PACKAGE.rglob("*.py") if "import llmland_sim" in p.read_text()
        or "from llmland_sim" in p.read_text()
    )
    assert importers == ["simrender.py"]
