"""The base mode in the trajectory NLP (:attr:`forte.model.robot.MobileManipulator.base`).

- ``holonomic``: nothing (the base's three variables are free);
- ``fixed``: the base variables of every waypoint are bounded to the initial configuration's base
  (:func:`pin_base`), so the solver cannot move them;
- ``differential``: one equality row per interval ``k >= 1`` (:func:`lateral_rows`), no lateral
  displacement in the base frame at the interval's *midpoint* heading::

      -sin(th) (x_k - x_{k-1}) + cos(th) (y_k - y_{k-1}) = 0,   th = (yaw_{k-1} + yaw_k) / 2

  Why the midpoint: a differential drive that holds its forward and turning speeds over the
  interval drives a circular arc, whose chord points exactly along the midpoint heading, so the
  row is exact for such arcs (the end-point heading would forbid them: it is off by half the
  turn). The row touches ``(q_{k-1}, q_k)`` only, so its Hessian lands in the stage windows of
  the Lagrangian Hessian's pattern (:func:`forte.planning.nlp.assembly.hessian_pattern`).

These are bounds and rows outside the compiled kernels: the kernels (and their cache key) do not
depend on the base mode.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from forte.model.robot import N_BASE, MobileManipulator
from forte.validation import FloatArray


def pin_base(robot: MobileManipulator, n: int, lbx: FloatArray, ubx: FloatArray, q_init: FloatArray) -> None:
    """With a fixed base, bound the base of each of the ``n`` waypoints to ``q_init``'s (in place)."""
    if robot.base != "fixed":
        return
    base = np.asarray(q_init, dtype=float)[:N_BASE]
    for k in range(n):
        lbx[k * robot.nq:k * robot.nq + N_BASE] = ubx[k * robot.nq:k * robot.nq + N_BASE] = base


def lateral_rows(robot: MobileManipulator, X: ca.MX, at_rest: int = 0) -> ca.MX:
    """The differential-drive rows (one per interval, in order; none for another base mode).

    ``at_rest``: the last intervals whose step the NLP already forces to zero (a plan that ends at
    rest: two). Their rows would be linear combinations of those equalities: a rank-deficient
    Jacobian at the solution, which made IPOPT's step computation fail (TIAGo's reach at 31
    waypoints: ``Error_In_Step_Computation``), so they are left out; their lateral step is 0."""
    intervals = X.shape[1] - 1 - at_rest
    if robot.base != "differential" or intervals < 1:
        return ca.MX(0, 1)
    step = X[:N_BASE, 1:intervals + 1] - X[:N_BASE, :intervals]  # 3 x intervals
    heading = 0.5 * (X[2, 1:intervals + 1] + X[2, :intervals])
    return ca.vec(-ca.sin(heading) * step[0, :] + ca.cos(heading) * step[1, :])


def lateral_hessian(rows: ca.MX, lam: ca.MX, x: ca.MX, pattern: ca.Sparsity) -> ca.MX:
    """Upper triangle of ``sum lam_k Hess(row_k)`` in the Lagrangian Hessian's ``pattern``."""
    if rows.numel() == 0:
        return ca.MX(pattern, 0)
    upper = ca.triu(ca.hessian(ca.dot(lam, rows), x)[0])
    if not upper.sparsity().is_subset(pattern):  # project would drop entries: a wrong Hessian
        raise AssertionError("base_rows: the lateral rows' Hessian leaves the Lagrangian Hessian's pattern")
    return ca.project(upper, pattern)


def lateral_displacement(q: FloatArray) -> FloatArray:
    """Per interval, the base's sideways displacement (m) at the midpoint heading, as the rows."""
    q = np.asarray(q, dtype=float)
    step = np.diff(q[:, :N_BASE], axis=0)
    heading = 0.5 * (q[1:, 2] + q[:-1, 2])
    return -np.sin(heading) * step[:, 0] + np.cos(heading) * step[:, 1]
