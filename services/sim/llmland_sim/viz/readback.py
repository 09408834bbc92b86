"""Reading a landing recording back with the Rerun dataframe API (tests, checks, analysis).

``rr.server.Server`` serves the ``.rrd`` as a one-segment dataset; queries return Arrow
tables. Needs ``datafusion`` (rerun-sdk's ``catalog`` extra; in the project's test tools).
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import rerun as rr
from rerun.chunk import RrdReader

from . import paths
from .scene import GROUND_Z_M

DATASET = "landing"


class Recording:
    """Query one ``.rrd``: entity paths, and columns per ``sim_time`` or static."""

    def __init__(self, dataset: Any) -> None:
        self._ds = dataset

    def entity_paths(self) -> set[str]:
        """Every entity path with data, without the leading ``/``."""
        return {c.entity_path.lstrip("/") for c in self._ds.schema().component_columns()}

    def table(self, contents: str | Sequence[str], *, static: bool = False, at_s: Sequence[float] | None = None,
              clears: bool = False) -> pa.Table:
        """Rows per ``sim_time`` (or the static row) of the entities matching ``contents``;
        with ``at_s``, one row per given time holding the latest values (latest-at, which
        here ignores ``Clear``); with ``clears``, the ``Clear:is_recursive`` columns too."""
        selection = self._ds.filter_contents([contents] if isinstance(contents, str) else list(contents))
        if static:
            return selection.reader(index=None).to_arrow_table()
        if at_s is not None:
            times = np.array([round(t * 1e9) for t in at_s], dtype=np.int64)
            at = {segment: times for segment in selection.segment_ids()}
            return selection.reader(index=paths.TIMELINE, using_index_values=at,
                                    fill_latest_at=True).to_arrow_table()
        return selection.reader(index=paths.TIMELINE, include_tombstone_columns=clears).to_arrow_table()


@contextmanager
def open_recording(rrd: Path) -> Iterator[Recording]:
    """A local Rerun server over ``rrd`` for the duration of the block."""
    with rr.server.Server(datasets={DATASET: [str(rrd)]}) as server:
        yield Recording(server.client().get_dataset(DATASET))


def has_blueprint(rrd: Path) -> bool:
    """True when the file carries a blueprint store (the layout it opens with)."""
    return bool(RrdReader(rrd).blueprints())


def column(table: pa.Table, entity: str, component: str) -> list[Any]:
    """One component column as Python values (None where not logged), e.g.
    ``column(t, "world/drone", "InstancePoses3D:translations")``."""
    name = f"/{entity}:{component}"
    return table.column(name).to_pylist() if name in table.column_names else [None] * table.num_rows


def seconds(table: pa.Table) -> np.ndarray:
    """The ``sim_time`` column in seconds."""
    return np.asarray(table.column(paths.TIMELINE).cast(pa.int64()).to_numpy(), dtype=float) / 1e9


#: a path point is where the drone was to within this (m)
PATH_TOLERANCE_M = 0.01
#: an unsafe box may reach this little (m, float noise) below the ground
GROUND_TOLERANCE_M = 1e-6
#: entity paths that only semantic methods (captions → specs) produce
SEMANTIC_ONLY = (paths.SCENE_CAPTION, paths.PLOT_SPEC_LATENCY)


def landing_problems(rrd: Path, *, semantic: bool = True) -> list[str]:
    """What a landing recording gets wrong ([] when nothing): no blueprint; an entity path of
    DESIGN §9 missing; a path point away from the drone's world position at its ``sim_time``;
    an unsafe box reaching below the ground."""
    problems = [] if has_blueprint(rrd) else ["no blueprint"]
    with open_recording(rrd) as r:
        entities = r.entity_paths()
        drone = r.table([paths.DRONE, paths.TRAJECTORY])
        unsafe = r.table(f"/{paths.UNSAFE}/**")
    for p in paths.DESIGN_PATHS:
        if (semantic or p not in SEMANTIC_ONLY) and not any(e == p or e.startswith(p + "/") for e in entities):
            problems.append(f"missing entity path {p}")
    problems += _path_problems(drone)
    for name in unsafe.column_names:
        if not name.endswith(":Boxes3D:centers"):
            continue
        entity = name[1:].split(":")[0]
        for t, centres, halves in zip(seconds(unsafe), column(unsafe, entity, "Boxes3D:centers"),
                                      column(unsafe, entity, "Boxes3D:half_sizes"), strict=True):
            for c, h in zip(centres or [], halves or [], strict=False):
                if c[2] - h[2] < GROUND_Z_M - GROUND_TOLERANCE_M:
                    problems.append(f"{entity} at {t:.2f} s reaches {c[2] - h[2]:.2f} m, below the ground")
    return problems


def _path_problems(table: pa.Table) -> list[str]:
    """Each logged path ends at the drone's pose of the same ``sim_time`` and keeps its
    earlier points where they were."""
    problems: list[str] = []
    before: np.ndarray = np.zeros((0, 3))
    checked = 0
    for t, pose, strip in zip(seconds(table), column(table, paths.DRONE, "InstancePoses3D:translations"),
                              column(table, paths.TRAJECTORY, "LineStrips3D:strips"), strict=True):
        if not strip:
            continue
        points = np.asarray(strip[0], dtype=float)
        if not pose:
            problems.append(f"path logged at {t:.2f} s without a drone pose")
        elif np.linalg.norm(points[-1] - np.asarray(pose[0])) > PATH_TOLERANCE_M:
            problems.append(f"path end {points[-1].round(3)} is not the drone {np.round(pose[0], 3)} at {t:.2f} s")
        n = min(len(before), len(points))
        if n and np.abs(points[:n] - before[:n]).max() > PATH_TOLERANCE_M:
            problems.append(f"path points moved at {t:.2f} s")
        before = points
        checked += 1
    return problems if checked else problems + ["no path logged"]
