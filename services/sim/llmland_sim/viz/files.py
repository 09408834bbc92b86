"""Recording files: compaction with the ``rerun`` CLI that comes with rerun-sdk, and size."""

from __future__ import annotations

import logging
import shutil
import subprocess
import sys
from pathlib import Path

log = logging.getLogger(__name__)

#: `rerun rrd optimize` of a one-episode recording takes a second or two; never wait longer than this (s)
COMPACT_TIMEOUT_S = 120.0
MB = 1e6


def rerun_cli() -> str | None:
    """The ``rerun`` executable installed with this Python's rerun-sdk (else the one on PATH)."""
    beside = Path(sys.executable).parent / "rerun"
    return str(beside) if beside.exists() else shutil.which("rerun")


def compact_rrd(path: Path) -> bool:
    """Rewrite ``path`` with its chunks compacted (``rerun rrd optimize``); False if it could not."""
    cli = rerun_cli()
    if cli is None:
        log.warning("rerun CLI not found: %s left uncompacted", path)
        return False
    tmp = path.with_name(path.name + ".compact")
    try:
        proc = subprocess.run([cli, "rrd", "optimize", str(path), "-o", str(tmp)], capture_output=True, text=True,
                              timeout=COMPACT_TIMEOUT_S, check=False)
    except (OSError, subprocess.TimeoutExpired) as e:
        log.warning("compacting %s failed (%s): left as recorded", path, e)
        tmp.unlink(missing_ok=True)
        return False
    if proc.returncode != 0 or not tmp.exists():
        log.warning("compacting %s failed: %s", path, proc.stderr.strip()[-500:])
        tmp.unlink(missing_ok=True)
        return False
    tmp.replace(path)
    return True


def size_report(path: Path, flight_s: float) -> str:
    """``"8.1 MB, 195 kB per flight-second"``."""
    size = path.stat().st_size if path.exists() else 0
    per_s = f", {size / max(flight_s, 1e-9) / 1e3:.0f} kB per flight-second" if flight_s > 0 else ""
    return f"{size / MB:.1f} MB{per_s}"
