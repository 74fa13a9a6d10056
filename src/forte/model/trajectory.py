"""Time-stamped trajectories: the paper's backward finite differences and quintic paths.

Section 3.2 of the paper approximates velocities and accelerations by backward differences::

    v_k = (x_k - x_{k-1}) / dt_k,    a_k = (v_k - v_{k-1}) / dt_k,    dt_k = t_k - t_{k-1}.

The formulas need the samples before ``k = 1``. By default forte assumes the trajectory starts
at rest: ``v_1 = 0`` and ``a_1 = 0``, so ``a_2 = v_2 / dt_2``. A trajectory that starts in motion
(a receding horizon spliced into a moving plan) has a :class:`StartMotion` ``(v_1, a_1)``; its
samples before ``k = 1`` are then the two of :func:`start_history`, one step ``dt_2`` apart, whose
backward differences give ``v_1`` and ``a_1`` (and ``a_2 = (v_2 - v_1) / dt_2``). The same rule
serves the end-effector positions (task force, Section 4.1) and the arm joints (nominal torques,
Section 3.2).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np

from forte.exceptions import InvalidInputError
from forte.validation import FloatArray, as_array, check_times


def trajectory_header(n_arm: int) -> list[str]:
    """``t, x_b, y_b, yaw, q1..qn``: the columns of a plan's ``trajectory.csv``."""
    return ["t", "x_b", "y_b", "yaw", *(f"q{i}" for i in range(1, n_arm + 1))]


class StartMotion(NamedTuple):
    """Velocity and acceleration (backward differences) at a trajectory's first sample; ``None``
    in their place everywhere means "at rest"."""

    velocity: FloatArray  # d
    acceleration: FloatArray  # d

    def columns(self, part: slice) -> StartMotion:
        """The motion of some coordinates (e.g. the arm's, ``slice(3, None)``)."""
        return StartMotion(self.velocity[part], self.acceleration[part])

    @staticmethod
    def checked(velocity: Any, acceleration: Any, size: int, name: str = "start") -> StartMotion:
        """A start motion of ``size`` coordinates, validated (finite)."""
        return StartMotion(as_array(velocity, f"{name}.velocity", (size,)),
                           as_array(acceleration, f"{name}.acceleration", (size,)))


def start_history(x0: Any, start: StartMotion | None, h: float) -> FloatArray:
    """The two samples ``[x_{-1}; x_0]`` before the first ``x_1 = x0``, ``h`` apart (2 x d), whose
    backward differences give ``start``: ``x_0 = x_1 - v h``, ``x_{-1} = x_0 - (v - a h) h``; at
    rest (``start`` ``None``) both are ``x0``."""
    x0 = np.asarray(x0, dtype=float)
    if start is None:
        return np.stack([x0, x0])
    before = x0 - start.velocity * h
    return np.stack([before - (start.velocity - start.acceleration * h) * h, before])


def start_of(samples: Any, h: float) -> StartMotion:
    """The start motion of ``[x_{-1}; x_0; x_1]`` (3 x d, ``h`` apart): the inverse of
    :func:`start_history` (e.g. the end effector's, from its positions at a start history)."""
    s = np.asarray(samples, dtype=float)
    v, before = (s[2] - s[1]) / h, (s[1] - s[0]) / h
    return StartMotion(v, (v - before) / h)


def start_through(position: Callable[[FloatArray], FloatArray], x0: Any, start: StartMotion | None,
                  h: float) -> StartMotion | None:
    """The start motion of ``position(x)`` (e.g. the end effector's) while ``x`` starts at ``x0``
    with ``start``: :func:`start_of` its values along :func:`start_history`."""
    if start is None:
        return None
    return start_of([position(x) for x in (*start_history(x0, start, h), np.asarray(x0, dtype=float))], h)


def motion_at(x: Any, t: Any, k: int, start: StartMotion | None = None) -> StartMotion:
    """The backward-difference velocity and acceleration of samples ``x`` at sample ``k`` (from the
    samples ``k - 2 .. k``; ``start``: the motion at sample 0, default at rest): where a trajectory
    spliced in at ``k`` starts moving."""
    lo = max(k - 2, 0)
    v, a = backward_differences(np.asarray(x)[lo:k + 1], np.asarray(t)[lo:k + 1], "x", start if lo == 0 else None)
    return StartMotion(v[-1], a[-1])


def backward_differences(x: Any, t: Any, name: str = "x",
                         start: StartMotion | None = None) -> tuple[FloatArray, FloatArray]:
    """Velocities and accelerations of samples ``x`` (N x d) at times ``t`` (N).

    Returns:
        ``(v, a)``, each N x d, with ``v[0], a[0]`` the ``start`` motion (default: 0, at rest).
    """
    times = check_times(t, "t")
    samples = as_array(x, name, (times.size, None))
    v = np.zeros_like(samples)
    a = np.zeros_like(samples)
    if start is not None:
        v[0], a[0] = start.velocity, start.acceleration
    if times.size > 1:
        dt = np.diff(times)[:, None]
        v[1:] = np.diff(samples, axis=0) / dt
        a[1:] = np.diff(v, axis=0) / dt
    return v, a


def quintic_blend(s: FloatArray) -> FloatArray:
    """Minimum-jerk time scaling ``10 s^3 - 15 s^4 + 6 s^5`` on ``s`` in [0, 1]."""
    return 10 * s**3 - 15 * s**4 + 6 * s**5


def quintic_path(knot_times: Any, knots: Any, times: Any) -> FloatArray:
    """Piecewise quintic (rest-to-rest) interpolation of ``knots`` (K x d) at ``times``.

    Each segment between consecutive knots uses the minimum-jerk blend, so velocity and
    acceleration are zero at every knot.
    """
    kt = check_times(knot_times, "knot_times")
    values = as_array(knots, "knots", (kt.size, None))
    ts = as_array(times, "times", (None,))
    if ts.min() < kt[0] - 1e-12 or ts.max() > kt[-1] + 1e-12:
        raise InvalidInputError(f"times: expected values within [{kt[0]}, {kt[-1]}]")
    seg = np.clip(np.searchsorted(kt, ts, side="right") - 1, 0, max(kt.size - 2, 0))
    if kt.size == 1:
        return np.repeat(values, ts.size, axis=0)
    s = np.clip((ts - kt[seg]) / (kt[seg + 1] - kt[seg]), 0.0, 1.0)
    w = quintic_blend(s)[:, None]
    return values[seg] + w * (values[seg + 1] - values[seg])


def quintic_hermite(t_knots: Any, q: Any, v: Any, a: Any, times: Any) -> tuple[Any, Any, Any]:
    """Piecewise quintic through ``(t_k, q_k)`` with velocity ``v_k`` and acceleration ``a_k`` at
    every knot; returns position, velocity and acceleration at ``times`` (knots held outside)."""
    tk = check_times(t_knots, "t")
    ts = as_array(times, "times", (None,))
    seg = np.clip(np.searchsorted(tk, ts, side="right") - 1, 0, tk.size - 2)
    h = (tk[seg + 1] - tk[seg])[:, None]
    s = (np.clip(ts, tk[0], tk[-1]) - tk[seg])[:, None] / h
    p0, p1, v0, v1, a0, a1 = q[seg], q[seg + 1], v[seg] * h, v[seg + 1] * h, a[seg] * h**2, a[seg + 1] * h**2
    # coefficients of p(s) = sum c_i s^i on s in [0, 1] (velocities and accelerations in s units)
    c3 = 10 * (p1 - p0) - 6 * v0 - 4 * v1 - 1.5 * a0 + 0.5 * a1
    c4 = -15 * (p1 - p0) + 8 * v0 + 7 * v1 + 1.5 * a0 - a1
    c5 = 6 * (p1 - p0) - 3 * v0 - 3 * v1 - 0.5 * a0 + 0.5 * a1
    pos = p0 + s * (v0 + s * (a0 / 2 + s * (c3 + s * (c4 + s * c5))))
    vel = (v0 + s * (a0 + s * (3 * c3 + s * (4 * c4 + s * 5 * c5)))) / h
    acc = (a0 + s * (6 * c3 + s * (12 * c4 + s * 20 * c5))) / h**2
    outside = ((ts < tk[0]) | (ts > tk[-1]))[:, None]
    return pos, np.where(outside, 0.0, vel), np.where(outside, 0.0, acc)


#: A coordinate whose rest is within this (rad, m) of one of its limits rests "at" it
#: (:func:`limit_rests`): goals sit at or just inside a limit (MotionBenchMaker's at 0-9 mrad), and the
#: spline's ring past the rest (up to 2.5 mrad measured there) would cross it.
LIMIT_REST_NEAR = 0.01
#: Knots within this of the last one (in every coordinate; the NLP ties them with equality rows
#: met to its tolerance) count as the motion's final rest.
REST_TOL = 1e-6


def resting_from(q: FloatArray) -> int:
    """The index of the first knot of the final rest: the first ``k`` with every later knot within
    :data:`REST_TOL` of the last (``len(q) - 1`` without a rest)."""
    moving = np.flatnonzero(np.max(np.abs(q - q[-1]), axis=1) > REST_TOL)
    return int(moving[-1]) + 1 if moving.size else 0


def clamped_spline(t_knots: Any, q: Any, times: Any, v_start: FloatArray | None = None,
                   limits: tuple[Any, Any] | None = None) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Clamped cubic spline through ``(t_k, q_k)`` (C2, zero velocity at both ends, or ``v_start``
    at the first knot) sampled at ``times``: position, velocity, acceleration; the first/last knot
    is held outside the knots' range (velocity and acceleration 0). One knot: held everywhere.

    With ``limits`` (lower, upper per coordinate): a coordinate that ends at rest (the last knots
    equal to the last, within :data:`REST_TOL`) at one of its limits (within :data:`LIMIT_REST_NEAR`)
    is clamped where the rest begins and holds it: through the rest's equal knots the C2 spline
    would ring past the rest, beyond the limit (:func:`limit_rests`).

    The knot slopes ``m_k`` solve the tridiagonal continuity system
    ``h_k m_{k-1} + 2 (h_{k-1} + h_k) m_k + h_{k-1} m_{k+1} = 3 (h_k s_{k-1} + h_{k-1} s_k)``
    (``h_k`` the intervals, ``s_k`` the secant slopes, ``m_0 = v_start`` or 0, ``m_N = 0``) by the Thomas
    algorithm; each interval is then the cubic Hermite through its ends (equal to SciPy's
    ``CubicSpline(..., bc_type="clamped")``, tested; written out because importing
    ``scipy.interpolate`` alone takes half a second of every ``forte plan``).
    """
    tk = check_times(t_knots, "t")
    qk = as_array(q, "q", (tk.size, None))
    ts = as_array(times, "times", (None,))
    pos, vel, acc = _spline(tk, qk, ts, v_start)
    rest = resting_from(qk)
    cols = limit_rests(qk, rest, limits)
    if cols.any():  # those coordinates: the spline up to the rest, then held
        v0 = None if v_start is None else np.asarray(v_start, dtype=float)[cols]
        pos[:, cols], vel[:, cols], acc[:, cols] = _spline(tk[:rest + 1], qk[:rest + 1, cols], ts, v0)
    return pos, vel, acc


def limit_rests(q: FloatArray, rest: int, limits: tuple[Any, Any] | None) -> FloatArray:
    """Per coordinate: whether it moves, then rests from knot ``rest`` on at one of its ``limits``
    (within :data:`LIMIT_REST_NEAR`)."""
    if limits is None or rest >= len(q) - 1:
        return np.zeros(q.shape[1], dtype=bool)
    lower, upper = (np.asarray(b, dtype=float) for b in limits)
    final = q[-1]
    return (np.ptp(q, axis=0) > REST_TOL) & ((final <= lower + LIMIT_REST_NEAR) | (final >= upper - LIMIT_REST_NEAR))


def joint_limits(robot: Any) -> tuple[FloatArray, FloatArray]:
    """Whole-body position limits: the base unbounded, the arm's joint range."""
    base = robot.nq - robot.n_arm
    return np.r_[np.full(base, -np.inf), robot.lower], np.r_[np.full(base, np.inf), robot.upper]


def _spline(tk: FloatArray, qk: FloatArray, ts: FloatArray,
            v_start: FloatArray | None) -> tuple[FloatArray, FloatArray, FloatArray]:
    """The clamped spline through every knot (see :func:`clamped_spline`)."""
    if tk.size == 1:
        pos = np.repeat(qk, ts.size, axis=0)
        return pos, np.zeros_like(pos), np.zeros_like(pos)
    m = _clamped_slopes(tk, qk, v_start)
    tc = np.clip(ts, tk[0], tk[-1])
    seg = np.clip(np.searchsorted(tk, tc, side="right") - 1, 0, tk.size - 2)
    h = (tk[seg + 1] - tk[seg])[:, None]
    x = (tc - tk[seg])[:, None]
    secant = (qk[seg + 1] - qk[seg]) / h
    c2 = (3 * secant - 2 * m[seg] - m[seg + 1]) / h
    c3 = (m[seg] + m[seg + 1] - 2 * secant) / h**2
    inside = ((ts >= tk[0]) & (ts <= tk[-1]))[:, None]
    pos = qk[seg] + x * (m[seg] + x * (c2 + x * c3))
    vel = m[seg] + x * (2 * c2 + 3 * c3 * x)
    return pos, np.where(inside, vel, 0.0), np.where(inside, 2 * c2 + 6 * c3 * x, 0.0)


def _clamped_slopes(tk: FloatArray, qk: FloatArray, v_start: FloatArray | None = None) -> FloatArray:
    """Knot slopes of the clamped cubic spline (see :func:`clamped_spline`)."""
    h = np.diff(tk)[:, None]
    secant = np.diff(qk, axis=0) / h
    m = np.zeros_like(qk)
    if v_start is not None:
        m[0] = v_start
    n = tk.size - 1  # unknowns m_1 .. m_{n-1}
    if n < 2:
        return m
    lower, diag, upper = h[1:], 2 * (h[:-1] + h[1:]), h[:-1]
    rhs = 3 * (h[1:] * secant[:-1] + h[:-1] * secant[1:])
    rhs[0] = rhs[0] - lower[0] * m[0]  # the known first slope's part of the first equation
    d, r = diag.copy(), rhs.copy()
    for k in range(1, n - 1):  # forward sweep
        w = lower[k] / d[k - 1]
        d[k] = d[k] - w * upper[k - 1]
        r[k] = r[k] - w * r[k - 1]
    x = np.empty_like(r)
    x[-1] = r[-1] / d[-1]
    for k in range(n - 3, -1, -1):  # back substitution
        x[k] = (r[k] - upper[k] * x[k + 1]) / d[k]
    m[1:-1] = x
    return m
