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

from forte.model.twin import CasadiTwin
from forte.planning.nlp.assembly import dm, nz_map
from forte.planning.nlp.collision_kernels import CollisionKernels, world_frames
from forte.validation import FloatArray

_FRAME_JOINTS: dict[str, tuple[np.ndarray, ...]] = {}


def frame_joints(robot: Any) -> tuple[np.ndarray, ...]:
    """Per frame of :func:`world_frames` (the base's, each arm joint's): the entries of ``q`` its
    world pose depends on, from the structural Jacobian of its rotation and position (the base's
    pose and the arm joints on the path to it; cached per robot)."""
    key = robot.fingerprint + str(robot.urdf_path)
    if key not in _FRAME_JOINTS:
        q = ca.SX.sym("q", robot.nq)
        found = []
        for R, p in world_frames(CasadiTwin(robot), q):
            sp = ca.jacobian(ca.vertcat(ca.vec(R), p), q).sparsity()
            found.append(np.unique(np.asarray(sp.get_col(), dtype=int)))
        _FRAME_JOINTS[key] = tuple(found)
    return _FRAME_JOINTS[key]


def window_columns(robot: Any, frame: int, other: int | None = None) -> np.ndarray:
    """The entries of the stage window ``z = [q_{k-2}; q_{k-1}; q_k]`` a kernel's rows can depend
    on: ``q_{k-1}`` and ``q_k``'s joints that move ``frame`` (and ``other``). The Jacobian's other
    entries are zero at every ``z``; left out of the NLP's pattern, they cost IPOPT's KKT nothing."""
    joints = frame_joints(robot)
    used = joints[frame] if other is None else np.union1d(joints[frame], joints[other])
    return np.concatenate([robot.nq + used, 2 * robot.nq + used])


def clearance_jacobian(kern: CollisionKernels, Z: ca.MX, params: ca.MX, index: FloatArray, kept: FloatArray,
                       nx: int, robot: Any) -> ca.MX:
    """Jacobian (rows kept x nx) of the kept clearance rows of ``robot``: the window entries the
    rows depend on (:func:`window_columns`), the others left out of the pattern."""
    n, w, rows = index.shape[1], index.shape[0], kern.slots
    blocks = kern.jac.map(n)(Z, params)  # rows x (w n)
    k, r = np.divmod(np.asarray(kept, dtype=np.int64), rows)
    c = window_columns(robot, kern.frame, kern.other)
    t = np.repeat(np.arange(kept.size), c.size)
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
