"""The NLP: hand-assembled exact derivatives equal CasADi's AD; solutions meet the constraints."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from scipy.fft import dct

from forte.exceptions import InvalidInputError
from forte.force.taskforce import payload_force
from forte.model.trajectory import quintic_path
from forte.planning.nlp.optimizer import SolverOptions, TrajectoryOptimizer
from forte.planning.tasks.ik import follow_path
from forte.planning.terms.motion_terms import BaseSpectral, dct_penalty_matrix
from forte.planning.terms.reference import base_spectral_cost, smoothness_cost
from forte.planning.terms.spectral import dct_matrix, high_frequencies
from forte.settings import CostWeights


def lift_problem(robot, n, duration=3.0, drop=0.2):
    q0 = robot.home()
    T0 = robot.ee_pose(q0)
    t = np.linspace(0, duration, n)
    P = quintic_path([0, duration], [T0[:3, 3], T0[:3, 3] + [0.1, 0.0, -drop]], t)
    targets = np.repeat(T0[None], n, axis=0)
    targets[:, :3, 3] = P
    return t, targets, q0


@pytest.mark.parametrize(("method", "fix"), [("forte", True), ("rfp-radius", True), ("rfp-cone", True),
                                              ("manipulability", False), ("forte", False)])
def test_assembled_derivatives_equal_automatic_differentiation(robot, method, fix):
    n = 5 if fix else 1
    opt = TrajectoryOptimizer(robot, n, method, fix_initial=fix, options=SolverOptions(codegen=False))
    rng = np.random.default_rng(0)
    q = np.tile(robot.home(), n) + 0.1 * rng.normal(size=robot.nq * n)
    T = np.repeat(robot.ee_pose(robot.home())[None], n, 0)
    p = opt.parameters(np.linspace(0, 1, n), T, rng.normal(size=(n, 3)) * 30, np.full(n, 10.0))
    # every variable the NLP has: in trajectory mode the executed spline's knot accelerations follow
    # q (limits.on_spline, on by default), moved off the spline so their rows are not all at 0
    assert opt.on_spline == fix and (opt.spans.knots.stop > opt.spans.knots.start) == fix
    x = opt.full_x(q)
    x[opt.spans.knots] += 0.1 * rng.normal(size=x[opt.spans.knots].size)
    assert x.size == opt.solver.size_in("x0")[0]
    oracle = opt.solver.oracle()
    xs, ps = ca.MX.sym("x", x.size), ca.MX.sym("p", p.size)
    out = oracle(x=xs, p=ps)
    lam_g = rng.normal(size=out["g"].numel())
    lagrangian = 0.7 * out["f"] + ca.dot(ca.DM(lam_g), out["g"])
    auto = ca.Function("auto", [xs, ps], [ca.gradient(out["f"], xs), ca.jacobian(out["g"], xs),
                                          ca.hessian(lagrangian, xs)[0]])
    grad_a, jac_a, hess_a = (np.array(ca.densify(v)) for v in auto(x, p))
    _, grad = opt.solver.get_function("nlp_grad_f")(x, p)
    _, jac = opt.solver.get_function("nlp_jac_g")(x, p)
    hess = np.array(ca.densify(opt.solver.get_function("nlp_hess_l")(x, p, 0.7, lam_g)))
    hess = np.triu(hess) + np.triu(hess, 1).T
    scale = 1 + np.abs(hess_a).max()
    np.testing.assert_allclose(np.array(grad).ravel(), grad_a.ravel(), atol=1e-9 * scale)
    np.testing.assert_allclose(np.array(ca.densify(jac)), jac_a, atol=1e-12)
    np.testing.assert_allclose(hess, hess_a, atol=1e-10 * scale)


def test_compiled_kernels_equal_the_virtual_machine(robot, tmp_path):
    n = 6
    t, targets, q0 = lift_problem(robot, n)
    force = payload_force(t, targets[:, :3, 3], 2.0)
    vm = TrajectoryOptimizer(robot, n, "forte", options=SolverOptions(codegen=False))
    cg = TrajectoryOptimizer(robot, n, "forte", options=SolverOptions(cache_dir=str(tmp_path)))
    assert cg.codegen in ("compiled", "cached")
    p = vm.parameters(t, targets, force.f, force.r)
    x = vm.full_x(np.tile(q0, n) + 0.05)  # with the spline's knot accelerations (on_spline)
    assert vm.spans.knots.stop > vm.spans.knots.start and x.size == vm.solver.size_in("x0")[0]
    for name in ("nlp_grad_f", "nlp_jac_g"):
        a = vm.solver.get_function(name)(x, p)
        b = cg.solver.get_function(name)(x, p)
        for u, v in zip(a, b, strict=True):
            np.testing.assert_allclose(np.array(ca.densify(u)), np.array(ca.densify(v)), rtol=1e-12, atol=1e-12)
    again = TrajectoryOptimizer(robot, n, "forte", options=SolverOptions(cache_dir=str(tmp_path)))
    assert again.codegen == "cached"


def test_solution_meets_pose_bounds_and_initial_configuration(robot):
    n = 12
    t, targets, q0 = lift_problem(robot, n)
    force = payload_force(t, targets[:, :3, 3], 2.7)
    guess = follow_path(robot, targets, q0)
    opt = TrajectoryOptimizer(robot, n, "forte")
    sol = opt.solve(t, targets, force.f, force.r, q0, guess)
    assert sol.success, sol.status
    np.testing.assert_allclose(sol.q[0], q0, atol=1e-12)
    # every waypoint but N-1 and N-2 (replaced by the end-at-rest rows) meets its pose
    assert opt._pose_steps.tolist() == [*range(1, n - 3), n - 1]
    for k in opt._pose_steps:
        T, Tk = robot.ee_pose(sol.q[k]), targets[k]
        assert np.linalg.norm(T[:3, 3] - Tk[:3, 3]) < 1e-6
        assert np.abs(T[:3, :3] - Tk[:3, :3]).max() < 1e-6
    # the plan ends at rest: backward-difference velocity and acceleration vanish at the last waypoint
    v = np.diff(sol.q, axis=0) / np.diff(t)[:, None]
    a = np.diff(v, axis=0) / np.diff(t)[1:, None]
    assert np.abs(v[-1]).max() < 1e-6 and np.abs(a[-1]).max() < 1e-6
    assert np.all(sol.q[:, 3:] >= robot.lower - 1e-8) and np.all(sol.q[:, 3:] <= robot.upper + 1e-8)
    terms = opt.cost_terms(sol.q, t, targets, force.f, force.r)
    assert terms["smoothness"] == pytest.approx(smoothness_cost(sol.q, {"base_smoothness": {"base": (0.0, 0.0, 0.0)}}),
                                                rel=1e-9)
    assert terms["smoothness"] + terms["base_smoothness"] == pytest.approx(smoothness_cost(sol.q, opt.settings),
                                                                           rel=1e-9)
    assert terms["base_spectral"] == pytest.approx(base_spectral_cost(sol.q[:, :3], opt.settings), rel=1e-9,
                                                   abs=1e-15)
    # the optimizer improves on its own initial guess
    guess_terms = opt.cost_terms(guess, t, targets, force.f, force.r)
    w = CostWeights()
    total = {k: v * getattr(w, k) for k, v in terms.items()}
    total_guess = {k: v * getattr(w, k) for k, v in guess_terms.items()}
    assert sum(total.values()) < sum(total_guess.values())


def test_iteration_limit_is_reported_as_failure(robot):
    n = 8
    t, targets, q0 = lift_problem(robot, n)
    force = payload_force(t, targets[:, :3, 3], 2.7)
    opt = TrajectoryOptimizer(robot, n, "forte", options=SolverOptions(max_iter=1))
    sol = opt.solve(t, targets, force.f, force.r, q0, np.tile(q0, (n, 1)))
    assert not sol.success
    assert sol.status == "Maximum_Iterations_Exceeded"


def test_bad_method_and_horizon(robot):
    with pytest.raises(InvalidInputError, match="method: expected one of"):
        TrajectoryOptimizer(robot, 5, "quintic")
    with pytest.raises(InvalidInputError, match="waypoints: expected at least 1"):
        TrajectoryOptimizer(robot, 0)


def test_dct_matches_scipy_and_penalizes_only_high_frequencies():
    x = np.random.default_rng(1).normal(size=20)
    np.testing.assert_allclose(dct_matrix(20) @ x, dct(x, norm="ortho"), atol=1e-12)
    assert high_frequencies(20, 0.35).tolist() == list(range(7, 20))
    w = {"base_spectral": {"power": 1.0, "cutoff": 0.35, "ramp": False}}
    coeffs = dct(x, norm="ortho")
    H = high_frequencies(20, 0.35)
    expected = np.sum((H / 19.0) * coeffs[H] ** 2)
    assert x @ dct_penalty_matrix(20, w) @ x == pytest.approx(expected)
    # a constant or a low-frequency base motion costs nothing, a fast one its full energy
    demo = {"base_spectral": {"power": 0.0, "cutoff": 0.35, "ramp": False}}
    slow = 1.0 + np.cos(np.pi * (2 * np.arange(20) + 1) * 2 / 40)
    assert slow @ dct_penalty_matrix(20, demo) @ slow == pytest.approx(0.0, abs=1e-12)
    fast = np.cos(np.pi * (2 * np.arange(20) + 1) * 15 / 40)
    assert fast @ dct_penalty_matrix(20, demo) @ fast == pytest.approx(fast @ fast)
    # the authors' ramp: bins with l/(N-1) > c, gamma_l = ((l/(N-1) - c)/(1 - c))^2 (0 at the cutoff)
    ramp = None
    term = BaseSpectral.from_settings(ramp)
    assert (term.cutoff, term.power, term.ramp) == (0.1, 2.0, True)
    ell = np.arange(20)
    high = ell / 19 > 0.1
    gamma = np.where(high, ((ell / 19 - 0.1) / 0.9) ** 2, 0.0)
    assert x @ dct_penalty_matrix(20, ramp) @ x == pytest.approx(float(np.sum(gamma * coeffs**2)))
    assert gamma[1] == 0 and gamma[2] > 0 and gamma[19] == pytest.approx(1.0)
    base = np.column_stack([x, 2 * x, x])
    w0 = demo
    H = high_frequencies(20, 0.35)
    axis = BaseSpectral.from_settings(w0).axis
    direct = 0.5 * sum(eta * np.sum(dct(base[:, i], norm="ortho")[H] ** 2) for i, eta in enumerate(axis))
    assert base_spectral_cost(base, w0) == pytest.approx(direct)


def test_kinematic_limits_bound_the_backward_differences(robot):
    from forte.planning.nlp.optimizer import KinematicLimits

    n = 12
    t, targets, q0 = lift_problem(robot, n, duration=1.2, drop=0.3)
    force = payload_force(t, targets[:, :3, 3], 2.7)
    guess = follow_path(robot, targets, q0)
    limits = KinematicLimits(arm_velocity=(1.0,) * 7, arm_acceleration=(4.0,) * 7, end_at_rest=False)
    opt = TrajectoryOptimizer(robot, n, "forte", limits=limits)
    sol = opt.solve(t, targets, force.f, force.r, q0, guess)
    assert sol.success, sol.status
    dt = np.diff(t)[:, None]
    v = np.vstack([np.zeros(robot.nq), np.diff(sol.q, axis=0) / dt])  # at rest at k = 1
    a = np.diff(v, axis=0) / dt
    vel, acc = limits.resolve(robot)
    assert np.all(np.abs(v) <= vel + 1e-6)
    assert np.all(np.abs(a) <= acc + 1e-5)
    assert np.any(np.abs(v[:, 3:]) > 0.99 * 1.0)  # the velocity limit binds on this fast lift
    free = TrajectoryOptimizer(robot, n, "forte", limits=KinematicLimits(enabled=False, end_at_rest=False))
    assert free.solver.size_out("g")[0] == 6 * (n - 1)  # the paper's NLP: pose constraints only
    assert np.array_equal(KinematicLimits().resolve(robot)[0][3:], robot.model.velocityLimit)


def test_hold_starts_are_seeded_within_the_limits_and_begin_at_the_taught_point():
    from dataclasses import replace
    from pathlib import Path

    from forte.planning.solve import hold_starts
    from forte.planning.tasks.tasks import load_task

    task = load_task(Path(__file__).resolve().parents[1] / "examples" / "tasks" / "hold.yaml")
    starts = hold_starts(task)
    assert starts.shape == (task.solver.hold_starts, task.robot.nq)
    np.testing.assert_array_equal(starts[0], task.q_init)
    assert np.all(starts[:, 3:] >= task.robot.lower) and np.all(starts[:, 3:] <= task.robot.upper)
    np.testing.assert_array_equal(starts, hold_starts(task))  # deterministic
    other = replace(task, solver=replace(task.solver, hold_seed=1))
    assert not np.allclose(starts[1:], hold_starts(other)[1:])


@pytest.mark.slow
def test_more_hold_starts_never_give_a_worse_objective():
    from dataclasses import replace
    from pathlib import Path

    from forte.planning.planner import plan
    from forte.planning.tasks.tasks import load_task

    task = load_task(Path(__file__).resolve().parents[1] / "examples" / "tasks" / "hold.yaml")  # 2.7 kg
    single = plan(replace(task, solver=replace(task.solver, hold_starts=1)), "forte")
    multi = plan(task, "forte")
    assert single.solved and multi.solved and "starts" not in single.solver
    assert multi.solver["starts"]["count"] == task.solver.hold_starts
    assert multi.solver["objective"] <= single.solver["objective"] + 1e-9
    starts = multi.solver["starts"]
    assert multi.solver["objective"] == starts["objectives"][starts["chosen"]]
    # the documented gain: at 2.7 kg, from the taught point alone forte stops in a worse basin
    assert starts["chosen"] != 0 and multi.solver["objective"] < single.solver["objective"] - 0.1
    # reported effort covers every start
    assert multi.solver["iterations"] == starts["iterations"] >= starts["chosen_iterations"]
