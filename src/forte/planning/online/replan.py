"""Warm re-planning: keep the compiled problem and the last primal-dual solution, re-solve fast.

A :class:`Replanner` builds the NLP of one task once (its horizon ``N`` fixed) and solves it.
After a change of payload mass, force profile, targets or start configuration it re-solves
from the last solution: the configurations as the initial guess and the last bound and
constraint multipliers as IPOPT's warm start (barrier parameter ``tol / 10``, tiny bound pushes:
:meth:`~forte.planning.nlp.optimizer.TrajectoryOptimizer.warm_solver`), so a re-plan takes a handful
of full Newton steps instead of tens of iterations.

The problem re-solved is the planner's own (:func:`forte.planning.planner.plan`): same cost,
constraints and nominal trajectory (the task's: from its taught configurations, or derived
again by IK when new targets or a new start change it; never the last solution, which would
make each re-plan depend on the ones before it). So a converged re-plan is a cold plan of the
changed task, reached from a better start, with one difference for a hold task: :func:`plan`
keeps the best of ``solver.hold_starts`` starts, a re-plan continues from the last solution.
And one for every task whose ``limits.on_spline`` is null (the default): the re-planner bounds
velocities and accelerations at the waypoints only, as if it were false, where ``forte plan``
bounds them on the executed spline too (:mod:`forte.planning.nlp.spline_rows`: those rows
tripled a warm re-plan's latency, 67 -> 195 ms in ``forte experiment mpc``); a task that sets it
true gets them online too.

:meth:`Replanner.shift` moves the horizon forward (receding horizon): the targets, the nominal
trajectory, the guess and the multipliers are shifted by whole waypoints and the tail holds the
last target, so ``N`` and the compiled problem stay the same.

With a scene, the problem carries clearance rows for the pairs near the last solution
(:mod:`forte.planning.nlp.collision_slots`): a re-plan after a change keeps them and starts warm; when
its solution brings another pair close, or after a shift (the pairs move with the horizon), the
rows are assigned again and that problem is solved cold.

Every re-plan is judged as ``forte plan`` judges a plan (:func:`forte.planning.verdict.verdict.judge_plan`:
the waypoints and the spline at ``SAMPLES_PER_INTERVAL`` samples per interval), after its latency
is taken (``ReplanResult.verdict_s``: about 25 ms at N = 41, 11 ms of it the waypoints'). It gets
no refinement rounds (:func:`forte.planning.planner.plan`'s), so a converged re-plan can be
infeasible along the spline; what a loop does with one is the loop's choice
(:data:`forte.execution.closed_loop.ON_INFEASIBLE`).

Converged means IPOPT's ``Solve_Succeeded`` (its ``tol`` on the scaled KKT error, no
"acceptable level" exit) with the constraint violation within ``constraint_tol``. A warm try that
does not converge is retried once from the cold initial guess; if that fails too the result says
so (``success`` false) and the last good solution is kept: a re-plan never returns an
unconverged plan as a success.

The solver is the task's (``solver.backend``, or ``backend=``): IPOPT, warm-started from the last
primal-dual point, or the stagewise interior-point method (:mod:`forte.planning.nlp.solvers`), which
takes the same Newton steps with a factorization of the null-space reduced system and warm-starts
from its last iterate; :mod:`forte.planning.online.realtime` takes one of those steps per call (real-time
iterations). The sparse QP solvers (OSQP, proxsuite) need a convex Hessian, which the capability
terms' Lagrangian Hessian is not (``benchmarks/bench_replan.py --sqp``: CasADi's SQP with OSQP and
a regularized Hessian does not converge in 50 iterations). The re-plan runs with one BLAS thread
(:mod:`forte.planning.nlp.blas`).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import replace
from typing import Any, NamedTuple

import numpy as np

from forte.exceptions import InvalidInputError
from forte.force.taskforce import TaskForce
from forte.model.trajectory import StartMotion, motion_at
from forte.planning.methods.catalog import get_method
from forte.planning.nlp.blas import single_threaded_blas
from forte.planning.nlp.collision_slots import assign_slots, missing_pairs
from forte.planning.nlp.layout import shift_rows
from forte.planning.nlp.optimizer import SolverResult, TrajectoryOptimizer
from forte.planning.planner import Plan, evaluate, resolve_payload
from forte.planning.scene.scene_solve import solve_in_scene
from forte.planning.solve import start_guess
from forte.planning.tasks.tasks import Task
from forte.planning.tasks.terms_section import term_values, with_task_terms
from forte.planning.terms.wrench_terms import for_requirement
from forte.planning.verdict.verdict import judge_plan
from forte.validation import FloatArray

#: IPOPT's status of a solve converged to its ``tol`` (its "acceptable level" exit is not).
CONVERGED = "Solve_Succeeded"


class ReplanResult(NamedTuple):
    """One re-plan: the plan, its latency and how it was reached."""

    plan: Plan
    latency_s: float  # until the new trajectory is ready: new task data, solve(s) (not its metrics, verdict)
    iterations: int  # IPOPT iterations, the cold retry's included
    warm: bool  # solved from the last primal-dual point (else: a cold retry)
    solve_s: float = 0.0  # time inside IPOPT's solve calls
    verdict_s: float = 0.0  # after the latency: the plan's metrics and its verdict (``forte plan``'s)


class Problem(NamedTuple):
    """A changed problem: the task, its force, nominal trajectory, primal guess and multipliers
    (``None``: a cold solve), and the NLP to solve it with (``None``: the re-planner's)."""

    task: Task
    force: TaskForce
    nominal: FloatArray
    guess: FloatArray
    warm: tuple[FloatArray, FloatArray] | Any | None  # IPOPT's multipliers or a stagewise iterate
    optimizer: TrajectoryOptimizer | None = None


def converged(sol: SolverResult) -> bool:
    """IPOPT converged to ``tol`` and the constraints hold (see the module docstring)."""
    return sol.success and sol.status == CONVERGED


class Replanner:
    """Plans ``task`` once and re-plans it quickly after changes (see the module docstring).

    Args:
        task: A trajectory task (payload resolved or resolvable).
        method: An optimized method.
        estimator_options: For a payload that still needs a mass estimate.
    """

    def __init__(self, task: Task, method: str = "forte", estimator_options: dict[str, Any] | None = None,
                 backend: str | None = None) -> None:
        if backend is not None:
            task = replace(task, solver=replace(task.solver, backend=backend))
        self.method = get_method(method)
        if not self.method.optimized:
            raise InvalidInputError(f"method: re-planning needs an optimized method, got '{self.method.name}'")
        if task.limits.on_spline is None:  # online: the waypoint rows (the spline rows tripled a re-plan's latency)
            task = replace(task, limits=replace(task.limits, on_spline=False))
        self.task = resolve_payload(task, estimator_options)
        self.force = self.task.force()
        # as the planner solves it: J1 on the wrench when the payload has a moment, the task's terms
        self.method = with_task_terms(for_requirement(self.method, self.force), self.task.terms)
        self.nominal = self.task.nominal()  # the planner's nominal trajectory, shifted with the horizon
        guess = start_guess(self.task, self.nominal)
        if self.task.scene:  # clearance rows for the pairs near the first solution (planner.solve_in_scene)
            self.optimizer, first, _ = solve_in_scene(self.task, self.method, self.force, guess, self.nominal,
                                                      task.solver, keep_multipliers=True)
        else:
            self.optimizer = TrajectoryOptimizer(
                task.robot, task.n, self.method, task.weights, fix_initial=task.mode != "hold",
                options=task.solver, limits=task.limits, keep_multipliers=True, settings=task.settings)
            first = self._solve(self.task, self.force, self.nominal, guess, None)
        if not converged(first):
            raise InvalidInputError(f"re-planning: the first solve failed ({first.status}); nothing to warm-start")
        self.last = first

    # -- changes ------------------------------------------------------------------------
    def replan(self, mass: float | None = None, force: TaskForce | None = None, targets: FloatArray | None = None,
               q_init: FloatArray | None = None) -> ReplanResult:
        """Re-solve after a new payload ``mass``, ``force`` profile, ``targets`` or start ``q_init``."""
        return self._run(lambda: self._changed(mass, force, targets, q_init))

    def shift(self, steps: int, q_now: FloatArray | None = None, mass: float | None = None,
              v_now: FloatArray | None = None, a_now: FloatArray | None = None) -> ReplanResult:
        """Move the horizon ``steps`` waypoints forward; the tail holds the last target.

        ``q_now`` (the measured configuration) becomes the new first waypoint (default: the
        planned one at the new start); ``mass``, when given, is the payload's new mass. The new
        first waypoint moves: with ``v_now`` (the measured velocity, nq) and ``a_now`` (nq), by
        default with the last plan's backward-difference velocity and acceleration there, so a
        plan continues its own motion (:mod:`forte.planning.nlp.history`; zeros give a start at rest).
        With ``force_model: authors`` the force blend goes on from where it was (no restart).
        """
        return self._run(lambda: self._shifted(steps, q_now, mass, v_now, a_now))

    def _changed(self, mass: float | None, force: TaskForce | None, targets: FloatArray | None,
                 q_init: FloatArray | None) -> Problem:
        """The problem after a change, to be solved from the last solution."""
        task = self.task
        if targets is not None:
            task = replace(task, targets=np.asarray(targets, dtype=float))
        if q_init is not None:
            task = replace(task, q_init=task.robot.check_configuration(q_init, "q_init"))
        if mass is not None:
            task = task.with_payload(task.payload.with_mass(mass, source="replan"))
        if force is None:
            force = task.force() if (mass is not None or targets is not None) else self.force
        nominal = self.nominal
        if task.knots is None and (targets is not None or q_init is not None):
            nominal = task.nominal()  # the IK path / pose the planner would derive from the new task
        guess = self.last.q.copy()
        guess[0] = task.q_init
        warm = self.last.iterate if self.last.iterate is not None else (self.last.lam_x, self.last.lam_g)
        return Problem(task, force, nominal, guess, warm)

    def _shifted(self, steps: int, q_now: FloatArray | None, mass: float | None,
                 v_now: FloatArray | None = None, a_now: FloatArray | None = None) -> Problem:
        """The problem ``steps`` waypoints further, to be solved from the last solution shifted."""
        n = self.task.n
        if not 0 < steps < n:
            raise InvalidInputError(f"steps: expected 0 < steps < {n}, got {steps}")
        start = self._start_at(steps, v_now, a_now)
        targets = shift_rows(self.task.targets, steps)
        guess = shift_rows(self.last.q, steps)
        guess[0] = guess[0] if q_now is None else self.task.robot.check_configuration(q_now, "q_now")
        # the new first waypoint is t[steps] of the old horizon: the authors' force blend goes on
        elapsed = self.task.force_ramp_elapsed + float(self.task.t[steps] - self.task.t[0])
        profile = self.task.force_profile
        if profile is not None:  # a given profile moves with the horizon, like the path
            profile = TaskForce(profile.t, shift_rows(profile.f, steps), shift_rows(profile.r, steps))
        task = replace(self.task, targets=targets, q_init=guess[0].copy(), force_ramp_elapsed=elapsed,
                       force_profile=profile, targets_at=_shifted_path(self.task, steps), start_motion=start)
        if mass is not None:
            task = task.with_payload(task.payload.with_mass(mass, source="replan"))
        force = task.force()
        if task.scene:  # the pairs near the shifted horizon get the rows: a new NLP, solved cold
            slots = assign_slots(task.robot, guess, task.scene, task.clearance, True)
            opt = TrajectoryOptimizer(task.robot, task.n, self.method, task.weights, options=task.solver,
                                      limits=task.limits, keep_multipliers=True, slots=slots,
                                      settings=task.settings)
            return Problem(task, force, shift_rows(self.nominal, steps), guess, None, opt)
        if self.last.iterate is not None:
            warm = self.optimizer.stagewise().shifted(self.last.iterate, steps)
        else:
            warm = self.optimizer.shifted_multipliers(self.last.lam_x, self.last.lam_g, steps)
        return Problem(task, force, shift_rows(self.nominal, steps), guess, warm)

    def _start_at(self, steps: int, v_now: FloatArray | None, a_now: FloatArray | None) -> StartMotion:
        """The motion of the new first waypoint: measured where given, else the last plan's (its
        backward differences at waypoint ``steps``, from the three waypoints up to it)."""
        planned = motion_at(self.last.q, self.task.t, steps, self.task.start_motion)
        if v_now is None and a_now is None:
            return planned
        return StartMotion.checked(planned.velocity if v_now is None else v_now,
                                   planned.acceleration if a_now is None else a_now, self.task.robot.nq, "v_now/a_now")

    # -- solving ------------------------------------------------------------------------
    def _run(self, change: Callable[[], Problem]) -> ReplanResult:
        """Build the changed problem, solve it warm (cold once more if needed), keep it if converged."""
        start = time.perf_counter()
        with single_threaded_blas():
            pb = change()
            opt = pb.optimizer or self.optimizer
            sol, used_warm = self._solve(pb.task, pb.force, pb.nominal, pb.guess, pb.warm, opt), pb.warm is not None
            iterations, solve_s = sol.iterations, sol.solve_time
            if converged(sol) and pb.task.scene and missing_pairs(pb.task.robot, sol.q, pb.task.scene,
                                                                  pb.task.clearance, opt.slots):
                # the solution came close to a pair without rows: solve again with it (cold)
                opt, sol, _ = solve_in_scene(pb.task, self.method, pb.force, sol.q, pb.nominal, pb.task.solver,
                                             keep_multipliers=True)
                used_warm, iterations, solve_s = False, iterations + sol.iterations, solve_s + sol.solve_time
            if not converged(sol):  # one cold retry before giving up
                cold = start_guess(pb.task, pb.nominal)
                sol, used_warm = self._solve(pb.task, pb.force, pb.nominal, cold, None, opt), False
                iterations, solve_s = iterations + sol.iterations, solve_s + sol.solve_time
        ok = converged(sol)
        if ok:
            self.task, self.force, self.nominal, self.last = pb.task, pb.force, pb.nominal, sol
            self.optimizer = opt
        latency = time.perf_counter() - start  # the new trajectory is ready for the controller
        # its report after that: the exact metrics (about 1 ms at N = 41) and the verdict
        with single_threaded_blas():
            metrics = evaluate(pb.task.robot, sol.q, pb.task.t, pb.force, pb.task.settings.capability_params,
                               start=pb.task.start_motion)
        plan = Plan(method=self.method.name, robot=pb.task.robot, t=pb.task.t, q=sol.q, force=pb.force,
                    payload=pb.task.payload, metrics=metrics, solved=ok, status=sol.status,
                    solver={"iterations": iterations, "warm": used_warm, "solve_time_s": solve_s,
                            "status": sol.status, "constraint_violation": sol.constraint_violation}, task=pb.task,
                    scene=pb.task.scene)
        plan.solver["latency_s"] = latency
        # judged as ``forte plan`` judges: at the waypoints and along the spline at
        # SAMPLES_PER_INTERVAL samples per interval (about 25 ms at N = 41), after the latency
        with single_threaded_blas():
            plan.verdict = judge_plan(pb.task, sol.q, pb.force, plan.solver)
        verdict_s = time.perf_counter() - start - latency
        plan.solver["verdict_s"] = verdict_s
        return ReplanResult(plan, latency, iterations, used_warm, solve_s, verdict_s)

    def _solve(self, task: Task, force: TaskForce, nominal: FloatArray, guess: FloatArray,
               warm: tuple[FloatArray, FloatArray] | Any | None, optimizer: TrajectoryOptimizer | None = None
               ) -> SolverResult:
        opt = optimizer or self.optimizer
        return opt.solve(task.t, task.targets, force.f, force.r, task.q_init, guess, nominal, warm=warm,
                         term_values=term_values(opt.method_spec, force, task.terms), start=task.start_motion)


def _shifted_path(task: Task, steps: int) -> Callable[[FloatArray], FloatArray] | None:
    """The task's path moved ``steps`` waypoints forward in time, holding its end: what the shifted
    targets sample (:func:`~forte.planning.nlp.layout.shift_rows`), so the verdict judges a shifted
    plan against the path it follows. A path that ends at rest holds its final pose over the
    original grid's last samples (:class:`forte.planning.tasks.paths.HeldPath`), here too."""
    path = task.targets_at
    if path is None:
        return None
    delta, end = float(task.t[steps] - task.t[0]), float(task.t[-1])

    def at(ts: FloatArray) -> FloatArray:
        return path(np.minimum(np.asarray(ts, dtype=float) + delta, end))

    return at
