"""The first waypoint's motion in the NLP: a horizon that starts moving, not at rest.

The stage windows ``[q_{k-2}; q_{k-1}; q_k]`` of the first two waypoints reach before the
horizon. At rest (every plan of a task file) those configurations are the first one, ``q_1``:
the windows' indices are clamped to it (:meth:`~forte.planning.nlp.optimizer.TrajectoryOptimizer._window_index`).
A horizon spliced into a moving plan (:meth:`~forte.planning.online.replan.Replanner.shift`) starts
with a :class:`~forte.model.trajectory.StartMotion` ``(v_1, a_1)``; its samples before ``q_1``
are :func:`~forte.model.trajectory.start_history`'s, one step ``h = t_2 - t_1`` apart:

    q_0 = q_1 - v_1 h,    q_{-1} = q_0 - (v_1 - a_1 h) h.

Both solvers keep the clamped indices (so the structure, the derivatives' scatter and the
elimination of the fixed ``q_1`` stay as they are) and add the *offsets* ``q_{-1} - q_1`` and
``q_0 - q_1`` to the windows' values (an NLP parameter, zero at rest: then the values are
exactly the clamped ones). The derivatives that land on the clamped slots belong to the fixed
``q_1`` and are eliminated, as before. The time steps before the horizon are ``h`` (the
parameter ``dt_1``, 1 at rest, where it only divides zeros). One row changes: the first
acceleration row ``dq_2 - dq_1`` with ``dq_1 = v_1`` instead of 0, so its bounds move by ``v_1``
(:func:`acceleration_shift`). Only a trajectory task with its first waypoint fixed has a start
motion (a hold task's first configuration is free).
"""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np

from forte.exceptions import InvalidInputError
from forte.model.trajectory import StartMotion, start_history
from forte.validation import FloatArray


def history_step(t: FloatArray) -> float:
    """``h``: the spacing of the samples before the horizon (its first step)."""
    return float(t[1] - t[0])


def check_start(fix_initial: bool, n: int, start: StartMotion | None) -> None:
    """A start motion needs a horizon of two waypoints or more with a fixed first one."""
    if start is not None and (not fix_initial or n < 2):
        raise InvalidInputError("start: a start motion needs a trajectory (a fixed first waypoint and N >= 2)")


def history_parameters(fix_initial: bool, n: int, nq: int, t: FloatArray, start: StartMotion | None
                       ) -> tuple[FloatArray, FloatArray]:
    """The parameters ``dt`` (N; ``dt_1 = h`` with a start motion, else 1) and the offsets
    ``[q_{-1} - q_1; q_0 - q_1]`` (2 x nq; zero at rest) of an NLP of ``n`` waypoints."""
    check_start(fix_initial, n, start)
    dt = np.ones(n)
    dt[1:] = np.diff(t)
    if start is None:
        return dt, np.zeros((2, nq))
    dt[0] = history_step(t)
    return dt, start_history(np.zeros(nq), start, dt[0])


def history_windows(offsets: Any, nq: int, n: int) -> Any:
    """The offsets in window form (3nq x n, CasADi): ``[o_{-1}; o_0; 0]`` at the first waypoint,
    ``[o_0; 0; 0]`` at the second, zero after (``offsets`` = ``[o_{-1}; o_0]``, 2nq)."""
    zero = ca.MX(nq, 1)
    first = ca.vertcat(offsets, zero)
    if n == 1:
        return first
    return ca.horzcat(first, ca.vertcat(offsets[nq:], zero, zero), ca.MX(3 * nq, n - 2))


def add_history(windows: FloatArray, offsets: FloatArray) -> FloatArray:
    """The NumPy windows (n x 3nq) with the offsets (2 x nq) added, as :func:`history_windows`."""
    nq = offsets.shape[1]
    windows[0, : 2 * nq] += offsets.ravel()
    if windows.shape[0] > 1:
        windows[1, :nq] += offsets[1]
    return windows


def acceleration_shift(start: StartMotion | None, rows: FloatArray) -> FloatArray | None:
    """What the first acceleration rows' bounds move by (``v_1`` of the rows' dofs), None at rest."""
    return None if start is None else np.asarray(start.velocity, dtype=float)[rows]


def shifted_acceleration_bounds(bounds: tuple[FloatArray, FloatArray], start: StartMotion | None, first: int,
                                rows: FloatArray) -> tuple[FloatArray, FloatArray]:
    """IPOPT's kinematic row bounds (:func:`~forte.planning.nlp.layout.kinematic_bounds`) with the
    first step's acceleration rows (from index ``first``, one per dof of ``rows``) moved by ``v_1``."""
    shift = acceleration_shift(start, rows)
    if shift is None or not shift.size:
        return bounds
    lower, upper = bounds[0].copy(), bounds[1].copy()
    lower[first:first + shift.size] += shift
    upper[first:first + shift.size] += shift
    return lower, upper
