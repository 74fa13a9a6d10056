"""The stagewise interior-point solver: the same problem as IPOPT's, the same answer, and real-time
iterations that converge to it and are never published when they are not sound."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from forte.exceptions import InvalidInputError
from forte.planning.nlp.optimizer import TrajectoryOptimizer
from forte.planning.nlp.solvers.stagewise import StagewiseSolver
from forte.planning.online.realtime import RealTimeIteration
from forte.planning.online.replan import Replanner
from forte.planning.planner import plan
from forte.planning.solve import start_guess
from forte.planning.tasks.tasks import load_task
from forte.settings import SolverOptions

TASKS = Path(__file__).resolve().parents[1] / "examples" / "tasks"


def waypoint_rows(task):
    """``task`` with ``limits.on_spline: false``: the stagewise backend has no rows on the executed
    spline (it solves the waypoint rows alone), so IPOPT is compared with it on that problem."""
    return replace(task, limits=replace(task.limits, on_spline=False))


def _optimizers(task):
    """The task's NLP twice: solved by IPOPT and by the stagewise backend (waypoint rows only)."""
    task = waypoint_rows(task)
    make = lambda backend: TrajectoryOptimizer(  # noqa: E731
        task.robot, task.n, "forte", task.weights, fix_initial=task.mode != "hold",
        options=replace(task.solver, backend=backend), limits=task.limits)
    return make("ipopt"), make("stagewise")


def _solve(opt, task, guess=None):
    nominal = task.nominal()
    guess = start_guess(task, nominal) if guess is None else guess
    f = task.force()
    return opt.solve(task.t, task.targets, f.f, f.r, task.q_init, guess, nominal)


@pytest.mark.parametrize("waypoints", [25, 41])
def test_stagewise_equals_ipopt_on_the_lift(waypoints):
    task = load_task(TASKS / "lift.yaml", waypoints=waypoints)
    ipopt, stagewise = _optimizers(task)
    a, b = _solve(ipopt, task), _solve(stagewise, task)
    assert a.status == b.status == "Solve_Succeeded" and b.success
    assert stagewise.stagewise() is not None and b.iterate is not None  # the stagewise path ran
    np.testing.assert_allclose(b.q, a.q, atol=1e-5)
    assert abs(b.objective - a.objective) <= 1e-7 * abs(a.objective)
    assert b.constraint_violation <= 1e-6


def test_stagewise_equals_ipopt_on_the_hold_point():
    """Single-point holding: one free configuration with its pose rows. Its objective has several
    basins (different starts end in different ones, with either solver), so the planner's
    multi-start is compared: both backends keep the same best optimum."""
    task = load_task(TASKS / "hold.yaml")
    task = replace(task, solver=replace(task.solver, hold_starts=8, refine_rounds=0))
    a = plan(task, "forte")
    b = plan(replace(task, solver=replace(task.solver, backend="stagewise")), "forte")
    assert a.solved and b.solved
    np.testing.assert_allclose(b.q, a.q, atol=1e-5)
    assert b.solver["objective"] == pytest.approx(a.solver["objective"], rel=1e-7)


def test_the_reformulated_problem_is_the_optimizers():
    """Objective, gradient, pose rows and kinematic rows of the eliminated problem equal the IPOPT
    NLP's at random configurations (an independent evaluation: CasADi's functions of the NLP)."""
    task = load_task(TASKS / "lift.yaml", waypoints=15)
    opt, _ = _optimizers(task)
    pb = StagewiseSolver(opt.stage_nlp()).problem
    f = task.force()
    nominal = task.nominal()
    data = pb.task_data(task.t, task.targets, f.f, f.r, task.q_init, nominal)
    p = opt.parameters(task.t, task.targets, f.f, f.r, nominal)
    rng = np.random.default_rng(3)
    for _ in range(3):
        y = pb.y_of(start_guess(task, nominal)) + 0.05 * rng.standard_normal(pb.ny)
        x = pb.x_of(y, data)
        fx, gx = (np.array(v).ravel() for v in opt._nlp_options["grad_f"](opt.full_x(x.reshape(task.n, -1)), p))
        assert pb.objective(y, data) == pytest.approx(float(fx[0]), rel=1e-12)
        np.testing.assert_allclose(pb.gradient(y, data), pb.T.T @ gx[: x.size], rtol=1e-10, atol=1e-10)
        g = np.array(opt._g(opt.full_x(x.reshape(task.n, -1)), p)).ravel()
        np.testing.assert_allclose(pb.pose(y, data).ravel(), g[: 6 * pb.posed.size], atol=1e-12)
        kin = np.sort(pb.A[pb.bound_vars.size:] @ y + data.b[pb.bound_vars.size:])
        ipopt_kin = g[6 * pb.posed.size:]
        # IPOPT's rows include those the elimination makes identically 0 (the end at rest)
        np.testing.assert_allclose(kin, np.sort(ipopt_kin[np.abs(ipopt_kin) > 1e-14])[: kin.size] if False
                                   else np.sort(_nonconstant(ipopt_kin, kin.size)), atol=1e-12)


def _nonconstant(rows, count):
    """The rows of IPOPT's kinematic block that are not identically zero after the elimination:
    the end-at-rest rows (last) and the steps inside the tied tail are 0 here."""
    nonzero = rows[np.abs(rows) > 1e-13]
    assert nonzero.size == count, (nonzero.size, count)
    return nonzero


def test_newton_step_solves_the_full_kkt_system():
    """The null-space step equals the solution of the full KKT system (dense NumPy solve)."""
    task = load_task(TASKS / "lift.yaml", waypoints=12)
    opt, _ = _optimizers(task)
    solver = StagewiseSolver(opt.stage_nlp())
    pb, ip = solver.problem, solver.ip
    f = task.force()
    nominal = task.nominal()
    data = pb.task_data(task.t, task.targets, f.f, f.r, task.q_init, nominal)
    it = ip.start(pb.y_of(start_guess(task, nominal)), data)
    ev = ip.evaluate(it, data)
    ev.extras["hess"] = it.scale * pb.stage_hessians(it.y, data)  # the objective as scaled (IPOPT's rule)
    assert 0 < it.scale <= 1
    dy, lam_new, delta, parts = ip.step(it, ev, data, it.mu)
    sigma = parts[0]
    # the y Hessian from IPOPT's own Lagrangian Hessian (upper triangle) and the barrier
    p = opt.parameters(task.t, task.targets, f.f, f.r, nominal)
    lam_g = np.zeros(opt._g.size1_out(0))
    lam_g[: it.lam.size] = it.lam.ravel()
    hu = opt._nlp_options["hess_lag"](opt.full_x(pb.x_of(it.y, data).reshape(task.n, -1)), p, it.scale, lam_g)
    hu = np.array(hu.full())[: pb.T.shape[0], : pb.T.shape[0]]
    Hx = hu + np.triu(hu, 1).T
    H = pb.T.T @ Hx @ pb.T + (pb.A.T @ np.diag(sigma) @ pb.A) + delta * np.eye(pb.ny)
    J = np.zeros((it.lam.size, pb.ny))
    for i, blk in enumerate(pb.posed_block):
        J[6 * i:6 * i + 6, blk * pb.nq:(blk + 1) * pb.nq] = ev.J[i]
    sl, su, lo, up = parts[3], parts[4], parts[5], parts[6]
    barrier = np.where(up, it.mu / su, 0.0) - np.where(lo, it.mu / sl, 0.0)
    g = ev.grad + pb.A.T @ (barrier + sigma * ev.rA)
    K = np.block([[H, J.T], [J, np.zeros((J.shape[0], J.shape[0]))]])
    sol = np.linalg.solve(K, -np.concatenate([g, ev.c.ravel()]))
    np.testing.assert_allclose(dy, sol[: pb.ny], atol=1e-8 * max(1, np.abs(sol[: pb.ny]).max()))
    np.testing.assert_allclose(lam_new.ravel(), sol[pb.ny:], atol=1e-6 * max(1, np.abs(sol[pb.ny:]).max()))


@pytest.fixture(scope="module")
def light_lift():
    task = load_task(TASKS / "lift.yaml", waypoints=25)
    return task.with_payload(task.payload.with_mass(0.35))


def test_real_time_iterations_converge_to_the_ipopt_solution(light_lift):
    """After the 0.35 -> 2.7 kg jump, consecutive real-time steps reach IPOPT's solution of the
    new problem; published steps keep their constraint violation within the tolerance."""
    rti = RealTimeIteration(Replanner(light_lift, backend="stagewise"))
    heavy = light_lift.with_payload(light_lift.payload.with_mass(2.7))
    reference = plan(waypoint_rows(replace(heavy, solver=replace(heavy.solver, refine_rounds=0))), "forte")
    steps = [rti.step(mass=2.7)]
    while not steps[-1].converged and len(steps) < 40:
        steps.append(rti.step())
    assert steps[-1].converged, [s.kkt_error for s in steps]
    np.testing.assert_allclose(steps[-1].q, reference.q, atol=1e-5)
    assert all(s.violation <= 1e-3 for s in steps if s.published)
    assert sum(not s.published for s in steps) == sum(rti.misses.values())


def test_a_failed_real_time_step_is_never_published(light_lift):
    rp = Replanner(light_lift, backend="stagewise")
    before = rp.last.q.copy()
    rti = RealTimeIteration(rp)
    late = rti.step(deadline_s=1e-7)  # a deadline no tick can meet
    assert not late.published and late.reason == "deadline"
    np.testing.assert_array_equal(late.q, before)  # the plan in force is the last published one
    strict = RealTimeIteration(rp, violation_tol=1e-14)
    bad = strict.step(mass=2.7)  # the step after a jump leaves pose errors far above 1e-14
    assert not bad.published and bad.reason == "violation" and bad.violation > 1e-14
    np.testing.assert_array_equal(bad.q, before)
    assert rti.misses == {"deadline": 1} and strict.misses == {"violation": 1}


def test_backend_validation_and_fallback():
    with pytest.raises(InvalidInputError, match="backend: expected one of ipopt, stagewise, got 'fatrop'"):
        SolverOptions(backend="fatrop")
    with pytest.raises(InvalidInputError, match="stagewise backend"):
        RealTimeIteration(Replanner(load_task(TASKS / "lift.yaml", waypoints=10)))


def test_the_stagewise_backend_leaves_the_spline_rows_to_ipopt(capsys):
    """Without spline rows of its own, the stagewise backend solves a plan's waypoint rows when
    ``limits.on_spline`` is null (the default), and hands a task that sets it true to IPOPT."""
    task = load_task(TASKS / "lift.yaml", waypoints=12)
    for asked, handled in ((None, True), (True, False), (False, True)):
        limits = replace(task.limits, on_spline=asked)
        opt = TrajectoryOptimizer(task.robot, task.n, "forte", task.weights, limits=limits,
                                  options=replace(task.solver, backend="stagewise"))
        assert opt.on_spline == (asked is not False)
        assert (opt.stagewise() is not None) == handled
    assert "the stagewise solver does not handle the executed spline's rows (limits.on_spline: true)" \
        in capsys.readouterr().err


def test_banded_and_dense_reduced_systems_agree(monkeypatch):
    """The banded factorization with the dense rows by Woodbury (long horizons) and the dense one
    reach the same optimum, on a horizon whose J5 has lifted rows (the banded weighting)."""
    import forte.planning.nlp.solvers.interior_point as ipm

    task = load_task(TASKS / "lift.yaml", waypoints=70)
    results = {}
    for limit in (10_000, 10):
        monkeypatch.setattr(ipm, "DENSE_VARIABLES", limit)
        _, stagewise = _optimizers(task)
        results[limit] = _solve(stagewise, task)
        assert stagewise.stagewise().ip.system.banded == (limit == 10)
        assert stagewise.stagewise().problem.g.size  # there are dense rows to add by Woodbury
    dense, banded = results[10_000], results[10]
    assert dense.success and banded.success
    np.testing.assert_allclose(banded.q, dense.q, atol=1e-6)
    assert banded.objective == pytest.approx(dense.objective, rel=1e-10)


def test_forte_plan_with_the_stagewise_solver(tmp_path):
    """The command line: `--solver stagewise` plans with it and plan.json says which solver ran; a
    scene hands the problem to IPOPT (with one notice), recorded too."""
    import json
    import subprocess
    import sys

    out = tmp_path / "lift"
    run = subprocess.run([sys.executable, "-m", "forte.cli", "plan", str(TASKS / "lift.yaml"), "--solver", "stagewise",
                          "--no-figures", "--out", str(out)], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert json.loads((out / "plan.json").read_text())["solver"]["backend"] == "stagewise"
    crate = tmp_path / "crate"
    run = subprocess.run([sys.executable, "-m", "forte.cli", "plan", str(TASKS / "around-the-crate.yaml"), "--solver",
                          "stagewise", "--waypoints", "15", "--no-figures", "--allow-infeasible", "--out", str(crate)],
                         capture_output=True, text=True)
    assert "the stagewise solver does not handle a scene's clearance rows; solving with IPOPT" in run.stderr
    assert json.loads((crate / "plan.json").read_text())["solver"]["backend"] == "ipopt"
    bad = subprocess.run([sys.executable, "-m", "forte.cli", "plan", str(TASKS / "lift.yaml"), "--solver", "fatrop"],
                         capture_output=True, text=True)
    assert bad.returncode == 2 and "invalid choice: 'fatrop'" in bad.stderr


@pytest.mark.parametrize("method", ["manipulability", "rfp-radius", "rfp-cone", "static-polytope"])
def test_every_optimized_method_solves_the_same_with_both_backends(method):
    """The baselines' stage terms (rfp-cone's per-waypoint rays among them) on the same fast path."""
    task = waypoint_rows(load_task(TASKS / "lift.yaml", waypoints=25))
    make = lambda backend: TrajectoryOptimizer(  # noqa: E731
        task.robot, task.n, method, task.weights, options=replace(task.solver, backend=backend), limits=task.limits)
    a, b = _solve(make("ipopt"), task), _solve(make("stagewise"), task)
    assert a.success and b.success and b.backend == "stagewise"
    np.testing.assert_allclose(b.q, a.q, atol=1e-5)
    assert b.objective == pytest.approx(a.objective, rel=1e-7)


def test_the_wrench_term_solves_the_same_with_both_backends():
    """An offset payload (issue 25's wrench term, its per-waypoint moment given by the caller)."""
    task = waypoint_rows(load_task(TASKS / "offset-payload.yaml", waypoints=25))
    plans = [plan(replace(task, solver=replace(task.solver, backend=b, refine_rounds=0)), "forte")
             for b in ("ipopt", "stagewise")]
    assert plans[1].solver["backend"] == "stagewise" and "wrench_capability" in plans[1].solver["cost_terms"]
    np.testing.assert_allclose(plans[1].q, plans[0].q, atol=1e-5)
    np.testing.assert_allclose(plans[1].metrics["d"], plans[0].metrics["d"], atol=1e-4)


def test_kernels_without_a_compiler_give_the_same_numbers():
    """The horizon loop over the compiled kernels and its fallback (CasADi's mapped virtual-machine
    functions, used without a C compiler) agree on every kernel."""
    from forte.planning.nlp.kernels import build_kernels
    from forte.planning.nlp.solvers.native import StageKernels

    task = load_task(TASKS / "lift.yaml", waypoints=12)
    opt, _ = _optimizers(task)
    native = StageKernels(opt.kernels)
    vm = dict(build_kernels(task.robot, "forte", task.settings))
    virtual = StageKernels(type(opt.kernels)(*(vm[k] for k in ("stage_cost", "stage_grad", "stage_hess",
                                                                "stage_terms", "pose", "pose_jac", "pose_hess")),
                                            "virtual-machine"))
    assert native.native and not virtual.native
    pb = StagewiseSolver(opt.stage_nlp()).problem
    f = task.force()
    data = pb.task_data(task.t, task.targets, f.f, f.r, task.q_init, task.nominal())
    rng = np.random.default_rng(5)
    x = pb.x_of(pb.y_of(start_guess(task, task.nominal())) + 0.05 * rng.standard_normal(pb.ny), data)
    z = pb._win(x, data)
    for name in ("cost", "grad", "hess"):
        a, b = (getattr(k, name)(task.n, z, *data.stage_args)[0] for k in (native, virtual))
        np.testing.assert_allclose(a, b, rtol=1e-10, atol=1e-10)
    q = x.reshape(task.n, -1)
    lam = rng.standard_normal((task.n, 6))
    for name, extra in (("pose", ()), ("pose_jac", ()), ("pose_hess", (lam,))):
        args = (q, data.p_d, data.R_d, *extra)
        np.testing.assert_allclose(getattr(native, name)(task.n, *args)[0], getattr(virtual, name)(task.n, *args)[0],
                                   rtol=1e-10, atol=1e-10)


@pytest.mark.parametrize("name, waypoints", [("lift.yaml", 41), ("lift.yaml", 70), ("hold.yaml", None)])
def test_the_compiled_newton_step_equals_numpys(name, waypoints):
    """The step in C (:mod:`forte.planning.nlp.solvers.native_step`) and in NumPy give the same
    direction, multipliers and inertia correction: at the start of the lift (where the Hessian is
    indefinite) with J5's dense blocks coupling distant waypoints (N = 41), with J5's lifted rows
    (N = 70), and at the holding point (one free block)."""
    from forte.planning.nlp.solvers.interior_point import InteriorPoint

    task = load_task(TASKS / name, waypoints=waypoints)
    _, opt = _optimizers(task)
    solver = opt.stagewise()
    pb, ip = solver.problem, solver.ip
    if ip.native is None:
        pytest.skip("no C compiler: the NumPy step is the only one")
    plain = InteriorPoint(pb, use_native=False)
    f, nominal = task.force(), task.nominal()
    data = pb.task_data(task.t, task.targets, f.f, f.r, task.q_init, nominal)
    it = ip.start(pb.y_of(start_guess(task, nominal)), data)
    ev = ip.evaluate(it, data)
    ev.extras["hess"] = it.scale * pb.stage_hessians(it.y, data)
    fast, slow = ip.step(it, ev, data, it.mu), plain.step(it, ev, data, it.mu)
    scale = max(1.0, np.abs(slow[0]).max())
    np.testing.assert_allclose(fast[0], slow[0], atol=1e-10 * scale)
    np.testing.assert_allclose(fast[1], slow[1], atol=1e-8 * max(1.0, np.abs(slow[1]).max()))
    assert fast[2] == slow[2]
    if waypoints is not None:  # J5's wide coupling (41) or its lifted rows (70) are exercised
        assert (pb.Wy.nnz > 0, pb.g.size > 0) == (waypoints == 41, waypoints == 70)
