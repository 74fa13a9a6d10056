"""Layout of the trajectory NLP's variables and rows (:mod:`forte.planning.nlp.optimizer`).

Variables ``x = [vec(q_1..q_N); z]``: the configurations, then the lifted variables ``z = A x``
of the quadratic terms solved in lifted form (:meth:`forte.planning.terms.costs.CostTerm.lifted`).
Rows ``g = [pose; kinematic; A x - z]``: 6 pose equalities per posed waypoint, the velocity and
acceleration rows (one block per time step, then the end-at-rest rows), the lifting rows. The
optimizer appends more variables and rows after these (the executed spline's, a scene's, ...:
:class:`forte.planning.nlp.structure.Spans`).

Everything that depends on that order lives here: the lifted quadratic, the full ``x`` of a
trajectory, the bounds of a solve, and the shift of a solve's multipliers along the horizon.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
from scipy import sparse

from forte.model.robot import N_BASE, MobileManipulator
from forte.planning.terms.costs import CostTerm
from forte.validation import FloatArray


class Bounds(NamedTuple):
    """``lbx <= x <= ubx`` and ``lbg <= g(x) <= ubg`` of one solve."""

    lbx: FloatArray
    ubx: FloatArray
    lbg: FloatArray
    ubg: FloatArray


def lifted_quadratic(terms: Sequence[CostTerm], weights: Sequence[float], n_arm: int, n: int,
                     size: int) -> tuple[sparse.csr_matrix, sparse.csr_matrix]:
    """``Q`` over ``[x; z]``, ``blockdiag(sum_i w_i D_i, diag(w_i g_i))``, and the lifting rows
    ``A`` (``z = A x``) of the quadratic terms' lifted forms (``x`` of length ``size``; terms of
    weight 0 are left out, and so are rows of gain 0, which add nothing)."""
    D, rows, gains = sparse.csr_matrix((size, size)), [sparse.csr_matrix((0, size))], [np.zeros(0)]
    for term, w in zip(terms, weights, strict=True):
        if w != 0:
            lifted = term.lifted(n_arm, n)
            keep = lifted.g != 0
            D, rows, gains = D + w * lifted.D, [*rows, lifted.A[keep]], [*gains, w * lifted.g[keep]]
    A, g = sparse.vstack(rows, format="csr"), np.concatenate(gains)
    Q = sparse.block_diag([D, sparse.diags(g)], format="csr") if g.size else D.tocsr()
    return Q, A


def full_x(q: FloatArray, lift: sparse.csr_matrix) -> FloatArray:
    """The NLP's variables for configurations ``q``: ``vec(q)`` and the lifted ``z = A vec(q)``."""
    xq = np.asarray(q, dtype=float).ravel()
    return np.concatenate([xq, lift @ xq])


def variable_bounds(robot: MobileManipulator, n: int, lifted: int,
                    q_init: FloatArray | None) -> tuple[FloatArray, FloatArray]:
    """Joint limits of every waypoint (the base is free), ``q_1 = q_init`` where given, ``z`` free."""
    free = np.full(lifted, np.inf)
    lbx = np.r_[np.tile(np.r_[np.full(N_BASE, -np.inf), robot.lower], n), -free]
    ubx = np.r_[np.tile(np.r_[np.full(N_BASE, np.inf), robot.upper], n), free]
    if q_init is not None:
        lbx[: robot.nq] = ubx[: robot.nq] = q_init
    return lbx, ubx


def kinematic_bounds(vel: FloatArray, acc: FloatArray, t: FloatArray, rest_rows: int) -> tuple[FloatArray, FloatArray]:
    """``|q_k - q_{k-1}| <= v dt_k`` and ``|dq_k - dq_{k-1}| <= a dt_k`` (the limits of the rows
    the optimizer keeps, one block per step), then ``rest_rows`` end-at-rest rows equal to 0."""
    if not (len(vel) or len(acc) or rest_rows):  # no kinematic rows (holding, or limits off)
        return np.zeros(0), np.zeros(0)
    dt = np.diff(np.asarray(t, dtype=float))
    ub = np.concatenate([(np.asarray(vel)[:, None] * dt[None, :]).ravel(order="F"),
                         (np.asarray(acc)[:, None] * dt[None, :]).ravel(order="F"), np.zeros(rest_rows)])
    return -ub, ub


#: The executed spline leaves a rest and enters one with zero slope (``clamped_spline``): over that
#: interval its acceleration reaches 4x the backward difference's (a cubic Hermite from slope 0 to
#: the secant's: ``2 (3 s - m) / h`` with ``m = s``), so those rows keep a quarter of the limit.
REST_ENTRY_FACTOR = 0.25


def rest_entries(kinematic: tuple[FloatArray, FloatArray], offset: int, rows: int,
                 steps: Sequence[int]) -> tuple[FloatArray, FloatArray]:
    """The kinematic bounds with the acceleration rows of ``steps`` (the step that leaves the
    start's rest, the one that enters the final rest) scaled by :data:`REST_ENTRY_FACTOR`
    (``offset``: where the acceleration rows begin; ``rows`` per step)."""
    lower, upper = (np.array(b, dtype=float) for b in kinematic)
    for step in steps:
        if step >= 0 and rows:
            block = slice(offset + step * rows, offset + (step + 1) * rows)
            if block.stop <= upper.size:
                lower[block] *= REST_ENTRY_FACTOR
                upper[block] *= REST_ENTRY_FACTOR
    return lower, upper


def constraint_bounds(posed: int, kinematic: tuple[FloatArray, FloatArray],
                      lifted: int) -> tuple[FloatArray, FloatArray]:
    """Pose rows of ``posed`` waypoints equal 0, the kinematic rows within their bounds, the
    ``lifted`` lifting rows equal 0."""
    pose, lift = np.zeros(6 * posed), np.zeros(lifted)
    return np.concatenate([pose, kinematic[0], lift]), np.concatenate([pose, kinematic[1], lift])


def shift_rows(a: FloatArray, steps: int) -> FloatArray:
    """``a[steps:]`` followed by ``steps`` copies of its last row (same shape as ``a``)."""
    a = np.asarray(a, dtype=float)
    steps = min(steps, a.shape[0])
    return np.concatenate([a[steps:], np.repeat(a[-1:], steps, axis=0)])


def shifted_multipliers(lam_x: FloatArray, lam_g: FloatArray, steps: int, n: int, nq: int,
                        posed: Sequence[int], kinematic_rows: Sequence[int]) -> tuple[FloatArray, FloatArray]:
    """The multipliers of a solve moved ``steps`` waypoints forward (a receding-horizon warm
    start): bounds per waypoint, pose rows (6 per posed waypoint) and kinematic rows (one block
    of ``rows`` per time step for each entry of ``kinematic_rows``: velocity, acceleration) hold
    their last block; the end-at-rest rows, the lifted variables and their rows stay."""
    posed = list(posed)
    pose = lam_g[: 6 * len(posed)].reshape(len(posed), 6)
    row = {k: i for i, k in enumerate(posed)}
    out = [np.array([pose[row.get(min(k + steps, posed[-1]), row[posed[-1]])] for k in posed]).ravel()]
    rest, offset = lam_g[6 * len(posed):], 0
    for rows in kinematic_rows:
        size = rows * (n - 1)
        if size:
            out.append(shift_rows(rest[offset:offset + size].reshape(n - 1, rows), steps).ravel())
        offset += size
    out.append(rest[offset:])
    lam_q = shift_rows(lam_x[: n * nq].reshape(n, nq), steps).ravel()
    return np.concatenate([lam_q, lam_x[n * nq:]]), np.concatenate(out)
