"""Velocity and acceleration rows on the executed spline: the motion where the robot runs it.

The NLP's kinematic rows bound the backward differences at the waypoints (the paper's view of the
motion). ``forte simulate`` and every export execute the clamped cubic spline through the
waypoints (:func:`~forte.model.trajectory.clamped_spline`: zero slope at the last knot, the start's
velocity or zero at the first, the plan's own knot times), whose accelerations differ: a
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

Velocity (:func:`velocity_rows`): on a segment of length ``h`` with secant slope ``s`` and knot
accelerations ``a_0, a_1`` the spline's velocity is the quadratic

    v(u) = s + h (a_0 (u - u^2/2 - 1/3) + a_1 (u^2/2 - 1/6)),   u = (t - t_k) / h in [0, 1],

whose Bernstein control points are ``v_0 = s - h (2 a_0 + a_1) / 6``, ``s + h (a_0 - a_1) / 6``
and ``v_1 = s + h (a_0 + 2 a_1) / 6``: linear in ``q`` and the knot accelerations. A Bernstein
polynomial lies in the convex hull of its control points, so bounding them by ``v_max`` bounds
the executed velocity on the whole segment (not only at the samples the verdict takes). The bound
is exact where the acceleration keeps its sign on the segment (the velocity is monotone and the
middle point lies between the ends); where it changes sign the middle point exceeds the true peak
by ``h |a_0| |a_1| / (2 (|a_0| + |a_1|)) <= h |a_1 - a_0| / 8``. Split into ``p`` equal pieces
(:data:`VELOCITY_PIECES`; each piece's control points, ``2 p`` rows a segment) the excess is at
most ``h |a_1 - a_0| / (8 p^2)``. Measured cost of the conservatism: none on the raw Kinova's
reaches, which ride their 0.628 rad/s limits (12 of 12 feasible in the first solve, each riding its
limit at 1.000 x on the spline). The NLP gives the arm these rows, not the base
(:class:`SplineCoordinates`, :meth:`~forte.planning.nlp.structure.NlpStructure._knot_variables`).

Waypoint rows they imply (:meth:`SplineCoordinates.implied`): a Bernstein polynomial's mean is
its control points' mean, ``(v_0 + v_m + v_1) / 3 = s``, so ``|s| <= v_max`` (the waypoint
velocity row ``|q_{k+1} - q_k| <= v_max h_k``) follows from the velocity rows, on every segment
after the first, and on the first too when ``|v_1| <= v_max``. The continuity row at knot ``k``
gives ``6 (s_k - s_{k-1}) / H_k = (h_{k-1} a_{k-1} + h_k a_{k+1}) / H_k + 2 a_k``, so
``|s_k - s_{k-1}| <= a_max H_k / 2``: the waypoint acceleration row (``<= a_max h_k``) follows
where ``h_{k-1} <= h_k`` (equal steps: every knot), and the first (``|s_1 - v_1| <= a_max h_1``)
from the first row's ``a_max h_1 / 2``. A given path's NLP leaves those rows out
(:func:`~forte.planning.nlp.ipopt_nlp.kinematic_rows`; the lift at N = 100: 1386 of 4673 rows,
IPOPT's CPU time 0.21 -> 0.16 s, the plan within 6e-10), and builds them back on a grid or a
start where they do not follow (:meth:`~forte.planning.nlp.optimizer.TrajectoryOptimizer.solve`).
"""

from __future__ import annotations

from typing import NamedTuple

import casadi as ca
import numpy as np

from forte.model.robot import N_BASE
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


#: Equal pieces per segment whose Bernstein control points bound the velocity (:func:`velocity_points`).
VELOCITY_PIECES = 1


def velocity_points(pieces: int = VELOCITY_PIECES) -> FloatArray:
    """Coefficients ``(alpha, beta)`` (2 p x 2) of the control points ``s + h (alpha a_0 + beta a_1)``
    of a segment's velocity cut into ``pieces`` equal pieces (module docstring), piece by piece: its
    middle point, then its end. On ``[u, u + d]`` the end is ``v(u + d)`` and the middle point
    ``v(u) + h d v'(u) / 2`` with ``v'(u) = a_0 + (a_1 - a_0) u``."""
    rows = []
    d = 1.0 / pieces
    for i in range(pieces):
        u, e = i * d, (i + 1) * d
        rows.append((u - u * u / 2 - 1 / 3 + d * (1 - u) / 2, u * u / 2 - 1 / 6 + d * u / 2))
        rows.append((e - e * e / 2 - 1 / 3, e * e / 2 - 1 / 6))
    return np.array(rows)


def velocity_rows(X: ca.MX, A: ca.MX, h: ca.MX, coordinates: list[int], pieces: int = VELOCITY_PIECES) -> ca.MX:
    """The Bernstein control points of the clamped spline's velocity (module docstring) of the
    ``coordinates`` rows of ``X`` (nq x N) with knot accelerations ``A`` (len(coordinates) x N;
    ``h``: 1 x N-1, the intervals), times their segment's ``h``: ``q_{k+1} - q_k + h^2 (alpha a_0 +
    beta a_1)``, in the kinematic rows' units (``q_k - q_{k-1}`` within ``v_max dt``; rows in rad/s
    cost the same: 826 vs 835 IPOPT iterations on 28 MotionBenchMaker goals, 761 without velocity
    rows, the same 34 of 35 feasible). ``vec``'d segment by segment, piece by piece; each row reaches 2
    waypoints and 2 accelerations. Not the first knot's velocity (the start's, fixed) nor the last's
    (0): ``(2 p (N - 1) - 1) len(coordinates)`` rows, bounded by :func:`velocity_bounds`."""
    Q = X[coordinates, :]
    H = ca.repmat(h, len(coordinates), 1)
    step, H2 = Q[:, 1:] - Q[:, :-1], H * H
    a0, a1 = A[:, :-1], A[:, 1:]
    points = ca.vertcat(*[step + H2 * (float(alpha) * a0 + float(beta) * a1)
                          for alpha, beta in velocity_points(pieces)])
    rows = ca.vec(points)
    return rows[: rows.numel() - len(coordinates)]


def velocity_bounds(limits: FloatArray, t: FloatArray, v_start: FloatArray | None = None,
                    pieces: int = VELOCITY_PIECES) -> tuple[FloatArray, FloatArray]:
    """``|row| <= v_max h`` of :func:`velocity_rows` on the times ``t`` (``limits``: the
    coordinates' ``v_max``). A start already faster than a limit (a measured start) keeps its own
    speed as the bound of the first piece's middle point, which it would otherwise make infeasible."""
    limits = np.asarray(limits, dtype=float)
    speed = np.tile(limits, (np.size(t) - 1, 2 * pieces, 1))  # segment x point x coordinate
    if v_start is not None:
        speed[0, 0] = np.maximum(limits, np.abs(np.asarray(v_start, dtype=float)))
    upper = (speed * np.diff(np.asarray(t, dtype=float))[:, None, None]).ravel()[: -limits.size]
    return -upper, upper


class SplineCoordinates(NamedTuple):
    """The coordinates the NLP follows on the executed spline, and which of its rows each gets.

    Attributes:
        coordinates: whole-body coordinates with knot-acceleration variables (ascending).
        velocity: positions in ``coordinates`` whose velocity rows :func:`velocity_rows` adds.
        acceleration: per coordinate, ``|a_k|``'s bound (``inf``: free, e.g. the base's, which
            the verdict does not judge on the spline).
        velocity_limits: the ``velocity`` coordinates' ``v_max``.
    """

    coordinates: list[int]
    velocity: list[int]
    acceleration: FloatArray
    velocity_limits: FloatArray

    @classmethod
    def of(cls, velocity: FloatArray, acceleration: FloatArray, with_base: bool) -> SplineCoordinates:
        """From the whole-body limits (``inf``: none): every arm joint with a finite velocity or
        acceleration limit, and with ``with_base`` the base's coordinates with a velocity limit."""
        nq = len(velocity)
        arm = np.arange(nq) >= N_BASE
        fast = np.isfinite(velocity) & (arm | with_base)
        limited = np.isfinite(acceleration) & arm
        coordinates = [int(i) for i in np.flatnonzero(fast | limited)]
        return cls(coordinates, [j for j, i in enumerate(coordinates) if fast[i]],
                   np.where(limited, acceleration, np.inf)[coordinates], np.asarray(velocity, float)[fast])

    def covered(self) -> tuple[list[int], list[int]]:
        """The whole-body coordinates whose waypoint velocity rows, and whose waypoint acceleration
        rows, these rows imply (module docstring) where :meth:`implied` says so."""
        return ([self.coordinates[j] for j in self.velocity],
                [c for c, a in zip(self.coordinates, self.acceleration, strict=True) if np.isfinite(a)])

    def implied(self, t: FloatArray, v_start: FloatArray | None, rtol: float = 1e-9) -> bool:
        """Whether these rows imply the :meth:`covered` coordinates' waypoint rows on the times
        ``t`` (``v_start``: the coordinates' start velocity, ``None`` at rest): no step shorter than
        the one before it (``rtol`` relative, for round-off) and no start faster than its limit."""
        h = np.diff(np.asarray(t, dtype=float))
        if np.any(h[:-1] > h[1:] * (1 + rtol)):
            return False
        if v_start is None or not self.velocity:
            return True
        start = np.abs(np.asarray(v_start, dtype=float)[self.velocity])
        return bool(np.all(start <= self.velocity_limits))

    def rows(self, X: ca.MX, A: ca.MX, h: ca.MX) -> ca.MX:
        """The continuity rows (:func:`spline_rows`), then the velocity rows (:func:`velocity_rows`)."""
        velocity = velocity_rows(X, A[self.velocity, :], h, [self.coordinates[j] for j in self.velocity]) \
            if self.velocity else ca.MX(0, 1)
        return ca.vertcat(spline_rows(X, A, h, self.coordinates), velocity)

    def bounds(self, t: FloatArray, v_start: FloatArray | None) -> tuple[FloatArray, FloatArray]:
        """The bounds of :meth:`rows` on the times ``t`` (``v_start``: the coordinates' start velocity)."""
        low, high = spline_bounds(t, v_start, len(self.coordinates))
        if not self.velocity:
            return low, high
        start = None if v_start is None else np.asarray(v_start, dtype=float)[self.velocity]
        v_low, v_high = velocity_bounds(self.velocity_limits, t, start)
        return np.concatenate([low, v_low]), np.concatenate([high, v_high])
