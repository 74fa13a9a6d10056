"""The task force the arm's feedforward applies: a payload's force along the executed reference.

A payload plan's task force at its waypoints is the paper's ``f_k = m (p''_k - g)``, ``p''_k`` the
backward differences of the hand's path (:mod:`forte.force.taskforce`). The arm executes the
clamped spline through the waypoints, whose hand accelerates differently (the backward differences
lag the spline by about one step). Fed forward as planned, linear between the waypoints, the
payload's inertial force arrives late: on MotionBenchMaker's table_under_pick 0049 with 1.5 kg (a
3.4 s route on 30 waypoints 0.12 s apart) joint 1 lagged its reference by 8 mrad, the hand by
10 mm, and ``panda_link5`` touched the table the plan cleared by 2.8 mm. The same formula on the
reference's own hand acceleration, ``m (p''_ref(t) - g)``, tracked the hand to 1.3 mm, no touch.

- :func:`carried_mass`: ``m`` when the plan's force is ``m (p'' - g)`` at every waypoint (to
  round-off), else ``None``: a given force profile, a contact task, another force model keep the
  plan's force, linear in time (:func:`~forte.execution.control.interpolate_force`); so does a
  payload off the hand, whose planned moment goes with its planned force (on the offset-payload
  example the reference's force with the waypoints' moment tracked worse: 3.1 against 2.9 mm).
- :func:`along_reference`: ``m (p''_ref - g)`` at the reference's samples, ``p''_ref`` the second
  differences of the hand's positions on the control grid (the spline is C2; at 1 kHz they are
  its acceleration to ~1e-6 m/s^2).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from forte.model.trajectory import backward_differences
from forte.validation import FloatArray

#: How closely (relative to the largest force) ``f_k`` must equal ``m (p''_k - g)``.
MOTION_FORCE_TOL = 1e-6


def gravity_vector(robot: Any) -> FloatArray:
    """``g`` of ``robot``'s world, ``[0, 0, -robot.gravity]``."""
    return np.array([0.0, 0.0, -float(robot.gravity)])


def hand_positions(robot: Any, q: Any) -> FloatArray:
    """World end-effector positions (K x 3) of whole-body configurations ``q`` (K x nq)."""
    return np.array([robot.ee_pose(qk)[:3, 3] for qk in np.atleast_2d(np.asarray(q, dtype=float))])


def carried_mass(robot: Any, t: Any, q: Any, force: Any) -> float | None:
    """``m`` with ``force[k] = m (p''_k - g)`` at every waypoint (``p''_k``: the backward
    differences of the hand's path from rest), by least squares, when the fit holds to
    :data:`MOTION_FORCE_TOL`; else ``None``."""
    f = np.asarray(force, dtype=float)
    _, acc = backward_differences(hand_positions(robot, q), t, "hand")
    a = acc - gravity_vector(robot)
    m = float(np.sum(f * a) / np.sum(a * a))
    scale = max(1.0, float(np.max(np.abs(f))))
    return m if m > 0 and float(np.max(np.abs(f - m * a))) <= MOTION_FORCE_TOL * scale else None


def along_reference(robot: Any, times: Any, q: Any, mass: float) -> FloatArray:
    """``mass (p''(t) - g)`` (T x 3) along the reference ``q`` (T x nq) at equally spaced ``times``
    (held at the ends: the reference starts and ends at rest)."""
    ts = np.asarray(times, dtype=float)
    p = hand_positions(robot, q)
    acc = np.zeros_like(p)
    if ts.size >= 3:
        dt = float(ts[1] - ts[0])
        acc[1:-1] = (p[2:] - 2 * p[1:-1] + p[:-2]) / dt**2
        acc[0], acc[-1] = acc[1], acc[-2]
    return mass * (acc - gravity_vector(robot))
