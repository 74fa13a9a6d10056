"""The waypoint rows the executed spline's rows imply, and the NLP that leaves them out
(:meth:`forte.planning.nlp.spline_rows.SplineCoordinates.implied`, ``ipopt_nlp.kinematic_rows``)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import CubicSpline

import forte
from forte.model.robot import N_BASE
from forte.planning.nlp.optimizer import TrajectoryOptimizer
from forte.planning.nlp.spline_rows import SplineCoordinates
from forte.planning.solve import start_guess


def _clamped(t, q, v1):
    """SciPy's clamped spline (slope ``v1`` at the start, 0 at the end): the independent reference."""
    return CubicSpline(t, q, bc_type=((1, v1), (1, 0.0)))


def _excess(t, q, v1):
    """How far the waypoint rows' differences exceed what the spline's own extremes allow: velocity
    ``max_k |s_k| - max|v|`` over its segment, and acceleration ``|s_k - s_{k-1}| - a_max h_k``
    (``s_{-1} = v_1``), ``a_max`` the largest knot acceleration (the spline's extreme)."""
    spline, h = _clamped(t, q, v1), np.diff(t)
    s = np.diff(q) / h
    dense = [np.abs(spline(np.linspace(a, b, 401), 1)).max() for a, b in zip(t[:-1], t[1:], strict=True)]
    a_max = np.abs(spline(t, 2)).max()
    return (np.abs(s) - np.array(dense)).max(), (np.abs(np.diff(np.r_[v1, s])) - a_max * h).max()


def test_the_spline_rows_imply_the_waypoint_rows_on_steps_that_do_not_shrink():
    """On equal and on growing steps, with a start velocity, every waypoint velocity is within the
    spline's largest speed on its segment (its mean) and every backward-difference acceleration
    within the largest knot acceleration times its step (module docstring); on a shrinking step the
    acceleration's is not, and :meth:`SplineCoordinates.implied` says so."""
    rng = np.random.default_rng(7)
    for steps in (np.full(12, 0.25), np.linspace(0.1, 0.4, 12)):
        t = np.r_[0.0, np.cumsum(steps)]
        for _ in range(40):
            velocity, acceleration = _excess(t, rng.normal(size=t.size), rng.normal())
            assert velocity <= 1e-9 and acceleration <= 1e-9
    # a shrinking step: the parabola t^2 / 2 (every knot's acceleration 1, the bound) has
    # s_k - s_{k-1} = (h_{k-1} + h_k) / 2 > h_k
    shrinking = np.r_[0.0, np.cumsum(np.linspace(0.4, 0.1, 12))]
    s = np.diff(shrinking ** 2 / 2) / np.diff(shrinking)
    assert np.allclose(CubicSpline(shrinking, shrinking ** 2 / 2, bc_type=((2, 1.0), (2, 1.0)))(shrinking, 2), 1.0)
    assert np.max(np.diff(s) - np.diff(shrinking)[1:]) > 1e-3
    spline = SplineCoordinates([3, 4], [0, 1], np.array([2.0, 2.0]), np.array([1.0, 1.0]))
    assert spline.implied(np.linspace(0, 2, 9), None) and spline.implied(np.r_[0.0, np.cumsum(steps)], None)
    assert not spline.implied(shrinking, None)
    assert spline.implied(np.linspace(0, 2, 9), np.array([0.9, -1.0]))
    assert not spline.implied(np.linspace(0, 2, 9), np.array([0.9, -1.2]))  # a start faster than its limit
    assert spline.covered() == ([3, 4], [3, 4])


@pytest.fixture(scope="module")
def lift():
    return forte.load_task("examples/tasks/lift.yaml", waypoints=13)


def _solve(task, t, restore=False):
    opt = TrajectoryOptimizer(task.robot, task.n, "forte", task.weights, limits=task.limits)
    if restore:  # the problem with every waypoint row, as it was built before they were left out
        opt._drop_implied = False
        opt._build()
    f, nominal = task.force(), task.nominal()
    return opt, opt.solve(t, task.targets, f.f, f.r, task.q_init, start_guess(task, nominal), nominal)


def test_a_given_paths_nlp_leaves_out_the_arms_implied_rows_and_plans_the_same(lift):
    """The lift's problem keeps the base's waypoint rows and leaves out the arm's (the spline's rows
    imply them); its plan equals the one with every row to IPOPT's tolerance and keeps every
    waypoint row it left out."""
    opt, sol = _solve(lift, lift.t)
    full, reference = _solve(lift, lift.t, restore=True)
    arm = np.arange(N_BASE, lift.robot.nq)
    assert np.all(opt._vel_rows < N_BASE) and np.all(opt._acc_rows < N_BASE)
    assert set(arm) <= set(opt._limited[0]) and set(arm) <= set(full._vel_rows)
    assert opt._g.size_out(0)[0] < full._g.size_out(0)[0]
    assert sol.success and reference.success
    np.testing.assert_allclose(sol.q, reference.q, atol=1e-6)
    vel, acc = opt._vel, opt._acc
    h = np.diff(lift.t)[:, None]
    s = np.diff(sol.q, axis=0) / h
    assert np.all(np.abs(s[:, arm]) <= vel[arm] * (1 + 1e-6))
    assert np.all(np.abs(np.diff(np.vstack([np.zeros(lift.robot.nq), s]), axis=0)[:, arm]) <= acc[arm] * h + 1e-6)


def test_a_grid_that_does_not_imply_them_gets_every_row_back(lift):
    """A shrinking step (times the rows do not imply the waypoint rows on) builds the problem again
    with every row before the solve."""
    t = lift.t.copy()
    t[1:-3] = lift.t[0] + (lift.t[1:-3] - lift.t[0]) ** 0.8 / (lift.t[-4] - lift.t[0]) ** -0.2  # shrinking steps
    assert np.any(np.diff(np.diff(t)) < -1e-6)
    opt, sol = _solve(lift, t)
    assert not opt._drop_implied and opt._vel_rows.size == opt._limited[0].size
    assert opt._acc_rows.size == opt._limited[1].size
