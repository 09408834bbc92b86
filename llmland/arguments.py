"""argparse types for the command line: a bad value is a usage error (exit 2, one line naming the
option) before any service starts, never a traceback after the stack is up."""

from __future__ import annotations

import argparse
import math
import os
import re
import tempfile
from pathlib import Path

from llmland_schemas.keys import validate_drone_id
from llmland_schemas.messages import LATENCY_MODEL_PATTERN, MAX_EPISODE_S, SCENARIO_PATTERN


def _int_at_least(text: str, low: int) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
    if value < low:
        raise argparse.ArgumentTypeError(f"must be >= {low}, got {value}")
    return value


def non_negative_int(text: str) -> int:
    """An integer ≥ 0 (seeds, counts)."""
    return _int_at_least(text, 0)


def positive_int(text: str) -> int:
    """An integer ≥ 1 (trials, jobs)."""
    return _int_at_least(text, 1)


def positive_seconds(text: str) -> float:
    """A finite number of seconds > 0 (time limits)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not math.isfinite(value) or value <= 0.0:
        raise argparse.ArgumentTypeError(f"must be a finite number of seconds > 0, got {text}")
    return value


def episode_seconds(text: str) -> float:
    """An episode time limit: :func:`positive_seconds` up to :data:`~llmland_schemas.MAX_EPISODE_S`
    (a mission asking for more is refused by its schema, after the services started)."""
    value = positive_seconds(text)
    if value > MAX_EPISODE_S:
        raise argparse.ArgumentTypeError(f"at most {MAX_EPISODE_S:.0f} s (sim time), got {text}")
    return value


def latency_model(text: str) -> str:
    """``measured``, ``fixed:<ms>`` or ``normal:<mean_ms>,<sd_ms>`` (DESIGN §4)."""
    if re.match(LATENCY_MODEL_PATTERN, text) is None:
        raise argparse.ArgumentTypeError(f"{text!r}: use measured, fixed:<ms> or normal:<mean_ms>,<sd_ms>")
    return text


def scenario(text: str) -> str:
    """``walk-in:<distance_m>,<speed_mps>`` (a scripted test on top of the seeded world)."""
    if re.match(SCENARIO_PATTERN, text) is None:
        raise argparse.ArgumentTypeError(f"{text!r}: use walk-in:<distance_m>,<speed_mps>, e.g. walk-in:5.5,1.5")
    return text


#: More seeds than any experiment flies (a typo such as ``0-99999999999`` built the list in memory).
MAX_SEEDS = 100_000
#: More people than a world is meant to hold (each walks its own path; 10000 never finished).
MAX_PEDESTRIANS = 50
#: More drones than one machine runs (three processes each).
MAX_DRONES = 32
#: most episodes in parallel: each job is a stack (sim, planner, VLE, reasoner with its LLM worker),
#: ≈ 1.2 GB resident, and a lockstep episode keeps about one core busy (``--jobs 100`` started 100)
MAX_JOBS = 16


def seed_list(text: str) -> list[int]:
    """Seeds as ``1-20`` or ``1,4,7-9`` (ranges inclusive, increasing, at least one seed, at most
    :data:`MAX_SEEDS` in all)."""
    seeds: list[int] = []
    for part in text.split(","):
        lo, dash, hi = part.strip().partition("-")
        if not lo or (dash and not hi):
            raise argparse.ArgumentTypeError(f"{part.strip()!r}: seeds are integers >= 0, ranges low-high")
        first, last = non_negative_int(lo), non_negative_int(hi) if dash else None
        if last is not None and last < first:
            raise argparse.ArgumentTypeError(f"range {part.strip()!r} is empty (write it low-high)")
        end = (first if last is None else last) + 1
        if len(seeds) + end - first > MAX_SEEDS:
            raise argparse.ArgumentTypeError(f"{text!r}: more than {MAX_SEEDS} seeds")
        seeds += list(range(first, end))
    return seeds


def _count(text: str, low: int, high: int, what: str) -> int:
    """An integer from ``low`` to ``high``; ``what`` names the things counted in the message."""
    value = _int_at_least(text, low)
    if value > high:
        raise argparse.ArgumentTypeError(f"at most {high} {what}, got {value}")
    return value


def pedestrian_count(text: str) -> int:
    """A number of pedestrians, 0 to :data:`MAX_PEDESTRIANS`."""
    return _count(text, 0, MAX_PEDESTRIANS, "pedestrians")


def job_count(text: str) -> int:
    """Episodes in parallel, 1 to :data:`MAX_JOBS` (each is a whole stack of four processes)."""
    return _count(text, 1, MAX_JOBS, "jobs (each a stack of ≈ 1.2 GB)")


def drone_count(text: str) -> int:
    """A number of drones, 1 to :data:`MAX_DRONES`."""
    return _count(text, 1, MAX_DRONES, "drones")


def writable_dir(text: str) -> str:
    """A folder that is writable, or can be created (``--out``): a scratch folder is made and
    removed in the nearest folder on its path that exists (``os.access`` says yes to root even on
    ``/proc``); nothing else is created while parsing."""
    path = Path(text).absolute()
    existing = next(p for p in (path, *path.parents) if p.exists())  # the root, at worst
    if not existing.is_dir():
        raise argparse.ArgumentTypeError(f"cannot create {text}: {existing} is not a folder")
    try:
        os.rmdir(tempfile.mkdtemp(prefix=".llmland-check-", dir=existing))
    except OSError as exc:
        raise argparse.ArgumentTypeError(f"cannot create {text}: {exc.strerror or exc}") from None
    return text


def writable_file(text: str) -> str:
    """A file whose folder exists (or can be created) and is writable, not a folder (``--rrd``)."""
    if Path(text).is_dir():
        raise argparse.ArgumentTypeError(f"{text} is a folder: name a file in it, e.g. {Path(text) / 'landing.rrd'}")
    writable_dir(str(Path(text).parent))  # "." for a bare file name
    return text


def existing_file(text: str) -> str:
    """A file that exists."""
    if not Path(text).is_file():
        raise argparse.ArgumentTypeError(f"no such file: {text}")
    return text


#: The first bytes of a GGUF model file (the llama.cpp format).
GGUF_MAGIC = b"GGUF"


def gguf_file(text: str) -> str:
    """A GGUF model file (``--gguf``, ``--llm-model``): it exists and starts with ``GGUF``."""
    existing_file(text)
    with Path(text).open("rb") as fh:
        if fh.read(len(GGUF_MAGIC)) != GGUF_MAGIC:
            raise argparse.ArgumentTypeError(f"{text} is no GGUF model file (it does not start with 'GGUF')")
    return text


def drone_id(text: str) -> str:
    """A drone id usable in bus keys (``--drone-id``)."""
    try:
        return validate_drone_id(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def port(text: str) -> int:
    """A TCP port, 0 (any free one) to 65535."""
    value = non_negative_int(text)
    if value > 65535:
        raise argparse.ArgumentTypeError(f"not a TCP port: {value}")
    return value


def names_from(known: list[str]):  # type: ignore[no-untyped-def]
    """A comma-separated list of names, each one of ``known`` (an argparse type)."""

    def parse(text: str) -> str:
        unknown = [n for n in text.split(",") if n not in known]
        if unknown or not text:
            raise argparse.ArgumentTypeError(f"unknown {', '.join(unknown) or 'empty list'}; known: {', '.join(known)}")
        return text

    return parse


#: the services a fault run (``--kill``) may kill: the sim is the episode itself
KILLABLE_SERVICES = ("vle", "reasoner", "planner", "pilot")


def fault(text: str) -> tuple[str, float]:
    """``SERVICE@SIM_S`` (a fault run: kill SERVICE when the episode reaches SIM_S seconds; ``@0``
    when the time is left out) → ``(service, seconds)``."""
    service, sep, at = text.partition("@")
    if not service:
        raise argparse.ArgumentTypeError(f"{text!r}: use SERVICE@SIM_S, e.g. reasoner@20")
    if service == "sim":
        raise argparse.ArgumentTypeError(f"{text!r}: the sim is the episode (no result would come); "
                                         f"kill {', '.join(KILLABLE_SERVICES)}")
    if service not in KILLABLE_SERVICES:
        raise argparse.ArgumentTypeError(f"{text!r}: {service!r} is no service a fault run kills; "
                                         f"one of {', '.join(KILLABLE_SERVICES)}")
    if sep and not at:
        raise argparse.ArgumentTypeError(f"{text!r}: no time after '@' (SERVICE alone kills it at 0 s)")
    try:
        seconds = float(at or 0.0)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: {at!r} is not a number of seconds") from None
    if not math.isfinite(seconds) or seconds < 0.0:
        raise argparse.ArgumentTypeError(f"{text!r}: the time must be a finite number of seconds >= 0")
    return service, seconds
