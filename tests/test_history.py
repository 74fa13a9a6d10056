"""A horizon that starts moving: the first waypoint's velocity and acceleration reach the NLP (both
solvers), the metrics, the task force, the verdict and the receding-horizon shift; at rest every
number is today's."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from scipy.interpolate import CubicSpline

from forte.capability.metrics import smooth_capability_penalty
from forte.capability.polytope import trajectory_rfp
from forte.exceptions import InvalidInputError
from forte.model.trajectory import (
    StartMotion,
    backward_differences,
    clamped_spline,
    motion_at,
    start_history,
    start_of,
)
from forte.planning.nlp.optimizer import TrajectoryOptimizer
from forte.planning.nlp.solvers.stagewise import StagewiseSolver
from forte.planning.online.replan import Replanner
from forte.planning.solve import start_guess
from forte.planning.tasks.tasks import load_task
from forte.planning.verdict.evaluation import evaluate
from forte.planning.verdict.motion_samples import sample_motion

LIFT = Path(__file__).resolve().parents[1] / "examples" / "tasks" / "lift.yaml"


@pytest.fixture(scope="module")
def task():
    return load_task(LIFT, waypoints=15)


def _moving(nq: int, seed: int = 1, scale: float = 0.3) -> StartMotion:
    rng = np.random.default_rng(seed)
    return StartMotion(scale * rng.standard_normal(nq), rng.standard_normal(nq))


def _optimizer(task, backend="ipopt", on_spline=None):
    return TrajectoryOptimizer(task.robot, task.n, "forte", task.weights, limits=task.limits,
                               options=replace(task.solver, backend=backend), on_spline=on_spline)


def test_backward_differences_with_a_start_are_those_of_its_history():
    """The definition, independently: prepend the two samples before the start (at rest before
    them) and difference the longer sequence."""
    rng = np.random.default_rng(0)
    t = np.cumsum(rng.uniform(0.1, 0.3, 9))
    x = rng.standard_normal((9, 4))
    start = StartMotion(rng.standard_normal(4), rng.standard_normal(4))
    h = t[1] - t[0]
    v, a = backward_differences(x, t, start=start)
    longer = np.vstack([start_history(x[0], start, h), x])
    v_ref, a_ref = backward_differences(longer, np.r_[t[0] - 2 * h, t[0] - h, t])
    np.testing.assert_allclose(v, v_ref[2:], atol=1e-11)
    np.testing.assert_allclose(a, a_ref[2:], atol=1e-10)
    back = start_of(np.vstack([start_history(x[0], start, h), x[:1]]), h)
    np.testing.assert_allclose(back.velocity, start.velocity, atol=1e-12)
    np.testing.assert_allclose(back.acceleration, start.acceleration, atol=1e-10)
    np.testing.assert_array_equal(start_history(x[0], None, h), [x[0], x[0]])  # at rest
    for k in (0, 1, 2, 5):  # the motion at one sample, from the three up to it
        at = motion_at(x, t, k, start)
        np.testing.assert_allclose(at.velocity, v[k], atol=1e-12)
        np.testing.assert_allclose(at.acceleration, a[k], atol=1e-12)


def test_the_spline_leaves_a_moving_start_with_its_velocity():
    """Against SciPy's cubic spline with the first derivative given at both ends."""
    rng = np.random.default_rng(2)
    t = np.cumsum(rng.uniform(0.1, 0.3, 7))
    q = rng.standard_normal((7, 3))
    v0 = rng.standard_normal(3)
    ts = np.linspace(t[0], t[-1], 50)
    pos, vel, acc = clamped_spline(t, q, ts, v0)
    ref = CubicSpline(t, q, bc_type=((1, v0), (1, np.zeros(3))))
    np.testing.assert_allclose(pos, ref(ts), atol=1e-12)
    np.testing.assert_allclose(vel, ref(ts, 1), atol=1e-10)
    np.testing.assert_allclose(acc, ref(ts, 2), atol=1e-9)


def test_the_nlp_reads_the_start_motion(task):
    """J1 of the NLP with a moving start equals the numpy surrogate on the exact polytopes with
    that start (Pinocchio's RNEA on the backward differences), and the velocity term gains the
    first waypoint's ``1/2 ||v_arm||^2``."""
    opt = _optimizer(task)
    start = _moving(task.robot.nq)
    q, f = start_guess(task, task.nominal()), task.force()
    params = task.settings.capability_params
    rest = opt.cost_terms(q, task.t, task.targets, f.f, f.r)
    moving = opt.cost_terms(q, task.t, task.targets, f.f, f.r, start=start)
    rfp = trajectory_rfp(task.robot, q, task.t, params.alpha, start=start)
    expected = smooth_capability_penalty(rfp.A, rfp.b, f.f, f.r, params).sum()
    assert moving["capability"] == pytest.approx(expected, rel=1e-12)
    assert moving["capability"] != pytest.approx(rest["capability"], rel=1e-9)  # the start matters
    assert moving["velocity"] - rest["velocity"] == pytest.approx(0.5 * np.sum(start.velocity[3:] ** 2), rel=1e-9)


@pytest.mark.parametrize("backend", ["ipopt", "stagewise"])
def test_a_start_at_rest_is_todays_problem_exactly(task, backend):
    opt = _optimizer(task, backend)
    nominal = task.nominal()
    guess, f = start_guess(task, nominal), task.force()
    zero = StartMotion(np.zeros(task.robot.nq), np.zeros(task.robot.nq))
    a = opt.solve(task.t, task.targets, f.f, f.r, task.q_init, guess, nominal)
    b = opt.solve(task.t, task.targets, f.f, f.r, task.q_init, guess, nominal, start=zero)
    assert a.success and a.iterations == b.iterations
    np.testing.assert_array_equal(a.q, b.q)
    assert a.objective == b.objective


def test_both_solvers_solve_the_same_moving_start(task):
    nominal = task.nominal()
    guess, f = start_guess(task, nominal), task.force()
    start = _moving(task.robot.nq)
    a, b = (_optimizer(task, backend).solve(task.t, task.targets, f.f, f.r, task.q_init, guess, nominal, start=start)
            for backend in ("ipopt", "stagewise"))
    rest = _optimizer(task).solve(task.t, task.targets, f.f, f.r, task.q_init, guess, nominal)
    assert a.success and b.success and b.backend == "stagewise"
    np.testing.assert_allclose(b.q, a.q, atol=1e-5)
    assert b.objective == pytest.approx(a.objective, rel=1e-7)
    assert np.abs(a.q - rest.q).max() > 1e-4  # a different problem from the start at rest


def test_the_reformulated_problem_reads_the_start_as_ipopts(task):
    """Objective, gradient and kinematic rows (the first acceleration rows move by the start
    velocity) of the stagewise problem equal the IPOPT NLP's, with a moving start. IPOPT's NLP
    without the spline's rows: with them it leaves out the arm's waypoint rows they imply
    (spline_rows.SplineCoordinates.covered)."""
    opt = _optimizer(task, on_spline=False)
    pb = StagewiseSolver(opt.stage_nlp()).problem
    f, nominal = task.force(), task.nominal()
    start = _moving(task.robot.nq, seed=4)
    data = pb.task_data(task.t, task.targets, f.f, f.r, task.q_init, nominal, start=start)
    p = opt.parameters(task.t, task.targets, f.f, f.r, nominal, start=start)
    _, _, lbg, ubg = opt.bounds(task.t, task.q_init, start)
    y = pb.y_of(start_guess(task, nominal)) + 0.02 * np.random.default_rng(3).standard_normal(pb.ny)
    x = opt.full_x(pb.x_of(y, data).reshape(task.n, -1))
    fx, gx = (np.array(v).ravel() for v in opt._nlp_options["grad_f"](x, p))
    assert pb.objective(y, data) == pytest.approx(float(fx[0]), rel=1e-12)
    np.testing.assert_allclose(pb.gradient(y, data), pb.T.T @ gx[: pb.T.shape[0]], rtol=1e-10, atol=1e-10)
    g = np.array(opt._g(x, p)).ravel()
    # each kinematic row (waypoint k, velocity 0 / acceleration 1, dof d) in IPOPT's order, minus its bound
    steps, nvel, nacc = task.n - 1, opt._vel_rows.size, opt._acc_rows.size
    k, kind, d = pb.kin_rows.T
    ipopt_row = 6 * pb.posed.size + np.where(
        kind == 0, (k - 1) * nvel + np.searchsorted(opt._vel_rows, d),
        steps * nvel + (k - 1) * nacc + np.searchsorted(opt._acc_rows, d))
    rows = pb.A[pb.bound_vars.size:] @ y + data.b[pb.bound_vars.size:]
    np.testing.assert_allclose(rows - pb._bounds[0][pb.bound_vars.size:], g[ipopt_row] - lbg[ipopt_row], atol=1e-12)
    np.testing.assert_allclose(pb._bounds[1][pb.bound_vars.size:] - rows, ubg[ipopt_row] - g[ipopt_row], atol=1e-12)
    first = (k == 1) & (kind == 1)
    assert first.any() and np.abs(ubg[ipopt_row[first]] + lbg[ipopt_row[first]]).max() > 0  # moved bounds


def test_a_start_motion_needs_a_trajectory():
    hold = load_task(LIFT.parent / "hold.yaml")
    opt = TrajectoryOptimizer(hold.robot, hold.n, "forte", hold.weights, fix_initial=False)
    with pytest.raises(InvalidInputError, match="start"):
        opt.parameters(hold.t, hold.targets, hold.force().f, hold.force().r, start=_moving(hold.robot.nq))


def test_the_metrics_and_the_verdict_start_with_the_motion(task):
    """A plan's metrics with a start motion are those of the longer plan that prepends the start's
    history (and is at rest before it); the verdict's samples leave the first waypoint with it."""
    q, f = start_guess(task, task.nominal()), task.force()
    start = _moving(task.robot.nq, scale=0.05)
    h = task.t[1] - task.t[0]
    moving = evaluate(task.robot, q, task.t, f, task.settings.capability_params, start=start)
    longer_q = np.vstack([start_history(q[0], start, h), q])
    longer_t = np.r_[task.t[0] - 2 * h, task.t[0] - h, task.t]
    longer_f = replace(f, t=longer_t, f=np.vstack([f.f[:1], f.f[:1], f.f]), r=np.r_[f.r[:2], f.r])
    longer = evaluate(task.robot, longer_q, longer_t, longer_f, task.settings.capability_params)
    for column in ("d", "max_torque_ratio", "inscribed_radius"):
        np.testing.assert_allclose(moving[column], longer[column][2:], rtol=1e-8, atol=1e-8)
    samples = sample_motion(task.robot, task.t, q, 4, start)
    first = samples.waypoint[0]
    np.testing.assert_allclose(samples.dq[first], start.velocity, atol=1e-12)
    after = first + 1  # the spline's sample at the same time leaves with the start velocity too
    np.testing.assert_allclose(samples.dq[after], start.velocity, atol=1e-10)


def test_the_task_force_starts_with_the_end_effectors_motion(task):
    """``f_1 = m (a_ee - g)``, the end effector's velocity from its positions along the start
    history: close to Pinocchio's Jacobian times the start velocity for a slow start."""
    J = task.robot.whole_body_jacobian(task.q_init)[:3]
    errors = []
    for scale in (0.01, 0.001):  # the difference quotient's error is second order: 10x slower, 10x smaller
        start = _moving(task.robot.nq, scale=scale)
        velocity = replace(task, start_motion=start).ee_start().velocity
        errors.append(np.linalg.norm(velocity - J @ start.velocity) / np.linalg.norm(J @ start.velocity))
    assert errors[0] < 1e-2 and errors[1] < 0.15 * errors[0]
    moving = replace(task, start_motion=start)
    ee = moving.ee_start()
    m = task.payload.mass + task.robot.tool_force_mass
    f = moving.force().f
    np.testing.assert_allclose(f[0], m * (ee.acceleration + [0, 0, task.robot.gravity]), rtol=1e-12)
    np.testing.assert_allclose(f[2:], task.force().f[2:], rtol=1e-12)  # after the first step: unchanged


def test_a_shift_continues_the_plans_own_motion(task):
    """Without a measurement the new first waypoint moves as the last plan did there, so the
    shifted plan's own metrics are those of the waypoints executed before it and the new plan
    (the MPC's splice); a measured velocity replaces the planned one."""
    planner = Replanner(task)
    before = planner.last.q.copy()
    v, a = backward_differences(before, task.t)
    result = planner.shift(3)
    assert result.plan.solved
    np.testing.assert_allclose(planner.task.start_motion.velocity, v[3], atol=1e-12)
    np.testing.assert_allclose(planner.task.start_motion.acceleration, a[3], atol=1e-12)
    spliced = np.vstack([before[:3], result.plan.q])[: task.n]
    executed = evaluate(task.robot, spliced, task.t, task.force(), task.settings.capability_params)
    np.testing.assert_allclose(result.plan.metrics["max_torque_ratio"][: task.n - 3],
                               executed["max_torque_ratio"][3:], rtol=1e-8)
    measured = np.full(task.robot.nq, 0.01)
    planner.shift(1, v_now=measured)
    np.testing.assert_array_equal(planner.task.start_motion.velocity, measured)
    with pytest.raises(InvalidInputError, match="v_now"):
        planner.shift(1, v_now=np.zeros(3))
