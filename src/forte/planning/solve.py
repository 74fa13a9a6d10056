"""Solving a task with an optimized method: the initial guess (IK, or a start clear of the scene),
coarse-to-fine for long horizons, clearance rows when the world needs them, and several starts
for a hold. :func:`forte.planning.planner.plan` calls :func:`optimize`, then judges and refines."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import Any, NamedTuple

import numpy as np

from forte.force.taskforce import TaskForce
from forte.model.robot import N_BASE
from forte.planning.methods.catalog import Method
from forte.planning.nlp.budget import budget_of, once, solve_budget, spent_before
from forte.planning.nlp.optimizer import SolverResult, TrajectoryOptimizer, accepted_violation
from forte.planning.scene.diagnosis import failed_rows
from forte.planning.scene.scene_guess import clear_start
from forte.planning.scene.scene_solve import (
    floor_near,
    goal_configuration,
    goal_kind,
    goal_vias,
    needs_rows,
    solve_in_scene,
)
from forte.planning.tasks.ik import initial_guess
from forte.planning.tasks.tasks import Task
from forte.planning.tasks.terms_section import term_settings, term_values
from forte.planning.verdict.requirements import TRACKING_ORIENTATION_TOL, orientation_errors
from forte.validation import FloatArray

#: Trajectories longer than this are solved coarse-to-fine (see :func:`coarse_guess`).
COARSE_WAYPOINTS = 25
#: IPOPT's barrier settings for a start that is already near the optimum or on the constraints
#: (the coarse optimum, or the retry of :func:`_small_barrier_retry`).
SMALL_BARRIER = {"mu_strategy": "monotone", "mu_init": 1e-4}
#: Statuses that end a solve for its time budget: no retry (the budget is spent).
OUT_OF_TIME = ("Maximum_CpuTime_Exceeded", "Maximum_WallTime_Exceeded")


def coarse_guess(task: Task, method: Method) -> tuple[FloatArray, dict[str, Any]] | None:
    """Solve the same task on ``COARSE_WAYPOINTS`` samples and interpolate the result in time.

    A fine horizon makes the finite-difference accelerations stiff (``1 / dt^2``) and IPOPT slow
    from the IK guess; starting from the interpolated coarse optimum halves the iterations at
    N = 100 (see ``benchmarks/bench_planner.py``). The coarse problem has no rows on the executed
    spline (``limits.on_spline: false``): the fine solve has them, from the same start
    (the lift at N = 100: coarse IPOPT 0.08 -> 0.06 s of CPU, 9 -> 11 iterations; the fine
    solve's 8 iterations and plan unchanged, within 2e-15 rad/m). Returns ``None`` when it does
    not apply.
    """
    if task.mode != "trajectory" or task.n <= 2 * COARSE_WAYPOINTS or task.targets_at is None:
        return None
    coarse = task.resampled(COARSE_WAYPOINTS)
    coarse = replace(coarse, limits=replace(coarse.limits, on_spline=False))
    force = coarse.force()
    nominal = once("nominal", coarse, coarse.nominal)  # start_guess's IK path too
    # with a scene (or near the floor) clear of it already: the fine solve starts outside the bodies
    sol = solve_clear(coarse, method, force, start_guess(coarse, nominal), nominal, task.solver)[1]
    if not sol.success:
        return None
    q = np.column_stack([np.interp(task.t, coarse.t, sol.q[:, j]) for j in range(sol.q.shape[1])])
    q[0] = task.q_init
    return q, {"waypoints": coarse.n, "iterations": sol.iterations, "solve_time_s": sol.solve_time}


def goal_guess(task: Task) -> FloatArray:
    """A goal task's initial guess (N x nq): the straight line in configuration space from the start
    to the goal configuration (a pose goal: its IK solution from the start) at the sample times,
    with a quintic time law that rests at both ends (:func:`~forte.planning.tasks.goals.straight_line`).
    The one place a path search's motion would come in."""
    return task.goal.motion(task.q_init, task.t)


def start_guess(task: Task, nominal: FloatArray | None = None) -> FloatArray:
    """The optimizer's initial guess: the nominal trajectory for taught configurations (the
    authors' joint-space interpolation), a goal task's :func:`goal_guess`, else IK along the path /
    onto the pose; with a scene, base poses that keep the robot clear of it where
    :func:`~forte.planning.scene.scene_guess.clear_start` finds them (not for a goal task: its
    route was searched clear of the scene on the exact model, and the ring search, made for a
    prescribed path, would move its base off it)."""
    if task.goal is not None:  # its route (or straight line) keeps the clearance on the exact model already
        return goal_guess(task)
    if task.knots is not None:
        guess = task.nominal() if nominal is None else nominal
    elif task.mode == "hold" and task.teaching is not None:
        guess = initial_guess(task)
    else:  # a path of poses: its nominal is this IK path (Task.nominal), made once per plan
        guess = once("nominal", task, task.nominal)
    if task.scene and task.robot.base != "fixed":  # a start clear of the scene (a fixed base has no other)
        clear = clear_start(task, guess)
        return guess if clear is None else clear
    return guess


def _solve(opt: TrajectoryOptimizer, task: Task, force: TaskForce, q: FloatArray, nominal: FloatArray) -> SolverResult:
    return opt.solve(task.t, task.targets, force.f, force.r, task.q_init, q, nominal,
                     term_values=term_values(opt.method_spec, force, task.terms), start=task.start_motion,
                     q_goal=goal_configuration(task))


def solve_clear(task: Task, method: Method, force: TaskForce, q: FloatArray, nominal: FloatArray, options: Any,
                 opt: TrajectoryOptimizer | None = None, self_rows: bool = False
                 ) -> tuple[TrajectoryOptimizer, SolverResult, dict | None]:
    """Solve from ``q``: with clearance rows when the task has bodies or ``q`` comes near the floor
    (:func:`~forte.planning.scene.scene_solve.needs_rows`) or ``self_rows`` (the robot's own pairs, see
    :func:`_apart`), else in free space (on ``opt`` when given), and again with rows from a
    free-space solution that comes within the clearance of the floor. Returns the problem, its
    solution and the rows' facts (``None``: solved without rows)."""
    if self_rows or needs_rows(task, q):
        return solve_in_scene(task, method, force, q, nominal, options)
    if opt is None:
        opt = TrajectoryOptimizer(task.robot, task.n, method, task.weights, fix_initial=task.mode != "hold",
                                  options=options, limits=task.limits, settings=task.settings,
                                  goal=goal_kind(task), keep_level=task.keep_level, via_steps=goal_vias(task))
    sol = _solve(opt, task, force, q, nominal)
    if sol.success and floor_near(task, sol.q, task.clearance) and not spent_before("clearance re-solve (floor)"):
        return solve_in_scene(task, method, force, sol.q, nominal, options)
    return opt, sol, None


def optimize(task: Task, method: Method, force: TaskForce, guess: FloatArray | None,
              reported: TaskForce | None = None, self_rows: bool = False) -> tuple[SolverResult, dict]:
    """Solve the method's NLP (coarse-to-fine unless a guess is given); returns the result and facts
    (the cost terms evaluated with the ``reported`` force, default ``force``); ``self_rows``: with
    rows for the robot's own pairs near the solve (:func:`_apart`)."""
    budget = budget_of(task.solver)
    with solve_budget(*budget):  # a plan's rounds share the plan's; a lone call has its own
        sol, info = _optimize(task, method, force, guess, reported, self_rows)
    return sol, info | {"time_budget_s": budget[0]}


def _optimize(task: Task, method: Method, force: TaskForce, guess: FloatArray | None,
              reported: TaskForce | None, self_rows: bool) -> tuple[SolverResult, dict]:
    nominal = once("nominal", task, task.nominal)  # IK along a path of poses: seconds on a raw URDF
    # a plan's re-solve from its own start (self rows) finds the same guess: made once per plan
    q_guess = once("start_guess", task, lambda: start_guess(task, nominal)) if guess is None else guess
    options, info = task.solver, {}
    warm = once(("coarse", id(method)), task, lambda: coarse_guess(task, method)) if guess is None else None
    if warm is not None:
        q_guess, info["coarse"] = warm
        # a near-optimal start: begin with a small barrier parameter
        options = replace(options, extra=SMALL_BARRIER | options.extra)
    opt, sol, rows = solve_clear(task, method, force, q_guess, nominal, options, self_rows=self_rows)
    if (retry := _small_barrier_retry(task, method, force, q_guess, nominal, options, sol, self_rows)) is not None:
        info["small_barrier_retry"] = retry.facts
        if retry.facts["kept"]:
            opt, sol, rows, options = retry.opt, retry.sol, retry.rows, retry.options
    if rows is not None:
        info["clearance_rows"] = rows
    if not sol.success and (failed := failed_rows(opt, sol, task, force)) is not None:
        info["failed_rows"] = failed.to_json()  # the body in the way, or the pose out of reach
    if task.mode == "hold" and guess is None and options.hold_starts > 1:
        free = None if rows is not None else opt  # the free-space problem serves every start

        def solve_from(q: FloatArray) -> SolverResult:
            # each start with rows gets those of the pairs near it (and near its solution)
            return solve_clear(task, method, force, q, nominal, options, free)[1]

        sol, info["starts"] = _best_of_starts(solve_from, task, sol)
    info |= {
        "status": sol.status, "success": sol.success, "iterations": sol.iterations, "backend": sol.backend,
        "objective": sol.objective, "constraint_violation": sol.constraint_violation,
        "accepted_violation": accepted_violation(options),
        "build_time_s": sol.build_time, "solve_time_s": sol.solve_time, "kernels": sol.codegen,
        "cost_terms": opt.cost_terms(sol.q, task.t, task.targets, (rep := reported or force).f, rep.r,
                                     term_values=term_values(method, rep, task.terms), start=task.start_motion),
        "term_weights": opt.term_weights(), "term_settings": term_settings(method, opt.settings),
        "quadratic_forms": opt.quadratic_forms,
    }
    if "starts" in info:  # the work of every start, the chosen start's own figures under "starts"
        starts = info["starts"]
        starts["chosen_iterations"], starts["chosen_solve_time_s"] = sol.iterations, sol.solve_time
        info["iterations"], info["solve_time_s"] = starts["iterations"], starts["solve_time_s"]
    return sol, info


class Retry(NamedTuple):
    """A failed solve's second try (:func:`_small_barrier_retry`): its problem, solution, rows'
    facts (``None``: no rows), solver options and what it did (``facts``)."""

    opt: TrajectoryOptimizer
    sol: SolverResult
    rows: dict | None
    options: Any
    facts: dict[str, Any]


def _small_barrier_retry(task: Task, method: Method, force: TaskForce, q: FloatArray, nominal: FloatArray,
                         options: Any, sol: SolverResult, self_rows: bool) -> Retry | None:
    """A failed solve solved again from the same start with a small, monotone barrier parameter
    (:data:`SMALL_BARRIER`); returns the :class:`Retry`, ``facts["kept"]`` when
    the retry succeeded or ended nearer the constraints, or ``None`` when no retry applies: a goal
    task (its route falls back on its own), a start off the path's poses (:func:`_on_the_path`: a
    pose out of reach, which a smaller barrier does not bring nearer), a solve that succeeded, ran
    out of its time budget or had the small barrier already, or a spent plan budget
    (:func:`~forte.planning.nlp.budget.spent_before`).

    Why: IPOPT's adaptive barrier starts from ``mu`` near 1 (its oracle), and from a start on the
    pose constraints (the IK along the path) its first full Newton step can leave them by most
    of a metre; the restoration phase then ends ``Infeasible_Problem_Detected`` or runs out of
    iterations (the ``moca-like`` sideways reaches of ``benchmarks/feasibility_matrix.py``, which
    converge in 6-7 iterations with ``mu_init = 1e-4``). The retry costs a second solve on
    failures only.
    """
    if sol.success or sol.status in OUT_OF_TIME or "mu_init" in options.extra or task.goal is not None:
        return None
    if not _on_the_path(task, q) or spent_before("small-barrier retry"):
        return None
    small = replace(options, extra=SMALL_BARRIER | options.extra)
    opt, again, rows = solve_clear(task, method, force, q, nominal, small, self_rows=self_rows)
    kept = again.success or (again.status not in OUT_OF_TIME
                             and again.constraint_violation < sol.constraint_violation)
    facts = {"kept": bool(kept), "status": again.status, "iterations": again.iterations,
             "constraint_violation": again.constraint_violation, "first_status": sol.status,
             "first_iterations": sol.iterations, "first_constraint_violation": sol.constraint_violation}
    return Retry(opt, again, rows, small, facts)


def hold_starts(task: Task) -> FloatArray:
    """The starting configurations of a hold problem (``task.solver.hold_starts`` rows): the
    task's initial configuration, then seeded ones around it (base within 0.3 m and 0.6 rad,
    each arm joint within 0.6 rad, clipped to the joint limits)."""
    rng = np.random.default_rng(task.solver.hold_seed)
    q0 = np.asarray(task.q_init, dtype=float)
    spread = np.r_[0.3, 0.3, 0.6, np.full(q0.size - N_BASE, 0.6)]
    starts = q0 + rng.uniform(-1.0, 1.0, (task.solver.hold_starts - 1, q0.size)) * spread
    starts[:, N_BASE:] = np.clip(starts[:, N_BASE:], task.robot.lower, task.robot.upper)
    return np.vstack([q0, starts])


def _best_of_starts(solve_from: Callable[[FloatArray], SolverResult], task: Task, first: SolverResult
                    ) -> tuple[SolverResult, dict[str, Any]]:
    """Solve the hold problem from every start of :func:`hold_starts` (``solve_from(q)``, q 1 x nq);
    the converged result with the lowest objective (``first`` is the solve from the first start).

    The orientation equality ``vee(R_d^T R - R^T R_d) = 0`` also holds with the hand turned by pi
    about some axis, and a start can converge there (the holding sweep's rfp-radius at capability
    weight 20 and 60 did); such a result is chosen only when no start converged the right way up
    (``facts["upside_down"]`` counts them)."""
    results = [first]
    for i, q in enumerate(hold_starts(task)[1:], 2):
        if spent_before(f"hold start {i} of {task.solver.hold_starts}"):
            break
        results.append(solve_from(q[None, :]))
    converged = [i for i, r in enumerate(results) if r.success]
    upright = [i for i in converged if _upright(task, results[i].q)]
    best = min(upright or converged, key=lambda i: results[i].objective) if converged else 0
    facts = {"count": len(results), "converged": len(converged), "upside_down": len(converged) - len(upright),
             "chosen": best,
             "objectives": [float(r.objective) for r in results],
             "iterations": int(sum(r.iterations for r in results)),
             "solve_time_s": float(sum(r.solve_time for r in results))}
    return results[best], facts


def _hand_poses(task: Task, q: FloatArray) -> FloatArray:
    """The end-effector pose (4 x 4) of each configuration of ``q``."""
    return np.array([task.robot.ee_pose(qk) for qk in q])


#: How near the path's poses a start must be for :func:`_small_barrier_retry` (m, rad).
ON_PATH_M, ON_PATH_RAD = 1e-3, 1e-2


def _on_the_path(task: Task, q: FloatArray) -> bool:
    """Every waypoint's end-effector pose of ``q`` within :data:`ON_PATH_M` and :data:`ON_PATH_RAD`
    of the task's (the IK guess of a path in reach)."""
    ee = _hand_poses(task, q)
    near = np.linalg.norm(ee[:, :3, 3] - task.targets[:, :3, 3], axis=1) <= ON_PATH_M
    return bool(np.all(near) and np.all(orientation_errors(ee, task.targets) <= ON_PATH_RAD))


def _upright(task: Task, q: FloatArray) -> bool:
    """The end effector within the verdict's orientation tolerance of the task's poses."""
    ee = _hand_poses(task, q)
    return bool(np.all(orientation_errors(ee, task.targets) <= TRACKING_ORIENTATION_TOL))
