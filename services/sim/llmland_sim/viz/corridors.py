"""Edges of the planner's convex corridors ``{x | A x ≤ b}`` for ``world/plan/corridors``.

scipy does the geometry: a Chebyshev centre (``linprog``) as the interior point, then
``HalfspaceIntersection`` for the vertices; two vertices span an edge when they share two
of the polytope's planes.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence

import numpy as np
from llmland_schemas import CorridorPolytope
from scipy.optimize import linprog
from scipy.spatial import HalfspaceIntersection, QhullError

log = logging.getLogger(__name__)

#: polytopes thinner than this (inscribed radius, m) are not drawn
MIN_INRADIUS_M = 1e-3
#: edges shorter than this (m) join duplicated vertices of degenerate corners
MIN_EDGE_M = 1e-6


def polytope_edges(A: np.ndarray, b: np.ndarray) -> list[np.ndarray]:  # noqa: N803 - the usual names
    """The edges (each a (2, 3) segment) of a bounded polytope ``A x ≤ b``; [] if empty or flat."""
    A, b = np.asarray(A, dtype=float), np.asarray(b, dtype=float)  # noqa: N806
    norms = np.linalg.norm(A, axis=1)
    res = linprog(c=[0.0, 0.0, 0.0, -1.0], A_ub=np.hstack([A, norms[:, None]]), b_ub=b,
                  bounds=[(None, None)] * 3 + [(0.0, None)], method="highs")
    if not res.success or res.x[3] < MIN_INRADIUS_M:
        return []
    try:
        hs = HalfspaceIntersection(np.hstack([A, -b[:, None]]), res.x[:3])
    except QhullError:
        log.debug("corridor polytope not drawn (qhull failed)")
        return []
    verts, planes = hs.intersections, [set(f) for f in hs.dual_facets]
    edges = []
    for i in range(len(verts)):
        for j in range(i + 1, len(verts)):
            if len(planes[i] & planes[j]) >= 2 and np.linalg.norm(verts[i] - verts[j]) > MIN_EDGE_M:
                edges.append(np.stack([verts[i], verts[j]]))
    return edges


def corridor_edges(corridors: Sequence[CorridorPolytope]) -> list[np.ndarray]:
    """All edges of all corridors."""
    out: list[np.ndarray] = []
    for c in corridors:
        out += polytope_edges(np.asarray(c.A), np.asarray(c.b))
    return out
