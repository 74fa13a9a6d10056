"""The NLP's velocity and acceleration rows on the executed spline (:mod:`forte.planning.nlp.spline_rows`)."""

from __future__ import annotations

import sys
from pathlib import Path

import casadi as ca
import numpy as np
from scipy.interpolate import CubicSpline

import forte
from forte.model.robot import N_BASE
from forte.planning.nlp.optimizer import TrajectoryOptimizer
from forte.planning.nlp.spline_rows import (
    SplineCoordinates,
    knot_acceleration_operator,
    knot_accelerations,
    knot_bounds,
    spline_bounds,
    spline_rows,
    velocity_bounds,
    velocity_rows,
)
from forte.planning.solve import goal_guess
from forte.planning.tasks.tasks import task_from_dict
from forte.planning.verdict.verdict import limit_ratios

sys.path.insert(0, str(Path(__file__).parent))
from test_goal_tasks import GOAL, panda_task  # noqa: E402
from test_planned_as_judged import _kinova  # noqa: E402


def test_the_knot_operator_gives_scipys_clamped_spline_accelerations():
    """``S q + c v_1`` at the knots equals SciPy's clamped spline (first derivative ``v_1`` at the
    start, 0 at the end), on uneven times; between knots the acceleration is linear, so the knots
    hold its extremes."""
    rng = np.random.default_rng(3)
    t = np.cumsum(np.r_[0.0, rng.uniform(0.05, 0.2, 13)])
    q = rng.normal(size=(t.size, 3))
    v1 = np.array([0.4, -1.0, 0.0])
    op = knot_acceleration_operator(t)
    for j in range(3):
        reference = CubicSpline(t, q[:, j], bc_type=((1, v1[j]), (1, 0.0)))
        np.testing.assert_allclose(op.S @ q[:, j] + op.c * v1[j], reference(t, 2), rtol=1e-9, atol=1e-9)
        dense = np.linspace(t[0], t[-1], 2001)
        assert np.max(np.abs(reference(dense, 2))) <= np.max(np.abs(reference(t, 2))) + 1e-9


def test_the_rows_hold_at_the_splines_knot_accelerations_and_the_start_velocity_moves_their_bounds():
    """At the clamped spline's own knot accelerations (start velocity ``v_1``, the dense operator
    ``S q + c v_1``) the rows equal their bounds; other accelerations break them; the variables'
    bounds are the limits."""
    rng = np.random.default_rng(4)
    t = np.cumsum(np.r_[0.0, rng.uniform(0.05, 0.2, 8)])
    q = rng.normal(size=(5, t.size))
    v1 = np.array([0.5, -0.3])
    X, A, h = ca.MX.sym("X", 5, t.size), ca.MX.sym("A", 2, t.size), ca.MX.sym("h", 1, t.size - 1)
    rows = ca.Function("rows", [X, A, h], [spline_rows(X, A, h, [1, 3])])
    op = knot_acceleration_operator(t)
    acc = np.stack([op.S @ q[j] + op.c * v for j, v in zip((1, 3), v1, strict=True)], axis=1)  # N x 2
    np.testing.assert_allclose(knot_accelerations(t, q[[1, 3]].T, v1), acc, atol=1e-8)
    lower, upper = spline_bounds(t, v1, 2)
    np.testing.assert_allclose(lower, upper)
    np.testing.assert_allclose(np.array(rows(q, acc.T, np.diff(t)[None])).ravel(), lower, atol=1e-8)
    assert np.any(lower[:2] != 0) and not np.any(lower[2:])
    wrong = acc.copy()
    wrong[4, 1] += 0.1
    assert np.max(np.abs(np.array(rows(q, wrong.T, np.diff(t)[None])).ravel() - lower)) > 0.05
    jac = ca.jacobian(spline_rows(X, A, h, [1, 3]), ca.vertcat(ca.vec(X), ca.vec(A))).sparsity()
    per_row = np.bincount(np.array(jac.get_triplet()[0]), minlength=jac.size1())
    assert per_row.max() <= 6 and jac.nnz() < 6 * 2 * t.size  # banded: 3 waypoints, 3 accelerations a row
    low, high = knot_bounds(np.array([2.0, 5.0]), t.size)
    np.testing.assert_allclose(high.reshape(t.size, 2), np.tile([2.0, 5.0], (t.size, 1)))
    np.testing.assert_allclose(low, -high)


def test_a_goal_tasks_nlp_keeps_the_executed_splines_accelerations_within_the_limits():
    """Without the rows the NLP rides the limits at its waypoints' backward differences and the
    executed spline exceeds them (1.5-1.6 x on this goal in 1 s); with them (goal tasks' default)
    the spline stays within, so the verdict's ``acceleration`` needs no refinement round."""
    task = panda_task({"kind": "goal", "configuration": GOAL, "samples": 20, "duration": 1.0})
    force = task.force()
    ratios = {}
    for on_spline in (False, None):
        opt = TrajectoryOptimizer(task.robot, task.n, goal="configuration", limits=task.limits, on_spline=on_spline)
        sol = opt.solve(task.t, task.targets, force.f, force.r, task.q_init, goal_guess(task), q_goal=np.array(GOAL))
        assert sol.success
        ratios[on_spline] = float(np.max(limit_ratios(task, sol.q)[1]))
        if on_spline is None:
            assert opt.on_spline and len(opt._spline_rows) == task.robot.nq - N_BASE
    assert ratios[False] > 1.2
    assert ratios[None] <= 1.0 + 1e-6


def test_limits_on_spline_turns_the_rows_on_or_off_for_any_task():
    """``limits.on_spline``: null (every plan: a given path and a goal task), true, false (either without)."""
    path = {"kind": "waypoints", "relative": True, "samples": 12,
            "waypoints": [{"t": 0.0, "position": [0.0, 0.0, 0.0]}, {"t": 2.0, "position": [0.1, 0.0, 0.0]}]}
    given = panda_task(path, payload={"mass": 1.0})
    goal = panda_task({"kind": "goal", "configuration": GOAL})
    on = panda_task(path, payload={"mass": 1.0}, limits={"on_spline": True})
    off = panda_task({"kind": "goal", "configuration": GOAL}, limits={"on_spline": False})
    given_off = panda_task(path, payload={"mass": 1.0}, limits={"on_spline": False})

    def rows(task, goal_kind):
        return TrajectoryOptimizer(task.robot, task.n, goal=goal_kind, limits=task.limits).on_spline

    assert rows(given, None) and rows(goal, "configuration")
    assert rows(on, None) and not rows(off, "configuration") and not rows(given_off, None)


def _velocity_rows(t, q, v1, pieces):
    """The velocity rows of every column of ``q`` (N x C) at the spline's own knot accelerations, divided by
    their segment's length (N-1 segments x 2 pieces x C, the last segment's end, the last knot's 0, appended)."""
    C = q.shape[1]
    X, A, h = ca.MX.sym("X", C, t.size), ca.MX.sym("A", C, t.size), ca.MX.sym("h", 1, t.size - 1)
    rows = ca.Function("rows", [X, A, h], [velocity_rows(X, A, h, list(range(C)), pieces)])
    values = np.array(rows(q.T, knot_accelerations(t, q, v1).T, np.diff(t)[None])).ravel()
    return np.r_[values, np.zeros(C)].reshape(t.size - 1, 2 * pieces, C) / np.diff(t)[:, None, None]  # rad/s


def test_the_velocity_rows_are_control_points_of_scipys_clamped_spline_velocity():
    """On uneven times, with a start velocity: the pieces' ends are SciPy's velocities there, the middle
    points its Bernstein control points (the value at a piece's middle is ``(v_0 + 2 P + v_1) / 4``), so
    their hull holds the dense-sampled velocity; the hull exceeds the true peak by at most
    ``h |a_1 - a_0| / (8 p^2)``, and by less with more pieces."""
    rng = np.random.default_rng(7)
    t = np.cumsum(np.r_[0.0, rng.uniform(0.05, 0.2, 11)])
    q = np.cumsum(rng.normal(scale=0.05, size=(t.size, 3)), axis=0)
    v1 = np.array([0.4, -0.3, 0.0])
    excess = {}
    for pieces in (1, 3):
        rows = _velocity_rows(t, q, v1, pieces)
        for j in range(3):
            spline = CubicSpline(t, q[:, j], bc_type=((1, v1[j]), (1, 0.0)))
            acc = spline(t, 2)
            for k in range(t.size - 1):
                h, u = t[k + 1] - t[k], np.arange(pieces + 1) / pieces
                ends = spline(t[k] + u * h, 1)
                np.testing.assert_allclose(rows[k, 1::2, j][: pieces - (k == t.size - 2)],
                                           ends[1:][: pieces - (k == t.size - 2)], atol=1e-10)
                middle = spline(t[k] + (u[:-1] + 0.5 / pieces) * h, 1)
                np.testing.assert_allclose((ends[:-1] + 2 * rows[k, ::2, j] + ends[1:]) / 4, middle, atol=1e-10)
                dense = np.abs(spline(np.linspace(t[k], t[k + 1], 401), 1))
                hull = max(np.abs(ends).max(), np.abs(rows[k, ::2, j]).max())
                assert dense.max() <= hull + 1e-12
                assert hull - dense.max() <= h * abs(acc[k + 1] - acc[k]) / (8 * pieces**2) + 1e-12
                excess[pieces] = max(excess.get(pieces, 0.0), hull - dense.max())
    assert excess[3] < excess[1] and excess[1] > 1e-3  # a case where the hull is conservative


def test_the_velocity_bounds_are_the_limits_times_the_segments_but_a_faster_start_keeps_its_speed():
    t = np.array([0.0, 0.1, 0.3, 0.4])
    low, high = velocity_bounds(np.array([1.0, 2.0]), t)
    assert high.size == 2 * (2 * 3 - 1) and np.all(low == -high)
    np.testing.assert_allclose(high, np.array([1.0, 2.0, 1.0, 2.0, 2.0, 4.0, 2.0, 4.0, 1.0, 2.0]) * 0.1)
    _, high = velocity_bounds(np.array([1.0, 2.0]), t, np.array([-1.5, 0.5]))
    np.testing.assert_allclose(high[:4], np.array([1.5, 2.0, 1.0, 2.0]) * 0.1)  # the first piece's middle point only
    _, high = velocity_bounds(np.array([1.0]), t, pieces=2)
    np.testing.assert_allclose(high, np.repeat(np.diff(t), 4)[:-1])


def test_the_spline_coordinates_are_the_velocity_and_acceleration_limited_ones():
    """The arm's joints with a velocity or acceleration limit, and the base's velocity when asked
    (its knot accelerations free: the verdict does not judge them); the NLP leaves the base out."""
    inf = np.inf
    vel, acc = np.array([1.0, 1.0, 1.5, 2.0, inf, inf]), np.array([1.0, 1.0, 2.0, 5.0, 7.0, inf])
    moving = SplineCoordinates.of(vel, acc, with_base=True)
    assert moving.coordinates == [0, 1, 2, 3, 4] and moving.velocity == [0, 1, 2, 3]
    np.testing.assert_allclose(moving.acceleration, [inf, inf, inf, 5.0, 7.0])
    np.testing.assert_allclose(moving.velocity_limits, [1.0, 1.0, 1.5, 2.0])
    fixed = SplineCoordinates.of(vel, acc, with_base=False)
    assert fixed.coordinates == [3, 4] and fixed.velocity == [0]


def _dense_velocity_ratio(task, q):
    """The worst ``|v| / v_max`` over every coordinate of SciPy's clamped spline through ``q``, 200 samples
    per interval (the verdict takes 8)."""
    limits = task.limits.resolve(task.robot)[0]
    dense = np.linspace(task.t[0], task.t[-1], 200 * (task.n - 1) + 1)
    v = np.stack([CubicSpline(task.t, q[:, j], bc_type="clamped")(dense, 1) for j in range(q.shape[1])], axis=1)
    return float(np.max(np.abs(v) / limits))


def test_an_own_urdf_riding_its_velocity_limits_keeps_them_on_the_executed_spline(tmp_path):
    """The raw Kinova URDF from a user's start (issue 36): without the rows its first solve keeps
    the 0.628 rad/s limits at the waypoints and the executed spline exceeds them (measured 1.34 x,
    joint 1 between waypoints 0 and 1); with them (``limits.on_spline``) SciPy's spline through
    the plan, sampled 25 x denser than the verdict, keeps every coordinate within its limit and the
    first solve is feasible, no refinement round."""
    ratios = {}
    for on in (False, True):
        task = task_from_dict(_kinova(rounds=0) | {"limits": {"on_spline": on}}, tmp_path / "task.yaml")
        plan = forte.plan(task)
        ratios[on] = _dense_velocity_ratio(task, plan.q)
        assert plan.feasible == on, plan.verdict.reason()
    assert ratios[False] > 1.2
    assert ratios[True] <= 1.0 + 1e-6
