"""Acceleration rows on the executed spline: the arm's accelerations where the robot runs them.

The NLP's kinematic rows bound the backward differences at the waypoints (the paper's view of the
motion). ``forte simulate`` and every export execute the clamped cubic spline through the
waypoints (:func:`~forte.model.trajectory.clamped_spline`), whose accelerations differ: a
weighted sum of the second differences around each knot, up to 3 x the largest of them
(alternating second differences; ``6 (1, 4, 1)^{-1}`` on equal steps has absolute row sum 3). A
plan riding an acceleration limit at its waypoints overshoots it on the spline, and the verdict
sends it back for a refinement round (:func:`forte.planning.rounds.refine`).

Exact rows instead of a round: the spline's knot slopes solve a linear system in ``q`` and the
start velocity ``v_1``, so its acceleration at knot ``k`` is linear too,

    a_k = sum_j S_kj q_j + c_k v_1,

with ``S`` and ``c`` fixed by the times alone (:func:`knot_acceleration_operator`). A cubic's
acceleration is linear in time between knots and the spline is C2, so ``|a_k| <= a_max`` at
every knot bounds the executed acceleration everywhere: the rows hold exactly what the verdict's
``acceleration`` requirement checks (the coordinates of a plan that rests at a joint limit are
executed on a shorter spline, :func:`~forte.model.trajectory.limit_rests`; the verdict judges
those as before). The times are an NLP parameter, so ``S`` is one too (dense: N^2 values, every knot's row reaches
every waypoint of its coordinate, with weights that fall by 2 - sqrt(3) = 0.27 per step); ``c_k v_1``
moves the bounds (:func:`spline_bounds`).
"""

from __future__ import annotations

from typing import NamedTuple

import casadi as ca
import numpy as np

from forte.model.trajectory import clamped_spline
from forte.validation import FloatArray


class KnotOperator(NamedTuple):
    """The clamped spline's knot accelerations ``a = S q + c v_1`` (per coordinate).

    Attributes:
        S: N x N, ``S[k, j]`` the acceleration at knot ``k`` of unit data at knot ``j``.
        c: N, the accelerations of a unit start velocity through all-zero data.
    """

    S: FloatArray
    c: FloatArray


def knot_acceleration_operator(t: FloatArray) -> KnotOperator:
    """:class:`KnotOperator` of the clamped spline on the times ``t`` (N >= 2), computed by the
    spline itself on unit data (it is linear in its data)."""
    t = np.asarray(t, dtype=float)
    n = t.size
    _, _, S = clamped_spline(t, np.eye(n), t)
    _, _, c = clamped_spline(t, np.zeros((n, 1)), t, np.ones(1))
    return KnotOperator(S, c[:, 0])


def spline_rows(X: ca.MX, S: ca.MX, coordinates: list[int]) -> ca.MX:
    """``vec`` of the knot accelerations ``S q`` of the ``coordinates`` rows of ``X`` (nq x N;
    ``S``: N x N, a parameter), knot by knot."""
    return ca.vec(ca.mtimes(X[coordinates, :], S.T))


def spline_bounds(limits: FloatArray, c: FloatArray, v_start: FloatArray | None) -> tuple[FloatArray, FloatArray]:
    """``-a_max - c_k v_1 <= S q <= a_max - c_k v_1`` of :func:`spline_rows` (``limits``: the
    coordinates' ``a_max``, in row order; ``v_start``: theirs, ``None`` at rest)."""
    limits = np.asarray(limits, dtype=float)
    shift = np.zeros((limits.size, c.size)) if v_start is None else np.outer(v_start, c)
    upper = (limits[:, None] - shift).ravel(order="F")
    lower = (-limits[:, None] - shift).ravel(order="F")
    return lower, upper
