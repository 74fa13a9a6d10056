"""The rounds after a solve: the verdict of a plan (:func:`judged`), and what the planner tries when
it fails (:func:`forte.planning.planner.plan` runs them in this order):

- :func:`own_force`: a goal task judged with its own motion's force is solved once more with it;
- :func:`apart`: self-collision rows for a plan whose arm runs into the robot;
- :func:`refine`: rounds for what the NLP's waypoint view misses between waypoints (capacity,
  velocity, acceleration, keep_level);
- :func:`slower`: a goal task on a slower route (what toppra's time law does not know), else its
  route itself slower (:func:`slower_route`);
- :func:`route_as_plan`: a goal task's route judged as the plan when the optimized one is not feasible.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from forte.force.taskforce import TaskForce
from forte.model.robot import N_BASE
from forte.model.trajectory import backward_differences
from forte.planning.methods.catalog import Method
from forte.planning.nlp.budget import spent_before
from forte.planning.nlp.optimizer import SolverResult
from forte.planning.search.route import on_samples, routed
from forte.planning.solve import optimize
from forte.planning.tasks.keep_level import tightened
from forte.planning.tasks.tasks import Task
from forte.planning.terms.wrench_terms import uses_capability
from forte.planning.verdict.goal_load import goal_load
from forte.planning.verdict.verdict import Verdict, capacity_shortfall, judge_plan, limit_ratios
from forte.validation import MAX_WAYPOINTS, FloatArray

#: What a refinement round adds to the shortfall it covers (N).
REFINE_SLACK_N = 0.5
#: How far below the executed peak a refinement round sets a velocity or acceleration bound.
REFINE_MARGIN = 1.05


def tightened_limit(limits: FloatArray, peaks: FloatArray, ratios: FloatArray) -> FloatArray:
    """The NLP's bound of every coordinate whose executed motion exceeds its limit by ``x``
    (``ratios``): ``min(limit, largest waypoint value) / (1.05 x)``, so the tighter bound binds."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(ratios > 1.0, np.minimum(limits, peaks) / (REFINE_MARGIN * ratios), limits)


def judged(task: Task, q: FloatArray, force: TaskForce, solver: dict[str, Any] | None = None
           ) -> tuple[Verdict, TaskForce]:
    """The verdict of ``q`` planned for ``task`` with ``force``, and the force it was judged with: a
    goal task's is the force along the plan's own end-effector motion (:meth:`Task.following
    <forte.planning.tasks.tasks.Task.following>`), whatever force it was planned with."""
    if task.goal is None:
        return judge_plan(task, q, force, solver), force
    own = task.following(q)
    force = own.force()
    return judge_plan(own, q, force, solver), force


def refine(task: Task, spec: Method, force: TaskForce, sol: SolverResult, info: dict[str, Any],
            verdict: Verdict) -> tuple[SolverResult, dict[str, Any], Verdict, TaskForce]:
    """Re-solve a converged plan whose verdict fails only where the NLP's discrete view of the
    motion falls short of the executed one.

    The NLP checks the force ball, the joint velocities and accelerations at the waypoints, on
    backward differences; the verdict also checks the executed spline between them, whose torques,
    velocities and accelerations differ (forte's 0.35 kg lift on the moca-like robot: arm
    accelerations within the limits at every waypoint, 1.45 x a limit on the spline; a Kinova
    riding its 0.628 rad/s joint limits at the waypoints: 1.014 x on the spline). With
    ``limits.on_spline`` (on by default) the NLP bounds the arm's velocities and accelerations on
    the spline itself (:mod:`forte.planning.nlp.spline_rows`): the rounds are left the base's
    velocity, the capacity, and plans without those rows. Each round, solved again from the current plan:

    - ``capacity`` (methods whose objective uses the ball, the ``capability`` term): ``r_k`` grows
      at the waypoints next to every failing sample by the shortfall there plus
      :data:`REFINE_SLACK_N`;
    - ``velocity``, ``acceleration``: the NLP's limit of each coordinate (base and arm velocities,
      arm accelerations) that exceeds its limit on the spline by the ratio ``x`` becomes
      ``min(limit, largest waypoint value) / (1.05 x)``;
    - ``keep_level`` (a goal task: a given path fixes its orientations, the NLP has no such rows):
      the NLP's tilt limit drops by twice the spline's excess over the task's
      (:func:`~forte.planning.tasks.keep_level.tightened`; its rows hold at the waypoints only).

    The metrics, the cost terms and the verdict keep the task's own radii and limits. At most
    ``task.solver.refine_rounds`` rounds (0: none); the first feasible plan is kept, else the original.
    ``info["refinement"]`` records the rounds. Returns the kept plan, its facts, its verdict and the
    force it was judged with (:func:`judged`; a goal task's: its own motion's).
    """
    fixable = {"velocity", "acceleration"} | ({"capacity"} if uses_capability(spec) else set())
    fixable |= {"keep_level"} if task.goal is not None else set()  # a given path has no keep_level rows
    if not sol.success or not verdict.failed or not set(verdict.failed) <= fixable or not task.solver.refine_rounds:
        return sol, info, verdict, force
    radius = force.r.copy()
    vel, acc = (limit.copy() for limit in task.limits.resolve(task.robot))
    acc, keep = acc[N_BASE:], task.keep_level
    rounds, current, current_verdict = [], sol, verdict
    apart = bool(info.get("self_rows", {}).get("kept"))  # a plan kept apart by self rows keeps them
    for k in range(task.solver.refine_rounds):
        if spent_before(f"refinement round {k + 1}"):
            break
        if "capacity" in current_verdict.failed:
            short = capacity_shortfall(task, current.q, force)
            radius = radius + np.where(short > 0, short + REFINE_SLACK_N, 0.0)
        if {"velocity", "acceleration"} & set(current_verdict.failed):
            v_ratio, a_ratio = limit_ratios(task, current.q)
            v_peak, a_peak = (np.max(np.abs(x), axis=0) for x in backward_differences(
                np.asarray(current.q), task.t, start=task.start_motion))
            vel = tightened_limit(vel, v_peak, v_ratio)
            acc = tightened_limit(acc, a_peak[N_BASE:], a_ratio)
        for v in (v for v in current_verdict.violations if v.requirement == "keep_level"):
            keep = tightened(keep, np.radians(v.worst - v.limit))
        trial_task = replace(task, limits=replace(task.limits, arm_acceleration=tuple(acc),
                                                  arm_velocity=tuple(vel[N_BASE:]),
                                                  base_velocity=tuple(vel[:N_BASE])), keep_level=keep)
        trial, trial_info = optimize(trial_task, spec, replace(force, r=radius), current.q, reported=force,
                                     self_rows=apart)
        trial_verdict, trial_force = judged(task, trial.q, force, trial_info)
        rounds.append({"max_added_radius_n": float(np.max(radius - force.r)), "arm_acceleration": acc.tolist(),
                       "velocity": vel.tolist(), "verdict": trial_verdict.label,
                       "keep_level_max_tilt_deg": None if keep is None else float(np.degrees(keep.max_tilt)),
                       "failed": list(trial_verdict.failed), "iterations": trial.iterations,
                       "solve_time_s": trial.solve_time})
        if trial_verdict.feasible:
            trial_info["refinement"] = {"rounds": rounds, "radius": radius.tolist()}
            return trial, trial_info, trial_verdict, trial_force
        if not trial.success or not set(trial_verdict.failed) <= fixable:
            break
        current, current_verdict = trial, trial_verdict
    info["refinement"] = {"rounds": rounds, "kept": "original"}
    return sol, info, verdict, force


#: IPOPT's status for a problem it found (locally) infeasible.
INFEASIBLE = "Infeasible_Problem_Detected"


def apart(task: Task, spec: Method, force: TaskForce, guess: FloatArray | None, sol: SolverResult,
           info: dict[str, Any], verdict: Verdict) -> tuple[SolverResult, dict[str, Any], Verdict, TaskForce]:
    """Solve again with self-collision rows a plan without clearance rows whose arm runs into the robot.

    A task without scene bodies near the robot has no rows for the robot's own pairs (most tasks
    never bring two parts close, and rows cost time); a plan the verdict finds in self-collision
    (exact meshes) is solved again, from the same guess, with rows for the robot's pairs near it
    (:func:`~forte.planning.scene.scene_solve.solve_in_scene`; a pair whose covers already overlap at
    the start keeps its start distance, :func:`~forte.planning.nlp.collision_slots.self_margins`).
    The new plan is kept when it no longer collides and converged, or when the plan it replaces did
    not converge either (then it fails nothing more: one failed solve for another, minus the
    collision). A re-solve that did not converge is otherwise dropped, collision-free or not: its
    iterate is wherever IPOPT stopped (solver-failed), and the converged plan's verdict names
    what is wrong with it more usefully. A plan whose solve IPOPT found infeasible (:data:`INFEASIBLE`:
    the raw TIAGo's pose 0.33 m out of reach) is not solved again: the same problem with more rows
    has fewer feasible points, not more (that re-solve ran 500 iterations, 50 s of CPU, or 110 s
    stopped by the budget, for the same verdict).
    ``info["self_rows"]`` records the try (its verdict's one line, ``reason``, names the pairs that
    still collide). Returns the force
    the kept plan was judged with too (:func:`judged`).
    """
    if "clearance_rows" in info or "self_collision" not in verdict.failed:
        return sol, info, verdict, force
    if sol.status == INFEASIBLE:  # rows only remove points: no feasible one to gain
        skipped = f"the solve without them stopped with {INFEASIBLE}: rows only remove feasible points"
        return sol, info | {"self_rows": {"kept": False, "skipped": skipped}}, verdict, force
    if spent_before("self-collision re-solve"):
        return sol, info, verdict, force
    trial, trial_info = optimize(task, spec, force, guess, self_rows=True)
    trial_verdict, trial_force = judged(task, trial.q, force, trial_info)
    kept = "self_collision" not in trial_verdict.failed and (trial.success or not sol.success)
    record = {"verdict": trial_verdict.label, "failed": list(trial_verdict.failed), "kept": kept,
              "reason": trial_verdict.reason(), "status": trial.status, "iterations": trial.iterations,
              "solve_time_s": trial.solve_time}
    if kept:
        return trial, trial_info | {"self_rows": record}, trial_verdict, trial_force
    return sol, info | {"self_rows": record}, verdict, force


def own_force(task: Task, spec: Method, force: TaskForce, sol: SolverResult, info: dict[str, Any],
               verdict: Verdict) -> tuple[SolverResult, dict[str, Any], Verdict, TaskForce]:
    """A goal task planned with its guess's force whose plan fails on a force requirement
    (capacity, torque) with its own motion's ``force``: solved once more, from the plan, with that
    force; the new plan is kept when it converged (``info["own_force"]`` records the try)."""
    by_force = {"capacity", "torque"}
    if task.goal is None or not sol.success or not set(verdict.failed) & by_force or spent_before("own-force re-solve"):
        return sol, info, verdict, force
    own = task.following(sol.q)
    trial, trial_info = optimize(own, spec, force, sol.q)
    trial_verdict, trial_force = judged(own, trial.q, force, trial_info)
    record = {"verdict": trial_verdict.label, "failed": list(trial_verdict.failed), "kept": trial.success,
              "iterations": trial.iterations, "solve_time_s": trial.solve_time}
    if trial.success:
        return trial, trial_info | {"own_force": record}, trial_verdict, trial_force
    return sol, info | {"own_force": record}, verdict, force


#: What a longer duration can fix, and how much longer each round makes it.
BY_DURATION = frozenset({"velocity", "acceleration", "torque", "capacity"})
SLOWER, SLOWER_ROUNDS = 1.5, 3


def slower(unrouted: Task, spec: Method, task: Task, sol: SolverResult, info: dict[str, Any], verdict: Verdict,
            force: TaskForce, route: dict[str, Any]) -> tuple[Task, SolverResult, dict[str, Any], Verdict, TaskForce]:
    """A goal task whose duration forte chose (toppra's, :mod:`forte.planning.search.route`) and whose
    converged plan fails only on what a slower motion fixes (:data:`BY_DURATION`: the payload's
    torques and the capacity margin are not in toppra's problem): planned again on a route
    :data:`SLOWER` times longer, at most :data:`SLOWER_ROUNDS` times; the first feasible plan is kept.
    A configuration goal that cannot hold the load at rest
    (:func:`~forte.planning.verdict.goal_load.goal_load`) is not slowed down: no motion ending
    there can. When no plan is feasible yet, the route itself may be slowed down
    (:func:`slower_route`). ``info["search"]`` records the route, the duration and the limit that
    set it, the slower rounds and the slower routes judged."""
    rounds: list[dict[str, Any]] = []
    limiting = route.get("limiting", "")
    stretch = 1.0
    held = task.goal.pose is not None or "capacity" not in verdict.failed or goal_load(task, sol.q[-1]) is None
    while (not task.goal.duration_given and sol.success and not verdict.feasible and len(rounds) < SLOWER_ROUNDS
           and set(verdict.failed) <= BY_DURATION and held and not spent_before("slower round")):
        stretch *= SLOWER
        trial_task, _ = routed(unrouted, stretch)
        trial_task = trial_task.following(trial_task.goal.route)
        trial, trial_info = optimize(trial_task, spec, trial_task.force(), None)
        trial_verdict, trial_force = judged(trial_task, trial.q, trial_task.force(), trial_info)
        rounds.append({"duration_s": float(trial_task.t[-1]), "verdict": trial_verdict.label,
                       "failed": list(trial_verdict.failed), "iterations": trial.iterations})
        if trial_verdict.feasible or not trial.success:
            limiting = f"{', '.join(verdict.failed)} with the task's force" if trial_verdict.feasible else limiting
            if trial_verdict.feasible:
                task, sol, info, verdict, force = trial_task, trial, trial_info, trial_verdict, trial_force
            break
    routes: list[dict[str, Any]] = []
    if not verdict.feasible:
        kept, routes = slower_route(task, sol, info, verdict, force)
        if kept is not None:
            task, sol, info, verdict, force = kept
            limiting = f"{info['fallback']['route_failed']} of the route with the task's force"
    info["search"] = route | {"duration_s": float(task.t[-1] - task.t[0]), "limiting": limiting,
                              "slower_rounds": rounds, "slower_routes": routes}
    return task, sol, info, verdict, force


def slower_route(task: Task, sol: SolverResult, info: dict[str, Any], verdict: Verdict, force: TaskForce
                 ) -> tuple[tuple[Task, SolverResult, dict[str, Any], Verdict, TaskForce] | None, list[dict[str, Any]]]:
    """A goal task with no feasible plan yet whose duration forte chose and whose route, judged as
    the plan (:func:`judged_route`), fails only on what a slower motion fixes (:data:`BY_DURATION`):
    the same route on a time law :data:`SLOWER` times longer (the task's times stretched,
    :func:`~forte.planning.search.route.on_samples`), at most :data:`SLOWER_ROUNDS` times, judged as
    the plan; the first feasible one is kept. Along the same path the arm's inertial torques and
    the payload's ``m p''`` fall as ``1 / stretch^2`` and the velocities as ``1 / stretch``
    (MotionBenchMaker's table_pick 0003 with 1.5 kg: the route 5.3 N short of capacity near the
    goal on toppra's x 1.5, feasible on x 2.25; the NLP's plans there cut a corner, failing
    clearance). A configuration goal that cannot hold the load at rest is not tried. Returns the
    task on the kept route's waypoints, the route as a converged plan whose status says so, its
    facts (``fallback``), verdict and force (``None`` when none is kept), and one record per try."""
    goal, records = task.goal, []
    if goal.duration_given or goal.law is None or goal.route is None or len(goal.route) != task.n:
        return None, records
    fast = judged(task, goal.route, force)[0]  # on its own waypoints first: one verdict, as route_as_plan's
    if not fast.feasible and set(fast.failed) <= BY_DURATION:
        fast = judged_route(task, force)[1]
    if fast.feasible or not set(fast.failed) <= BY_DURATION:  # route_as_plan keeps the faster one
        return None, records
    if goal.pose is None and "capacity" in fast.failed and goal_load(task, goal.route[-1]) is not None:
        return None, records
    for k in range(1, SLOWER_ROUNDS + 1):  # verdicts, no solve: they run past a spent budget (nlp/budget.py)
        slow = on_samples(task, task.t[0] + (task.t - task.t[0]) * SLOWER ** k)
        route_task, route_verdict, route_force, tries = judged_route(slow, slow.force())
        records.append({"duration_s": float(slow.t[-1] - slow.t[0]), "verdict": route_verdict.label,
                        "failed": list(route_verdict.failed), "waypoints": route_task.n})
        if route_verdict.feasible:
            failed = ", ".join(fast.failed)
            status = (f"route, {SLOWER ** k:.3g} x slower: the optimized plan was {verdict.label} ({sol.status}) "
                      f"and the route on {task.t[-1] - task.t[0]:.3g} s failed {failed}; the route on "
                      f"{records[-1]['duration_s']:.3g} s, timed by toppra, is judged feasible as it is on "
                      f"{route_task.n} waypoints (its force capability not optimized)")
            fallback = {"verdict": route_verdict.label, "failed": [], "kept": True, "waypoints": route_task.n,
                        "tries": tries, "stretch": SLOWER ** k, "route_failed": failed,
                        "optimized": {"status": sol.status, "verdict": verdict.label, "failed": list(verdict.failed)}}
            kept = replace(sol, q=route_task.goal.route, success=True, status=status)
            return (route_task, kept, info | {"fallback": fallback}, route_verdict, route_force), records
        if not set(route_verdict.failed) <= BY_DURATION:
            break
    return None, records


def passing(task: Task) -> dict[str, Any]:
    """A goal task's via times (s) and, for pick and place, the grasp's time (``forte simulate``
    attaches the payload then); empty without vias."""
    if not task.goal.vias:
        return {}
    steps = task.goal.steps(task.t)
    facts: dict[str, Any] = {"via_times_s": [float(task.t[k]) for k in steps]}
    if task.goal.grasp is not None:
        facts["grasp_time_s"] = float(task.t[steps[task.goal.grasp]])
    return facts


#: What the executed spline between a route's waypoints can break that its time law keeps (a cut
#: corner, an overshoot): a route failing only on these is judged again on more waypoints.
BETWEEN_WAYPOINTS = frozenset({"clearance", "joint_position", "self_collision", "velocity", "acceleration",
                               "torque", "capacity"})
#: The law's own states: a route failing one of these at a waypoint fails it on any samples.
AT_STATES = frozenset({"clearance", "joint_position", "self_collision"})
#: The route judged as the plan on these multiples of the task's waypoints, the first feasible kept.
DENSER = (1, 2, 4, 8)


def denser_helps(verdict: Verdict) -> bool:
    """Whether more waypoints can fix a route's ``verdict``: it fails only on :data:`BETWEEN_WAYPOINTS`,
    and on none of :data:`AT_STATES` at a waypoint."""
    return set(verdict.failed) <= BETWEEN_WAYPOINTS and not any(
        v.requirement in AT_STATES and v.waypoints for v in verdict.violations)


def judged_route(task: Task, force: TaskForce) -> tuple[Task, Verdict, TaskForce, list[dict[str, Any]]]:
    """The route judged as the plan on ``k N`` waypoints for ``k`` in :data:`DENSER` (sampled from its
    time law, :func:`~forte.planning.search.route.on_samples`; the same time span), until feasible or
    more cannot help (:func:`denser_helps`). The executed spline through ``N`` samples of a route
    with many corners (a cage: 20-40 rad of joint motion on 30 waypoints) cuts them by centimetres
    and overshoots the joint ranges; through more samples it keeps to the law. Returns the last
    task tried, its verdict and force, and one record per try."""
    tries: list[dict[str, Any]] = []
    trial = task
    for k in DENSER:
        n = k * task.n
        if k > 1:
            if task.goal.law is None or n > MAX_WAYPOINTS:
                break
            trial = on_samples(task, np.linspace(task.t[0], task.t[-1], n))
        verdict, judged_force = judged(trial, trial.goal.route, force)
        tries.append({"waypoints": n, "verdict": verdict.label, "failed": list(verdict.failed)})
        if verdict.feasible or not denser_helps(verdict):
            break
    return trial, verdict, judged_force, tries


def route_as_plan(task: Task, sol: SolverResult, info: dict[str, Any], verdict: Verdict, force: TaskForce
                   ) -> tuple[Task, FloatArray, bool, str, dict[str, Any], Verdict, TaskForce]:
    """A goal task whose optimized plan is not feasible (the NLP did not converge, or its plan fails
    the verdict): its route (the search's collision-free path timed by toppra,
    :mod:`forte.planning.search.route`) judged as it is (:func:`judged_route`: on more waypoints
    where the spline between them is what fails), and kept when the verdict calls it
    feasible (its clearance with the executor's margin included,
    :func:`~forte.planning.verdict.margin.execution_margin`). The route keeps the exact
    clearance between its states and the limits on toppra's time law, but its force capability is
    not optimized: ``info["fallback"]`` says so, and the status names what the NLP did. Returns the
    task the plan is on (the route's, on its waypoints) first."""
    keep = task, sol.q, sol.success, sol.status, info, verdict, force
    route = task.goal.route if task.goal is not None else None
    if verdict.feasible or route is None or len(route) != task.n:
        return keep
    route_task, route_verdict, route_force, tries = judged_route(task, force)
    record = {"verdict": route_verdict.label, "failed": list(route_verdict.failed), "kept": route_verdict.feasible,
              "waypoints": route_task.n, "tries": tries,
              "optimized": {"status": sol.status, "verdict": verdict.label, "failed": list(verdict.failed)}}
    if not route_verdict.feasible:
        return (*keep[:4], info | {"fallback": record}, verdict, force)
    status = (f"route: the optimized plan was {verdict.label} ({sol.status}); the searched route, timed by toppra, "
              f"is judged feasible as it is on {route_task.n} waypoints (its force capability not optimized)")
    return route_task, route_task.goal.route, True, status, info | {"fallback": record}, route_verdict, route_force
