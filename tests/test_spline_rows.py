"""The NLP's acceleration rows on the executed spline (:mod:`forte.planning.nlp.spline_rows`)."""

from __future__ import annotations

import sys
from pathlib import Path

import casadi as ca
import numpy as np
from scipy.interpolate import CubicSpline

from forte.model.robot import N_BASE
from forte.model.trajectory import clamped_spline
from forte.planning.nlp.optimizer import TrajectoryOptimizer
from forte.planning.nlp.spline_rows import knot_acceleration_operator, spline_bounds, spline_rows
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


def test_the_rows_are_the_knot_accelerations_and_their_bounds_move_with_the_start_velocity():
    rng = np.random.default_rng(4)
    t = np.linspace(0.0, 1.2, 9)
    q = rng.normal(size=(5, t.size))
    X, S = ca.MX.sym("X", 5, t.size), ca.MX.sym("S", t.size, t.size)
    rows = ca.Function("rows", [X, S], [spline_rows(X, S, [1, 3])])
    op = knot_acceleration_operator(t)
    got = np.array(rows(q, op.S)).ravel()
    _, _, acc = clamped_spline(t, q.T, t)
    np.testing.assert_allclose(got, acc[:, [1, 3]].ravel(), atol=1e-9)  # knot by knot, coordinate fastest
    lower, upper = spline_bounds(np.array([2.0, 5.0]), op.c, np.array([0.5, 0.0]))
    np.testing.assert_allclose(upper.reshape(t.size, 2)[:, 0], 2.0 - 0.5 * op.c)
    np.testing.assert_allclose(lower.reshape(t.size, 2)[:, 1], -5.0)


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
