"""Scatter the clearance kernels' per-waypoint blocks into the NLP's sparse Jacobian and Hessian.

The kernels (:mod:`forte.planning.nlp.collision_kernels`) give, per waypoint ``k``, the rows of every
slot, a dense Jacobian block on the stage window ``[q_{k-2}; q_{k-1}; q_k]`` and the Lagrangian
Hessian on the same window. Only the rows the broad phase kept (``keep``) enter the NLP; the
Hessian blocks land where the stage cost's do (:func:`forte.planning.nlp.assembly.hessian_pattern`).
"""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np
from scipy import sparse

from forte.planning.nlp.assembly import dm, nz_map
from forte.planning.nlp.collision_kernels import CollisionKernels
from forte.validation import FloatArray


def clearance_jacobian(kern: CollisionKernels, Z: ca.MX, params: ca.MX, index: FloatArray, kept: FloatArray,
                       nx: int) -> ca.MX:
    """Jacobian (rows kept x nx) of the kept clearance rows."""
    n, w, rows = index.shape[1], index.shape[0], kern.slots
    blocks = kern.jac.map(n)(Z, params)  # rows x (w n)
    k, r = np.divmod(np.asarray(kept, dtype=np.int64), rows)
    c = np.arange(w)
    t = np.repeat(np.arange(kept.size), w)
    cols = index[c[None, :], k[:, None]].ravel()
    src = ((k[:, None] * w + c[None, :]) * rows + r[:, None]).ravel()
    sp, pos = nz_map(t, cols, (kept.size, nx))
    M = sparse.csr_matrix((np.ones(src.size), (pos, src)), shape=(sp.nnz(), rows * w * n))
    return ca.MX(sp, ca.mtimes(dm(M), ca.vec(blocks)))


def clearance_hessian(kern: CollisionKernels, Z: ca.MX, params: ca.MX, lam: ca.MX, kept: FloatArray,
                      pattern: tuple[ca.Sparsity, Any], n: int) -> ca.MX:
    """Upper triangle of ``sum lam_i Hess(g_i)`` over the kept clearance rows, in the Lagrangian
    Hessian's ``pattern`` (:func:`~forte.planning.nlp.assembly.hessian_pattern`: the stage blocks)."""
    rows = kern.slots
    spread = sparse.csr_matrix((np.ones(kept.size), (kept, np.arange(kept.size))), shape=(rows * n, kept.size))
    lam_full = ca.reshape(ca.mtimes(dm(spread), lam), rows, n)
    blocks = kern.hess.map(n)(Z, params, lam_full)  # w x (w n)
    sp, maps = pattern
    return ca.MX(sp, ca.mtimes(ca.DM(maps[0]), ca.vec(blocks)))
