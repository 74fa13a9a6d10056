"""Re-planning benchmark (issue 14). Prints its figures; nothing is asserted.

Run: python benchmarks/bench_replan.py [--replans 60] [--waypoints 41] [--seed 0] [--no-check] [--sqp]
     [--ipopt-only] [--no-cold]

Each case runs with IPOPT's converged re-plan, the stagewise solver's converged re-plan and one
real-time iteration (:mod:`forte.planning.online.realtime`, from the converged solution of the last mass),
in the same run, with their ratios; then the 0.35 -> 2.7 kg jump followed by consecutive real-time
iterations until converged, where a converged stagewise re-plan's time goes (kernel evaluations,
factorizations, the rest of the solve, outside the solve) and cold plans at N = 41 and 400 with
both solvers. The lines are named ``mass changes, converged (IPOPT)``, ``mass changes, converged
(stagewise)``, ``mass changes, one real-time iteration (stagewise)`` and likewise for the shifts.

On the authors' lift (``examples/tasks/lift.yaml``, N = 41), with a warm
:class:`forte.planning.online.replan.Replanner`:

1. payload-mass changes: a seeded sequence of masses between 0.3 and 3.3 kg, each re-plan
   starting from the previous solution;
2. the receding horizon: shifted one waypoint per re-plan (a fresh planner, not timed, when the
   horizon has run out);
3. the receding horizon with a new mass at each shift (what the closed loop does).

For each: the latency until the new trajectory is ready (``ReplanResult.latency_s``: new task
data and the solve), the whole ``replan``/``shift`` call with the plan's metrics and verdict
(wall and CPU time; median, p95, max),
IPOPT iterations, the path taken (warm IPOPT, cold retry, not converged) and the slowest
re-plans. With the check (default) every converged re-plan is compared with a cold solve of the
same problem (the planner's own ``plan`` for a mass change; the optimizer from the planner's
initial guess for a shift), after the timed loop: the largest joint difference is printed.

The machine's load average is printed before and after: on a shared machine wall time is
noisy. CPU time equals wall time when nothing else in the process runs (a re-plan uses one BLAS
thread, :mod:`forte.planning.nlp.blas`; the benchmark's untimed work too, so that no OpenBLAS worker
of a cold solve busy-waits into a timed re-plan); well above it means busy BLAS workers.

``--sqp`` runs the alternative the issue names, an SQP on the same exact derivatives with a
sparse QP solver (CasADi's ``sqpmethod`` with its bundled OSQP, the Hessian regularized to make
the QPs convex), from the same warm primal-dual point: the Lagrangian Hessian is indefinite after
a mass change (IPOPT's inertia correction perturbs it in the first steps too), and the globally
regularized one gives steps of ~1e-3 rad, so it does not converge in 50 iterations where warm
IPOPT takes 3-12 (7 for this change).
"""

from __future__ import annotations

import argparse
import os
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np

from forte.planning.nlp.blas import single_threaded_blas
from forte.planning.online.realtime import RealTimeIteration, RealTimeStep
from forte.planning.online.replan import Replanner, ReplanResult, converged
from forte.planning.planner import plan
from forte.planning.solve import start_guess
from forte.planning.tasks.tasks import Task, load_task

LIFT = Path(__file__).resolve().parents[1] / "examples" / "tasks" / "lift.yaml"


def load() -> str:
    return "load average {:.2f} {:.2f} {:.2f}".format(*os.getloadavg())


class Series:
    """Latencies, iterations and paths of one kind of re-plan."""

    def __init__(self, name: str) -> None:
        self.name, self.wall, self.cpu, self.iters, self.labels, self.whole = name, [], [], [], [], []
        self.paths = {"warm IPOPT": 0, "cold retry": 0, "not converged": 0}
        self.deviation = 0.0

    def add(self, label: str, call: Callable[[], ReplanResult]) -> ReplanResult:
        cpu, wall = time.process_time(), time.perf_counter()
        result = call()
        self.cpu.append(time.process_time() - cpu)
        self.whole.append(time.perf_counter() - wall)
        self.wall.append(result.latency_s)
        self.iters.append(result.iterations)
        self.labels.append(label)
        path = "not converged" if not result.plan.solved else "warm IPOPT" if result.warm else "cold retry"
        self.paths[path] += 1
        return result

    def report(self) -> None:
        def stats(values: list[float]) -> str:
            ms = 1000 * np.asarray(values)
            return f"median {np.median(ms):.1f} ms, p95 {np.percentile(ms, 95):.1f} ms, max {ms.max():.1f} ms"

        it = np.asarray(self.iters)
        print(f"{self.name}: {len(it)} re-plans")
        print(f"  latency (wall, until the new trajectory is ready): {stats(self.wall)}")
        print(f"  the whole call with the plan's metrics and verdict (wall): {stats(self.whole)}; (CPU): "
              f"{stats(self.cpu)}")
        print(f"  IPOPT iterations: median {np.median(it):.0f}, p95 {np.percentile(it, 95):.0f}, max {it.max()}; "
              f"ms per iteration (wall, median) {np.median(1000 * np.asarray(self.wall) / np.maximum(it, 1)):.1f}")
        print("  path: " + ", ".join(f"{k} {v}" for k, v in self.paths.items()))
        slow = np.argsort(self.wall)[-3:][::-1]
        print("  slowest: " + "; ".join(f"{self.labels[i]} {1000 * self.wall[i]:.0f} ms, {it[i]} it" for i in slow))
        if self.deviation:
            print(f"  max |q - q_cold| over converged re-plans: {self.deviation:.1e} rad/m")


def cold_solve(planner: Replanner, problem: tuple) -> np.ndarray | None:
    """A cold solve of a re-planned problem (task, force, nominal) from the planner's initial guess."""
    task, force, nominal = problem
    sol = planner.optimizer.solve(task.t, task.targets, force.f, force.r, task.q_init,
                                  start_guess(task, nominal), nominal, start=task.start_motion)
    return sol.q if converged(sol) else None


def masses(args: argparse.Namespace, task: Task, planner: Replanner, name: str = "mass changes") -> Series:
    series, previous, done = Series(f"{name} (0.3-3.3 kg, seeded)"), task.payload.mass, []
    for mass in np.random.default_rng(args.seed).uniform(0.3, 3.3, args.replans):
        r = series.add(f"{previous:.2f}->{mass:.2f} kg", lambda m=float(mass): planner.replan(mass=m))
        previous = mass
        if r.plan.solved:
            done.append((float(mass), r.plan.q))
    for mass, q in done if args.check else ():  # after the timed loop: its BLAS threads stay out of it
        cold = plan(task.with_payload(task.payload.with_mass(mass)), "forte")
        series.deviation = max(series.deviation, float(np.abs(cold.q - q).max()))
    series.report()
    return series


def receding(args: argparse.Namespace, task: Task, with_mass: bool, backend: str = "ipopt") -> Series:
    name = "receding horizon, one waypoint per re-plan" + (", new mass each time" if with_mass else "")
    name += ", converged" + ("" if backend == "ipopt" else f" ({backend})")
    series, planner, moved, done = Series(name), Replanner(task, backend=backend), 0, []
    rng = np.random.default_rng(args.seed + 1)
    for _ in range(args.replans):
        if moved >= task.n - 3:  # the horizon has run out: start again (not timed)
            planner, moved = Replanner(task, backend=backend), 0
        mass = float(rng.uniform(0.3, 3.3)) if with_mass else None
        label = f"shift {moved}->{moved + 1}" + (f", {mass:.2f} kg" if with_mass else "")
        r = series.add(label, lambda m=mass, p=planner: p.shift(1, mass=m))
        moved += 1
        if r.plan.solved:
            done.append((planner, (planner.task, planner.force, planner.nominal), r.plan.q))
    for owner, problem, q in done if args.check else ():
        cold = cold_solve(owner, problem)
        if cold is not None:
            series.deviation = max(series.deviation, float(np.abs(cold - q).max()))
    series.report()
    return series


def sqp_probe(task: Task, planner: Replanner, mass: float = 0.5, max_iter: int = 50) -> None:
    """SQP (CasADi sqpmethod + OSQP) on the optimizer's exact derivatives from the warm point."""
    import casadi as ca

    opt, first = planner.optimizer, planner.last
    o, nlp = opt._nlp_options, opt._nlp
    x, p = ca.MX.sym("x", nlp["x"].numel()), ca.MX.sym("p", nlp["p"].numel())
    lam_f, lam_g = ca.MX.sym("lam_f"), ca.MX.sym("lam_g", nlp["g"].numel())
    f, grad = o["grad_f"](x, p)
    g, jac = o["jac_g"](x, p)
    options = {
        "jac_fg": ca.Function("nlp_jac_fg", [x, p], [f, grad.T, g, jac], ["x", "p"], ["f", "jac_f_x", "g", "jac_g_x"]),
        "hess_lag": ca.Function("nlp_hess_l", [x, p, lam_f, lam_g], [ca.triu2symm(o["hess_lag"](x, p, lam_f, lam_g))],
                                ["x", "p", "lam_f", "lam_g"], ["hess_gamma_x_x"]),
        "qpsol": "osqp", "convexify_strategy": "regularize", "max_iter": max_iter, "tol_pr": 1e-6, "tol_du": 1e-6,
        "print_time": False, "print_header": False, "print_iteration": False, "calc_lam_x": True,
        "qpsol_options": {"error_on_fail": False, "osqp": {"verbose": False, "eps_abs": 1e-9, "eps_rel": 1e-9}},
    }
    solver = ca.nlpsol("sqp", "sqpmethod", nlp, options)
    heavy = task.with_payload(task.payload.with_mass(mass))
    force = heavy.force()
    bounds = opt.bounds(heavy.t, heavy.q_init)  # as TrajectoryOptimizer.solve sets them (lifted variables too)
    start = time.perf_counter()
    out = solver(x0=opt.full_x(first.q), p=opt.parameters(heavy.t, heavy.targets, force.f, force.r, planner.nominal),
                 **bounds._asdict(), lam_x0=first.lam_x, lam_g0=first.lam_g)
    wall = time.perf_counter() - start
    stats = solver.stats()
    ref = planner.replan(mass=mass)
    q = np.asarray(out["x"]).ravel()[: task.n * task.robot.nq]
    print(f"SQP (sqpmethod + OSQP) {task.payload.mass} -> {mass} kg from the warm point: {stats['return_status']}, "
          f"{stats['iter_count']} iterations, {1000 * wall:.0f} ms; max |q - q_IPOPT| "
          f"{np.abs(q - ref.plan.q.ravel()).max():.1e} "
          f"(warm IPOPT: {ref.iterations} iterations, {1000 * ref.latency_s:.0f} ms)")


class Ticks:
    """Latencies of real-time iterations (one Newton step each)."""

    def __init__(self, name: str) -> None:
        self.name, self.wall, self.cpu, self.published, self.misses = name, [], [], 0, {}

    def add(self, call: Callable[[], RealTimeStep]) -> RealTimeStep:
        cpu = time.process_time()
        step = call()
        self.cpu.append(time.process_time() - cpu)
        self.wall.append(step.latency_s)
        self.published += step.published
        if step.reason:
            self.misses[step.reason] = self.misses.get(step.reason, 0) + 1
        return step

    def report(self) -> None:
        print(f"{self.name}: {len(self.wall)} steps")
        print(f"  latency (wall): {stats(self.wall)}")
        print(f"  latency (CPU):  {stats(self.cpu)}")
        print(f"  published {self.published}; not published: {self.misses or 'none'}")


def stats(values: list[float]) -> str:
    ms = 1000 * np.asarray(values)
    return f"median {np.median(ms):.1f} ms, p95 {np.percentile(ms, 95):.1f} ms, max {ms.max():.1f} ms"


def rti_masses(args: argparse.Namespace, task: Task) -> Ticks:
    """One real-time iteration after each mass change, from the converged solution of the last
    mass (converged again, untimed, before the next change)."""
    ticks, planner = Ticks("mass changes, one real-time iteration (stagewise)"), Replanner(task, backend="stagewise")
    rti = RealTimeIteration(planner)
    for mass in np.random.default_rng(args.seed).uniform(0.3, 3.3, args.replans):
        ticks.add(lambda m=float(mass): rti.step(mass=m))
        planner.replan()  # back to a converged solution of this mass (not timed)
    ticks.report()
    return ticks


def rti_receding(args: argparse.Namespace, task: Task, with_mass: bool) -> Ticks:
    name = "receding horizon, one real-time iteration per shift" + (", new mass each time" if with_mass else "")
    ticks, planner, moved = Ticks(name + " (stagewise)"), Replanner(task, backend="stagewise"), 0
    rti = RealTimeIteration(planner)
    rng = np.random.default_rng(args.seed + 1)
    for _ in range(args.replans):
        if moved >= task.n - 3:  # the horizon has run out: start again (not timed)
            planner, moved = Replanner(task, backend="stagewise"), 0
            rti = RealTimeIteration(planner)
        mass = float(rng.uniform(0.3, 3.3)) if with_mass else None
        ticks.add(lambda m=mass, r=rti: r.step(mass=m, steps=1))
        moved += 1
    ticks.report()
    return ticks


def jump(task: Task, start: float = 0.35, end: float = 2.7) -> None:
    """Consecutive real-time iterations after a jump of the payload mass, until converged."""
    light = task.with_payload(task.payload.with_mass(start))
    rti = RealTimeIteration(Replanner(light, backend="stagewise"))
    steps = [rti.step(mass=end)]
    while not steps[-1].converged and len(steps) < 100:
        steps.append(rti.step())
    first = next((i for i, st in enumerate(steps) if st.published), None)
    print(f"{start} -> {end} kg jump, real-time iterations: converged after {len(steps) - 1} steps "
          f"(the {len(steps)}th found nothing left to do); the first published step was step {first}; "
          f"KKT error by step: " + ", ".join(f"{st.kkt_error:.0e}" for st in steps))


def time_split(task: Task, replans: int, seed: int) -> None:
    """Where a converged stagewise re-plan's time goes (mass changes)."""
    planner = Replanner(task, backend="stagewise")
    solver = planner.optimizer.stagewise()
    clock, seconds = solver.problem.kernels.clock, solver.ip.seconds
    clock[0], total, inside = 0.0, 0.0, 0.0
    seconds.clear()
    native = solver.ip.native
    compiled = native.clock if native is not None else [0.0]
    compiled[0] = 0.0
    for mass in np.random.default_rng(seed).uniform(0.3, 3.3, replans):
        r = planner.replan(mass=float(mass))
        total += r.latency_s
        inside += r.solve_s
    kernels, factor, step = clock[0], seconds["factorization"], compiled[0]
    rest = inside - kernels - factor - step
    print(f"where a converged stagewise re-plan's time goes ({replans} mass changes, {1000 * total / replans:.1f} ms "
          f"each): kernel evaluations (cost, gradient, Hessian, pose rows) {100 * kernels / total:.0f} %, "
          f"the compiled step around the factorization {100 * step / total:.0f} %"
          f"{'' if native is not None else ' (not compiled: NumPy)'}, Cholesky factorizations "
          f"{100 * factor / total:.0f} %, the rest of the solve (line search, NumPy and Python) "
          f"{100 * rest / total:.0f} %, outside the solve (task data, plan metrics) "
          f"{100 * (total - inside) / total:.0f} %")


def step_cost(task: Task, mass: float = 3.3, repeats: int = 300) -> None:
    """One Newton step of the stagewise solver (everything but the kernels' evaluation) after a
    mass change, compiled (:mod:`forte.planning.nlp.solvers.native_step`) and in NumPy."""
    from forte.planning.nlp.solvers.interior_point import InteriorPoint

    planner = Replanner(task, backend="stagewise")
    solver = planner.optimizer.stagewise()
    pb, it = solver.problem, planner.last.iterate
    force = task.with_payload(task.payload.with_mass(mass)).force()
    data = pb.task_data(task.t, task.targets, force.f, force.r, task.q_init, planner.nominal)
    ev = solver.ip.evaluate(it, data)
    ev.extras["hess"] = it.scale * pb.stage_hessians(it.y, data)
    line = []
    for label, ip in (("compiled", solver.ip), ("NumPy", InteriorPoint(pb, use_native=False))):
        if label == "compiled" and ip.native is None:
            continue
        times = []
        for _ in range(repeats):
            ip.system.reset()  # the same inertia correction each time
            begin = time.perf_counter()
            delta = ip.step(it, ev, data, it.mu)[2]
            times.append(time.perf_counter() - begin)
        line.append(f"{label} {1000 * np.median(times):.2f} ms")
    print(f"one Newton step after a change to {mass} kg (factorizations with inertia correction delta = {delta:g} "
          f"included, kernels not), median of {repeats}: " + ", ".join(line))


def metrics_cost(task: Task, repeats: int = 50) -> None:
    """The plan's exact metrics (``forte.planning.verdict.evaluation.evaluate``), which a re-plan computes
    after its latency is taken, as it does the verdict."""
    from forte.planning.verdict.evaluation import evaluate

    planner = Replanner(task, backend="stagewise")
    q, force = planner.last.q, planner.force
    times = []
    for _ in range(repeats):
        begin = time.perf_counter()
        evaluate(task.robot, q, task.t, force, task.settings.capability_params)
        times.append(time.perf_counter() - begin)
    print(f"the plan's exact metrics (after the latency, with the verdict), median of {repeats}: "
          f"{1000 * np.median(times):.2f} ms")


def ratio(name: str, fast: Series | Ticks, reference: Series) -> None:
    print(f"{name}: median {np.median(reference.wall) / np.median(fast.wall):.1f}x faster than IPOPT's converged "
          f"re-plan ({1000 * np.median(fast.wall):.1f} ms against {1000 * np.median(reference.wall):.1f} ms)")


def cold_plans(task: Task) -> None:
    for n in (41, 400):
        t = task if n == task.n else load_task(LIFT, waypoints=n)
        line = []
        for backend in ("ipopt", "stagewise"):
            tk = replace(t, solver=replace(t.solver, backend=backend, refine_rounds=0))
            plan(tk, "forte")  # build and compile once (not timed)
            p = plan(tk, "forte")
            line.append(f"{backend} {1000 * p.solver['solve_time_s']:.0f} ms solve, {p.solver['iterations']} "
                        f"iterations ({p.status})")
        print(f"cold plan of the lift at N = {n}: " + "; ".join(line))


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--replans", type=int, default=60)
    parser.add_argument("--waypoints", type=int, default=41)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--no-check", dest="check", action="store_false",
                        help="skip the (untimed) cold solves the re-plans are compared with")
    parser.add_argument("--sqp", action="store_true", help="also run the SQP + OSQP probe (see the docstring)")
    parser.add_argument("--ipopt-only", action="store_true", help="only IPOPT's re-plans (the figures before issue 29)")
    parser.add_argument("--no-cold", dest="cold", action="store_false",
                        help="skip the cold plans at N = 41 and 400 (IPOPT and stagewise)")
    args = parser.parse_args()
    print(load())
    task = load_task(LIFT, waypoints=args.waypoints)
    start = time.perf_counter()
    planner = Replanner(task)
    print(f"lift, N = {task.n}, {task.payload.mass} kg: first solve (build + cold) "
          f"{time.perf_counter() - start:.2f} s, {planner.last.iterations} iterations")
    cold = plan(task, "forte")
    print(f"cold `plan` of the same task: {cold.solver['solve_time_s'] * 1000:.0f} ms solve, "
          f"{cold.solver['iterations']} iterations")
    if args.sqp:
        sqp_probe(task, Replanner(task))
    ipopt = masses(args, task, planner, "mass changes, converged (IPOPT)")
    if args.ipopt_only:
        receding(args, task, with_mass=False)
        receding(args, task, with_mass=True)
        print(load())
        return
    fast = masses(args, task, Replanner(task, backend="stagewise"), "mass changes, converged (stagewise)")
    rti = rti_masses(args, task)
    ratio("mass changes, converged (stagewise)", fast, ipopt)
    ratio("mass changes, one real-time iteration", rti, ipopt)
    jump(task)
    for with_mass in (False, True):
        shift_ipopt = receding(args, task, with_mass)
        shift_fast = receding(args, task, with_mass, backend="stagewise")
        shift_rti = rti_receding(args, task, with_mass)
        label = "shift" + (" with a new mass" if with_mass else "")
        ratio(f"{label}, converged (stagewise)", shift_fast, shift_ipopt)
        ratio(f"{label}, one real-time iteration", shift_rti, shift_ipopt)
    time_split(task, args.replans, args.seed)
    step_cost(task)
    metrics_cost(task)
    if args.cold:
        cold_plans(task)
    print(load())


if __name__ == "__main__":
    with single_threaded_blas():  # the untimed cold solves too: no BLAS worker left busy-waiting
        main()
