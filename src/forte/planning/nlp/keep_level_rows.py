"""``keep_level`` in the trajectory NLP (:mod:`forte.planning.tasks.keep_level`): one inequality row
per waypoint whose orientation the solver chooses,

    ``h(q_k) = w . R(q_k) a  >=  cos(max_tilt)``,

with ``R(q)`` the end effector's world rotation (the CasADi twin's forward kinematics, base yaw
included), ``a`` the tool axis and ``w`` the world axis. ``arccos`` decreases on [-1, 1], so the
row holds exactly when the tilt ``arccos(h)`` is at most ``max_tilt``; unlike the angle, ``h`` is
smooth everywhere (the angle's gradient blows up at tilt 0). A test compares ``h`` with the
exact angle of Pinocchio's forward kinematics.

Which waypoints (:func:`keep_steps`): every waypoint the solver moves, but those whose orientation
is fixed already: the first (``q_1 = q_init``), a posed one (a pose equality), the last of a
configuration goal (bounded to the goal), and the two before the last of a plan that ends at rest
(equal to the last). The reader checks those orientations itself.

The rows touch one waypoint each, so their Hessian lands in the diagonal stage blocks of the
Lagrangian Hessian's pattern (:func:`forte.planning.nlp.base_rows.lateral_hessian` projects it).
They go after every other row of the NLP.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from forte.model.robot import MobileManipulator
from forte.model.twin import CasadiTwin
from forte.planning.tasks.keep_level import KeepLevel
from forte.validation import FloatArray


def keep_steps(n: int, first: int, posed: FloatArray, rests_at_end: bool, goal: str | None) -> FloatArray:
    """The waypoints that get a row (module docstring)."""
    steps = [k for k in range(first, n) if k not in set(np.asarray(posed).tolist())]
    if rests_at_end:
        steps = [k for k in steps if k < n - 3 or k == n - 1]
    if goal == "configuration":
        steps = [k for k in steps if k != n - 1]
    return np.asarray(steps, dtype=int)


def level_function(robot: MobileManipulator, keep: KeepLevel) -> ca.Function:
    """``h(q) = w . R(q) a`` as a CasADi function of one whole-body configuration."""
    q = ca.SX.sym("q", robot.nq)
    R, _ = CasadiTwin(robot).ee_pose(q)
    h = ca.dot(ca.DM(keep.world_axis), ca.mtimes(R, ca.DM(keep.tool_axis)))
    return ca.Function("keep_level", [q], [h])


def keep_rows(robot: MobileManipulator, keep: KeepLevel | None, X: ca.MX, steps: FloatArray) -> ca.MX:
    """The rows ``h(q_k)`` at ``steps`` (a column ``X[:, k]`` per waypoint); none without ``keep``."""
    if keep is None or len(steps) == 0:
        return ca.MX(0, 1)
    h = level_function(robot, keep).map(len(steps))
    return ca.vec(h(X[:, [int(k) for k in steps]]))


def keep_bounds(keep: KeepLevel | None, rows: int) -> tuple[FloatArray, FloatArray]:
    """``cos(max_tilt) <= h <= inf`` for each of ``rows`` rows."""
    low = keep.min_cosine if keep is not None else 0.0
    return np.full(rows, low), np.full(rows, np.inf)


def level_cosines(robot: MobileManipulator, keep: KeepLevel, q: FloatArray) -> FloatArray:
    """``h(q_k)`` for every configuration of ``q`` (N x nq), as the NLP evaluates it."""
    f = level_function(robot, keep)
    return np.array([float(f(qk)) for qk in np.asarray(q, dtype=float)])
