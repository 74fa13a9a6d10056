"""Sparse assembly of the NLP from per-waypoint blocks: selection, scatter and pattern matrices.

Every derivative the optimizer hands to IPOPT is a constant sparse matrix times the vector of
per-waypoint kernel outputs, so nothing but these products depends on the horizon ``N``.
"""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np
from scipy import sparse

from forte.validation import FloatArray


def gather(x: ca.MX, index: FloatArray) -> ca.MX:
    """``x[index]`` as a sparse selection product (one MX node)."""
    sel = sparse.csr_matrix((np.ones(len(index)), (np.arange(len(index)), index)), shape=(len(index), x.numel()))
    return ca.mtimes(dm(sel), x)


def dm(matrix: Any) -> ca.DM:
    """casadi DM from a scipy sparse matrix (keeps the sparsity, explicit zeros included).

    The same matrix, built the cheap way (CasADi converts Python lists element by element, and
    a numpy array slower still): from its compressed rows as the transpose when it has fewer
    rows than columns (fewer pointers to convert; the transpose only permutes the nonzeros),
    and a matrix of ones from the scalar 1 (most are selections and scatters)."""
    rows = matrix.shape[0] < matrix.shape[1]
    m = sparse.csr_matrix(matrix) if rows else sparse.csc_matrix(matrix)
    m.sort_indices()
    shape = m.shape[::-1] if rows else m.shape
    sp = ca.Sparsity(shape[0], shape[1], m.indptr.tolist(), m.indices.tolist())
    out = ca.DM(sp, 1.0) if m.nnz and (m.data == 1.0).all() else ca.DM(sp, m.data.tolist())
    return out.T if rows else out


def scatter_matrix(index: FloatArray, size: int) -> sparse.csr_matrix:
    """``S`` with ``(S v)_i = sum of v_j over j with index[j] = i``."""
    return sparse.csr_matrix((np.ones(len(index)), (index, np.arange(len(index)))), shape=(size, len(index)))


def nz_map(rows: FloatArray, cols: FloatArray, shape: tuple[int, int]) -> tuple[ca.Sparsity, FloatArray]:
    """Sparsity of the entries (rows, cols) and the position of each entry among its nonzeros."""
    keys = np.asarray(cols, dtype=np.int64) * shape[0] + np.asarray(rows, dtype=np.int64)
    unique, position = np.unique(keys, return_inverse=True)  # column-major order = CasADi's
    u_cols, u_rows = np.divmod(unique, shape[0])
    colind = np.searchsorted(u_cols, np.arange(shape[1] + 1))
    return ca.Sparsity(shape[0], shape[1], colind.tolist(), u_rows.tolist()), position


def block_diagonal_pattern(rows: int, cols: int, count: int, col_offset: int, ncol: int) -> tuple[ca.Sparsity, Any]:
    """Pattern of ``count`` dense rows x cols blocks stacked diagonally, and the map from the
    column-major entries of ``horzcat(blocks)`` to its nonzeros."""
    k, c, r = np.meshgrid(np.arange(count), np.arange(cols), np.arange(rows), indexing="ij")
    src = (k * cols + c) * rows + r  # position in vec(horzcat(blocks))
    grow, gcol = (k * rows + r).ravel(), (col_offset + k * cols + c).ravel()
    sp, pos = nz_map(grow, gcol, (rows * count, ncol))
    m = sparse.csr_matrix((np.ones(src.size), (pos, src.ravel())), shape=(sp.nnz(), rows * cols * count))
    return sp, dm(m)


def hessian_pattern(
    index: FloatArray, nq: int, n: int, Q: sparse.spmatrix
) -> tuple[ca.Sparsity, tuple[Any, Any, Any]]:
    """Upper-triangular pattern of the Lagrangian Hessian and the maps that fill it from the
    stage Hessians (3nq x 3nq per waypoint), the pose Hessians (nq x nq) and the constant ``Q``
    (``Q`` may be larger than ``nq n``: variables after the configurations, see the optimizer)."""
    w = 3 * nq
    # stage blocks: entry (a, b) of waypoint k -> (index[a, k], index[b, k])
    a, b = np.meshgrid(np.arange(w), np.arange(w), indexing="ij")
    ks = np.arange(n)
    s_rows = index[a.ravel()[None, :], ks[:, None]]
    s_cols = index[b.ravel()[None, :], ks[:, None]]
    s_src = (ks[:, None] * w + b.ravel()[None, :]) * w + a.ravel()[None, :]
    # pose blocks: entry (a, b) of waypoint k -> (k nq + a, k nq + b)
    pa, pb = np.meshgrid(np.arange(nq), np.arange(nq), indexing="ij")
    p_rows = ks[:, None] * nq + pa.ravel()[None, :]
    p_cols = ks[:, None] * nq + pb.ravel()[None, :]
    p_src = (ks[:, None] * nq + pb.ravel()[None, :]) * nq + pa.ravel()[None, :]
    Qc = sparse.coo_matrix(Q)
    rows = np.concatenate([s_rows.ravel(), p_rows.ravel(), Qc.row])
    cols = np.concatenate([s_cols.ravel(), p_cols.ravel(), Qc.col])
    keep = rows <= cols
    size = Q.shape[0]
    sp, pos = nz_map(rows[keep], cols[keep], (size, size))
    pos_full = np.full(rows.size, -1)
    pos_full[keep] = pos
    ns, npose = s_rows.size, p_rows.size
    def build(sel: slice, src: FloatArray, length: int) -> Any:
        p_ = pos_full[sel]
        ok = p_ >= 0
        return dm(sparse.csr_matrix((np.ones(ok.sum()), (p_[ok], src.ravel()[ok])), shape=(sp.nnz(), length)))
    m_stage = build(slice(0, ns), s_src, w * w * n)
    m_pose = build(slice(ns, ns + npose), p_src, nq * nq * n)
    q_vals = np.zeros(sp.nnz())
    qpos = pos_full[ns + npose:]
    ok = qpos >= 0
    np.add.at(q_vals, qpos[ok], Qc.data[ok])
    return sp, (m_stage, m_pose, q_vals)
