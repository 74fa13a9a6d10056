"""The NLP's acceleration rows on the executed spline (:mod:`forte.planning.nlp.spline_rows`)."""

from __future__ import annotations

import sys
from pathlib import Path

import casadi as ca
import numpy as np
from scipy.interpolate import CubicSpline

from forte.model.robot import N_BASE
from forte.planning.nlp.optimizer import TrajectoryOptimizer
from forte.planning.nlp.spline_rows import (
    knot_acceleration_operator,
    knot_accelerations,
    knot_bounds,
    spline_bounds,
    spline_rows,
)
from forte.planning.solve import goal_guess
from forte.planning.verdict.verdict import limit_ratios

sys.path.insert(0, str(Path(__file__).parent))
from test_goal_tasks import GOAL, panda_task  # noqa: E402


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
    """``limits.on_spline``: null (goal tasks only), true (a given path too), false (a goal task without)."""
    path = {"kind": "waypoints", "relative": True, "samples": 12,
            "waypoints": [{"t": 0.0, "position": [0.0, 0.0, 0.0]}, {"t": 2.0, "position": [0.1, 0.0, 0.0]}]}
    given = panda_task(path, payload={"mass": 1.0})
    goal = panda_task({"kind": "goal", "configuration": GOAL})
    on = panda_task(path, payload={"mass": 1.0}, limits={"on_spline": True})
    off = panda_task({"kind": "goal", "configuration": GOAL}, limits={"on_spline": False})

    def rows(task, goal_kind):
        return TrajectoryOptimizer(task.robot, task.n, goal=goal_kind, limits=task.limits).on_spline

    assert not rows(given, None) and rows(goal, "configuration")
    assert rows(on, None) and not rows(off, "configuration")
