"""The fastest time law along a path under joint velocity and acceleration limits (toppra).

The waypoints ``q_0 ... q_M`` (the joints that move, :func:`~forte.planning.search.sampling.moving_joints`)
get the path parameter ``s_k = sum_{i<k} |q_{i+1} - q_i|`` (cumulative C-space distance) and a
cubic spline ``q(s)`` through them (toppra's ``SplineInterpolator``, not-a-knot ends). A time law
``s(t)`` gives ``dq/dt = q'(s) sd`` and ``d2q/dt2 = q''(s) sd^2 + q'(s) sdd``; toppra finds the one
of least duration with ``|dq_j/dt| <= v_j`` and ``|d2q_j/dt2| <= a_j`` at its gridpoints, at rest at
both ends. The limits are :meth:`forte.settings.KinematicLimits.resolve`'s: the arm's velocity
from the URDF, its acceleration from the robot (``acceleration_limits``), the base's velocity and
acceleration (x, y in the world frame, yaw) from :class:`~forte.settings.KinematicLimits`'s
``base_velocity`` and ``base_acceleration``; a joint with no acceleration limit is left free of
one. ``margin >= 1`` stretches the law uniformly: ``q(t) = q_toppra(t / margin)``, velocities
divided by ``margin``, accelerations by ``margin^2``.

The spline passes through the waypoints but not along the straight segments between them: it
departs from them by a fraction of the waypoint spacing near a corner. The searched path's states
are up to 0.2 apart and its clearance is checked on the segments, so the path is first given
states every :data:`KNOT_STEP` along its segments (:func:`on_segments`): through collinear
waypoints the spline is the segment itself (it is linear in its data and ``s`` is the arc
length), and it rounds a corner within a fraction of :data:`KNOT_STEP`, not of the search's
spacing (MotionBenchMaker's table_under_pick: a path 12 mm from a body cut a corner 21 mm into it
through the search's states, 13 mm from it through states every 0.1). Toppra's gridpoints are
at least :data:`GRID_PER_KNOT` per knot, so the limits hold at the tighter corners too (toppra
keeps them at its gridpoints only; through the wall test's path, measured on a fine grid: 1.07 x an
acceleration limit with 8 per knot, 1.00 x with 16).
"""

from __future__ import annotations

from collections import Counter
from typing import Any, NamedTuple

import numpy as np

from forte.exceptions import InvalidInputError
from forte.model.robot import MobileManipulator
from forte.planning.search.sampling import moving_joints
from forte.settings import KinematicLimits
from forte.validation import FloatArray

#: A limit counts as active at a gridpoint when it is used to this fraction.
ACTIVE = 0.99
#: The base's coordinates, as :class:`Timed.limiting` names them.
BASE_NAMES = ("base x", "base y", "base yaw")


class Timed(NamedTuple):
    """``t`` (samples), ``q`` at them (samples x nq), the ``duration`` (s) and the limit that set
    it (``"velocity of panda_joint4"``: the limit active at the most of toppra's gridpoints)."""

    t: FloatArray
    q: FloatArray
    duration: float
    limiting: str


def _toppra() -> Any:
    try:
        import toppra
    except ImportError as exc:
        raise InvalidInputError("retiming needs the 'toppra' package (a dependency of forte): pip install toppra"
                                ) from exc
    toppra.setup_logging("WARNING")
    return toppra


def path_parameter(q: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The waypoints with repeats dropped and their cumulative C-space distance ``s``."""
    keep = np.r_[True, np.linalg.norm(np.diff(q, axis=0), axis=1) > 1e-9]
    q = q[keep]
    return q, np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(q, axis=0), axis=1))]


#: toppra's gridpoints along the path (at least; :data:`GRID_PER_KNOT` per knot on a longer path).
GRIDPOINTS = 201
#: toppra's gridpoints per knot of the spline.
GRID_PER_KNOT = 16
#: Largest C-space distance between two knots of the spline (rad or m).
KNOT_STEP = 0.1


def on_segments(q: FloatArray, step: float = KNOT_STEP) -> FloatArray:
    """The polyline ``q`` (M x n) with states inserted on its segments so that no two are more than
    ``step`` apart (its own states kept)."""
    parts = [q[:1]]
    for a, b in zip(q[:-1], q[1:], strict=True):
        m = max(1, int(np.ceil(np.linalg.norm(b - a) / step)))
        parts.append(a + (b - a) * (np.arange(1, m + 1) / m)[:, None])
    return np.vstack(parts)


def retime(robot: MobileManipulator, q_path: Any, samples: int = 30, limits: KinematicLimits | None = None,
           margin: float = 1.0) -> Timed:
    """The time-optimal law along ``q_path`` (M x nq) under the limits (module docstring),
    sampled at ``samples`` equal times over ``[0, duration]``, ``duration`` = toppra's x ``margin``."""
    q_path = np.atleast_2d(np.asarray(q_path, dtype=float))
    if q_path.ndim != 2 or q_path.shape[1] != robot.nq or not np.all(np.isfinite(q_path)):
        raise InvalidInputError(f"q_path: expected finite M x {robot.nq} waypoints, got shape {q_path.shape}")
    if not margin >= 1.0 or samples < 2:
        raise InvalidInputError(f"retime: expected margin >= 1 and samples >= 2, got {margin}, {samples}")
    joints = moving_joints(robot)
    vel, acc = (limits or KinematicLimits()).resolve(robot)
    vel, acc = vel[joints], acc[joints]
    waypoints, s = path_parameter(q_path[:, joints])
    if len(waypoints) < 2:
        return Timed(np.zeros(samples), np.repeat(q_path[:1], samples, axis=0), 0.0, "")
    waypoints, s = path_parameter(on_segments(waypoints))
    ta = _toppra()
    spline = ta.SplineInterpolator(s, waypoints)
    constraints = [ta.constraint.JointVelocityConstraint(np.column_stack([-vel, vel]))]
    if np.all(np.isfinite(acc)):
        constraints.append(ta.constraint.JointAccelerationConstraint(np.column_stack([-acc, acc])))
    grid = np.linspace(0.0, s[-1], max(GRIDPOINTS, GRID_PER_KNOT * (len(s) - 1) + 1))  # toppra's own: ~0.5 s
    instance = ta.algorithm.TOPPRA(constraints, spline, gridpoints=grid, parametrizer="ParametrizeConstAccel")
    trajectory = instance.compute_trajectory(0.0, 0.0)
    if trajectory is None:
        raise InvalidInputError("retime: toppra found no time law along the path (limits too tight?)")
    base = float(trajectory.duration)
    t = np.linspace(0.0, base * margin, samples)
    q = np.repeat(q_path[:1], samples, axis=0)
    q[:, joints] = trajectory(t / margin)
    q[-1, joints] = waypoints[-1]  # exactly the goal
    names = [*(BASE_NAMES[j] for j in joints if j < len(BASE_NAMES)), *robot.arm_joints]
    return Timed(t, q, base * margin, _limiting(instance, spline, vel, acc, names))


def _limiting(instance: Any, spline: Any, vel: FloatArray, acc: FloatArray, names: list[str]) -> str:
    """The limit used to :data:`ACTIVE` at the most gridpoints (else the most used at any)."""
    sdd, sd, _, _ = instance.compute_parameterization(0.0, 0.0, return_data=True)
    grid = instance.gridpoints
    d1, d2 = spline(grid, 1), spline(grid, 2)
    sdd = np.r_[sdd, sdd[-1]]  # one fewer interval than gridpoints
    use_v = np.abs(d1 * sd[:, None]) / vel
    use_a = np.abs(d2 * sd[:, None] ** 2 + d1 * sdd[:, None]) / acc
    use = np.column_stack([use_v, use_a])
    labels = [f"velocity of {n}" for n in names] + [f"acceleration of {n}" for n in names]
    active = [labels[int(np.argmax(row))] for row in use if row.max() >= ACTIVE]
    if active:
        return Counter(active).most_common(1)[0][0]
    return labels[int(np.argmax(use.max(axis=0)))]
