"""Fixed sparsity layout of the MPC quadratic program (built once, values refreshed per tick).

Decision vector ``z = [x_0 … x_N (9 each), u_0 … u_{N-1} (4 each), s_1 … s_N]``. Constraint
rows in clarabel form ``A z + s = b`` with cones ``[Zero(n_eq), Nonnegative(n_ineq)]``:

* equalities: ``x_0 = x̂`` (9), then ``x_{k+1} − A_k x_k − B_k u_k = c_k`` (9 per stage);
* inequalities: input box (8 per stage), roll/pitch bounds on ``x_1 … x_N`` (4 per stage),
  per stage ``k ≥ 1``: ``K`` corridor rows ``a·p_k − s_k ≤ b`` and a floor row
  ``−z_k − s_k ≤ −z_floor``, and finally ``−s_k ≤ 0``.

:class:`SparseLayout` collects ``(row, col, value)`` triplets in a "slot" order that is
convenient to fill with vectorised numpy, and a permutation to clarabel's CSC data order;
per tick ``data = values[perm]`` is all that changes.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from llmland_schemas.arrays import FloatArray
from numpy.typing import NDArray

from llmland_planner.dynamics import NU, NX

IntArray = NDArray[np.int64]


@dataclass
class SparseLayout:
    """Triplet builder with a fixed CSC pattern; slots are indices into ``values``."""

    n_rows: int
    n_cols: int
    rows: list[IntArray] = field(default_factory=list)
    cols: list[IntArray] = field(default_factory=list)
    vals: list[FloatArray] = field(default_factory=list)
    n_slots: int = 0

    def add(self, rows: IntArray, cols: IntArray, vals: FloatArray | float) -> slice:
        """Append entries; returns the slot range that holds their values."""
        rb, cb = np.broadcast_arrays(np.asarray(rows, dtype=np.int64),
                                     np.asarray(cols, dtype=np.int64))
        v = np.broadcast_to(np.asarray(vals, dtype=float), rb.shape).astype(float).ravel()
        r, c = rb.ravel(), cb.ravel()
        self.rows.append(r)
        self.cols.append(c)
        self.vals.append(v)
        sl = slice(self.n_slots, self.n_slots + r.size)
        self.n_slots += r.size
        return sl

    def finish(self) -> tuple[sp.csc_matrix, IntArray, FloatArray]:
        """CSC matrix (explicit zeros kept), ``perm`` (slot order → CSC order), initial values."""
        r, c = np.concatenate(self.rows), np.concatenate(self.cols)
        v = np.concatenate(self.vals)
        perm = np.lexsort((r, c)).astype(np.int64)
        if np.any((np.diff(c[perm]) == 0) & (np.diff(r[perm]) == 0)):
            raise ValueError("duplicate entries in QP layout")
        indptr = np.zeros(self.n_cols + 1, dtype=np.int64)
        np.add.at(indptr, c + 1, 1)
        indptr = np.cumsum(indptr)
        mat = sp.csc_matrix((v[perm], r[perm], indptr), shape=(self.n_rows, self.n_cols))
        return mat, perm, v


@dataclass
class QpIndex:
    """Offsets of variables and constraint blocks for horizon ``n`` and ``k`` corridor rows."""

    n: int
    k: int

    @property
    def n_var(self) -> int:
        return (self.n + 1) * NX + self.n * NU + self.n

    def x(self, stage: int) -> int:
        return stage * NX

    def u(self, stage: int) -> int:
        return (self.n + 1) * NX + stage * NU

    def s(self, stage: int) -> int:
        """Slack of stage ``1 … N``."""
        return (self.n + 1) * NX + self.n * NU + stage - 1

    @property
    def n_eq(self) -> int:
        return (self.n + 1) * NX

    @property
    def row_input(self) -> int:
        return self.n_eq

    @property
    def row_tilt(self) -> int:
        return self.row_input + 2 * NU * self.n

    @property
    def row_corr(self) -> int:
        return self.row_tilt + 4 * self.n

    @property
    def row_slack(self) -> int:
        return self.row_corr + (self.k + 1) * self.n

    @property
    def n_con(self) -> int:
        return self.row_slack + self.n


def dynamics_masks(a_d: FloatArray, b_d: FloatArray) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
    """Structural nonzeros of ``A_d (M, 9, 9)``/``B_d (M, 4)`` sampled at generic points."""
    return np.any(a_d != 0.0, axis=0), np.any(b_d != 0.0, axis=0)


def build_constraints(ix: QpIndex, mask_a: NDArray[np.bool_],
                      mask_b: NDArray[np.bool_]) -> tuple[SparseLayout, dict[str, slice]]:
    """Lay out ``A``; returns the layout and the slot ranges refreshed every tick."""
    n, k = ix.n, ix.k
    lay = SparseLayout(ix.n_con, ix.n_var)
    slots: dict[str, slice] = {}
    lay.add(np.arange(NX), np.arange(NX), 1.0)
    st = np.arange(n)
    base = NX + NX * st  # first row of each dynamics block
    lay.add(base[:, None] + np.arange(NX), np.array([ix.x(int(s) + 1) for s in st])[:, None]
            + np.arange(NX), 1.0)
    ai, aj = np.nonzero(mask_a)
    slots["A"] = lay.add(base[:, None] + ai, np.array([ix.x(int(s)) for s in st])[:, None] + aj, 0.0)
    bi, bj = np.nonzero(mask_b)
    slots["B"] = lay.add(base[:, None] + bi, np.array([ix.u(int(s)) for s in st])[:, None] + bj, 0.0)
    ucol = np.array([ix.u(int(s)) for s in st])[:, None] + np.arange(NU)
    r_in = ix.row_input + 2 * NU * st[:, None]
    lay.add(r_in + np.arange(NU), ucol, 1.0)
    lay.add(r_in + NU + np.arange(NU), ucol, -1.0)
    xcol = np.array([ix.x(int(s) + 1) for s in st])
    r_t = ix.row_tilt + 4 * st
    lay.add(np.stack([r_t, r_t + 1, r_t + 2, r_t + 3], 1),
            np.stack([xcol + 6, xcol + 6, xcol + 7, xcol + 7], 1), np.array([1.0, -1.0, 1.0, -1.0]))
    r_c = ix.row_corr + (k + 1) * st[:, None] + np.arange(k)  # (n, k)
    slots["corr"] = lay.add(np.repeat(r_c[..., None], 3, axis=2),
                            xcol[:, None, None] + np.arange(3), 0.0)
    scol = np.array([ix.s(int(s) + 1) for s in st])
    lay.add(r_c, np.repeat(scol[:, None], k, axis=1), -1.0)
    r_f = ix.row_corr + (k + 1) * st + k
    lay.add(r_f, xcol + 2, -1.0)
    lay.add(r_f, scol, -1.0)
    lay.add(ix.row_slack + st, scol, -1.0)
    return lay, slots


def build_cost(ix: QpIndex, q_diag: FloatArray, q_term: FloatArray, r_diag: FloatArray,
               rd_diag: FloatArray, slack_quad: float) -> sp.csc_matrix:
    """Upper-triangular ``P`` for ``½ zᵀ P z``: state weights ``(9,)`` on stages ``1…N-1``,
    ``q_term (9,)`` on ``N``, input ``r_diag (4,)``, input-change ``rd_diag (4,)`` (including
    ``u_0 − u_prev``), quadratic slack weight."""
    n = ix.n
    diag = np.zeros(ix.n_var)
    for s in range(1, n + 1):
        diag[ix.x(s):ix.x(s) + NX] = q_term if s == n else q_diag
    for s in range(n):
        n_terms = 2 if s < n - 1 else 1
        diag[ix.u(s):ix.u(s) + NU] = r_diag + n_terms * rd_diag
    diag[ix.s(1):] = slack_quad
    rows, cols, vals = [np.arange(ix.n_var)], [np.arange(ix.n_var)], [diag]
    for s in range(1, n):
        rows.append(ix.u(s - 1) + np.arange(NU))
        cols.append(ix.u(s) + np.arange(NU))
        vals.append(-rd_diag)
    p = sp.coo_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                      shape=(ix.n_var, ix.n_var))
    return sp.triu(p).tocsc()
