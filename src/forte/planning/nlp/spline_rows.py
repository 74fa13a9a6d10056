"""Acceleration rows on the executed spline: the arm's accelerations where the robot runs them.

The NLP's kinematic rows bound the backward differences at the waypoints (the paper's view of the
motion). ``forte simulate`` and every export execute the clamped cubic spline through the
waypoints (:func:`~forte.model.trajectory.clamped_spline`), whose accelerations differ: a
weighted sum of the second differences around each knot, up to 3 x the largest of them
(alternating second differences; ``6 (1, 4, 1)^{-1}`` on equal steps has absolute row sum 3). A
plan riding an acceleration limit at its waypoints overshoots it on the spline, and the verdict
sends it back for a refinement round (:func:`forte.planning.rounds.refine`).

Exact rows instead of a round: the spline's knot slopes ``m`` solve a tridiagonal linear system
in ``q`` and the start velocity ``v_1``, so its acceleration at knot ``k`` is linear too,

    a_k = sum_j S_kj q_j + c_k v_1,

with ``S`` and ``c`` fixed by the times alone (:func:`knot_acceleration_operator`). A cubic's
acceleration is linear in time between knots and the spline is C2, so ``|a_k| <= a_max`` at
every knot bounds the executed acceleration everywhere: the rows hold exactly what the verdict's
``acceleration`` requirement checks (the coordinates of a plan that rests at a joint limit are
executed on a shorter spline, :func:`~forte.model.trajectory.limit_rests`; the verdict judges
those as before). ``S`` is dense (every knot reaches every waypoint of its coordinate, with
weights that fall by 2 - sqrt(3) = 0.27 per step), and dense rows fill the KKT factorization;
the NLP keeps the knot accelerations as bounded variables instead, tied to ``q`` by the spline's
continuity rows (:func:`spline_rows`: each row reaches 3 accelerations and 3 waypoints). The same
accelerations; on 16 MotionBenchMaker goals ~20 % less time per IPOPT iteration than ``S q``
(slopes as the variables instead were slower, with more iterations).
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


def spline_rows(X: ca.MX, A: ca.MX, h: ca.MX, coordinates: list[int]) -> ca.MX:
    """The rows that make ``A`` (len(coordinates) x N, NLP variables) the knot accelerations of
    the clamped spline through the ``coordinates`` rows of ``X`` (nq x N; ``h``: 1 x N-1, the
    intervals, a parameter), ``vec``'d knot by knot.

    With ``s_k = (q_{k+1} - q_k) / h_k`` and ``H_k = h_{k-1} + h_k``, the spline is C2 at the
    interior knots when ``(h_{k-1} a_{k-1} + h_k a_{k+1}) / H_k + 2 a_k - 6 (s_k - s_{k-1}) / H_k = 0``,
    and its end slopes are ``v_1`` and 0 when ``2 a_1 + a_2 - 6 s_1 / h_1 = -6 v_1 / h_1`` and
    ``a_{N-1} + 2 a_N + 6 s_{N-1} / h_{N-1} = 0`` (:func:`spline_bounds`). Every row reaches 3
    accelerations and 3 waypoints instead of the dense ``S q``'s N, and ``|a_k| <= a_max`` are
    the variables' bounds (:func:`knot_bounds`): the KKT system stays banded."""
    Q = X[coordinates, :]
    H = ca.repmat(h, len(coordinates), 1)
    s = (Q[:, 1:] - Q[:, :-1]) / H
    before, after = H[:, :-1], H[:, 1:]
    inner = ((before * A[:, :-2] + after * A[:, 2:] - 6 * (s[:, 1:] - s[:, :-1])) / (before + after)
             + 2 * A[:, 1:-1])
    first = 2 * A[:, 0] + A[:, 1] - 6 * s[:, 0] / H[:, 0]
    last = A[:, -2] + 2 * A[:, -1] + 6 * s[:, -1] / H[:, -1]
    return ca.vec(ca.horzcat(first, inner, last))


def spline_bounds(t: FloatArray, v_start: FloatArray | None, count: int) -> tuple[FloatArray, FloatArray]:
    """Both bounds of :func:`spline_rows` (equalities): ``-6 v_1 / h_1`` on the first knot's rows
    (``v_start``: the ``count`` coordinates' start velocity, ``None`` at rest), 0 elsewhere."""
    t = np.asarray(t, dtype=float)
    value = np.zeros((t.size, count))
    if v_start is not None:
        value[0] = -6 * np.asarray(v_start, dtype=float) / (t[1] - t[0])
    return value.ravel(), value.ravel()


def knot_bounds(limits: FloatArray, n: int) -> tuple[FloatArray, FloatArray]:
    """``|a_k| <= a_max`` of the knot accelerations (``limits``: the coordinates' ``a_max``;
    ``n`` knots, coordinate fastest)."""
    upper = np.tile(np.asarray(limits, dtype=float), n)
    return -upper, upper


def knot_accelerations(t: FloatArray, q: FloatArray, v_start: FloatArray | None) -> FloatArray:
    """The clamped spline's accelerations at its knots (N x coordinates) through ``q`` (N x coordinates)."""
    return clamped_spline(t, q, t, v_start)[2]
