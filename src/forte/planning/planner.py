"""Planning: from a validated :class:`~forte.planning.tasks.tasks.Task` to a :class:`Plan` and its metrics.

The methods are the entries of :data:`forte.planning.methods.catalog.METHODS`: optimized ones solve the
NLP of :mod:`forte.planning.nlp.optimizer` with their cost terms, the others produce their
configurations directly (the quintic path + IK, the teaching configuration).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from forte.exceptions import EstimationError, InvalidInputError, TaskFileError
from forte.force.contact import Contact
from forte.force.payload import Payload
from forte.force.taskforce import TaskForce
from forte.model.robot import MobileManipulator
from forte.model.scene import Scene
from forte.planning.methods.catalog import METHODS, Method, get_method, method_names
from forte.planning.nlp.budget import Budget, budget_of, solve_budget
from forte.planning.rounds import apart, judged, judged_route, own_force, passing, refine, route_as_plan, slower
from forte.planning.scene.scene_solve import blocked_path
from forte.planning.search.route import routed
from forte.planning.solve import optimize, start_guess
from forte.planning.tasks.tasks import Task
from forte.planning.tasks.terms_section import with_task_terms
from forte.planning.terms.wrench_terms import for_requirement
from forte.planning.verdict.evaluation import evaluate
from forte.planning.verdict.goal_load import said_at_goal
from forte.planning.verdict.start_load import said_at_start
from forte.planning.verdict.verdict import SOLVER_FAILED, Verdict
from forte.validation import FloatArray


@dataclass
class Plan:
    """A whole-body plan: configurations at times ``t``, the desired force, metrics, solver facts.

    Attributes:
        method: the method's name.
        robot: the robot it was planned for.
        t, q: sample times (N) and whole-body configurations (N x nq).
        force: desired forces and ball radii (``None`` when unknown, e.g. a plan read from disk
            without one).
        payload: the payload the force was computed for.
        metrics: exact per-waypoint metrics (:func:`evaluate`; empty when not computed).
        solved, status: whether the solver converged (always true for a plan that is not
            optimized), and the solver's or producer's status.
        solver: solver facts (iterations, times, cost terms, ...).
        task: the task it solves (``None`` for a plan read from disk).
        verdict: whether the plan can be executed (:mod:`forte.planning.verdict.verdict`; ``None`` when
            not judged).
        scene: the task's scene (:mod:`forte.model.scene`), recorded in plan.json for
            ``forte simulate``, ``forte view`` and the exports.
    """

    method: str
    robot: MobileManipulator
    t: FloatArray
    q: FloatArray
    force: TaskForce | None
    payload: Payload
    metrics: dict[str, FloatArray] = field(default_factory=dict)
    solved: bool = True
    status: str = "success"
    solver: dict[str, Any] = field(default_factory=dict)
    task: Task | None = None
    verdict: Verdict | None = None
    #: The static bodies around the robot the plan was made in (empty: free space).
    scene: Scene = field(default_factory=Scene)
    #: The task's contact (:mod:`forte.force.contact`), recorded in plan.json for ``forte simulate``.
    contact: Contact | None = None

    @property
    def feasible(self) -> bool:
        """The plan can be executed: its verdict is ``feasible``."""
        return self.verdict is not None and self.verdict.feasible

    @property
    def success(self) -> bool:
        """The same as :attr:`feasible` (a plan is a success only when it can be executed)."""
        return self.feasible

    @property
    def label(self) -> str:
        """The verdict's label (``feasible``, ``infeasible``, ``solver-failed``); ``unjudged``
        when there is none (a plan written before verdicts)."""
        if self.verdict is not None:
            return self.verdict.label
        return "unjudged" if self.solved else SOLVER_FAILED

    @property
    def estimate(self) -> dict[str, Any] | None:
        """The mass estimator's record, when the payload mass was estimated."""
        return None if self.payload.estimate is None else dict(self.payload.estimate)


#: The name used before there was one plan type.
PlanResult = Plan


def methods_for(task: Task) -> tuple[str, ...]:
    """Registered methods that apply to the task (``given`` ones only with what they need)."""
    return tuple(name for name in method_names(task.mode) if METHODS[name].applies_to(task))


def resolve_payload(task: Task, estimator_options: dict[str, Any] | None = None) -> Task:
    """The task with its payload mass known: estimated when only a description/image is given."""
    if not task.payload.needs_estimate:
        return task
    if (task.force_profile is not None or task.contact is not None) and not (task.payload.description
                                                                            or task.payload.image):
        return task  # the profile or the contact model alone: no payload to estimate
    if not (task.payload.description or task.payload.image):
        raise TaskFileError(f"{task.source}: payload: give a mass, a description or an image")
    from forte.force.estimate import estimate_payload

    try:
        estimate = estimate_payload(task.payload.description, task.payload.image, **(estimator_options or {}))
    except EstimationError as exc:  # named by the field the estimator was given
        field = "payload.description" if task.payload.description else f"payload.image ({task.payload.image})"
        raise EstimationError(f"{task._where(field)}: {exc}") from None
    return task.with_payload(task.payload.with_estimate(estimate))


#: A plan with its facts: the task it is on, q, solved, status, solver facts, verdict, judged force.
Planned = tuple[Task, FloatArray, bool, str, dict[str, Any], Verdict, TaskForce]


def route_plan(task: Task, force: TaskForce, route: dict[str, Any]) -> tuple[Planned | None, dict[str, Any]]:
    """``solver.route_first``: a goal task's route (searched, timed by toppra) judged as the plan
    before any NLP (:func:`~forte.planning.rounds.judged_route`: on more waypoints where the spline
    between them is what fails). Returns the task the plan is on, the plan and its facts when the
    verdict calls it feasible (else ``None``: the NLP runs as without the option), and the record
    of the try."""
    if task.goal is None or task.goal.route is None or len(task.goal.route) != task.n:
        return None, {}
    begin = time.perf_counter()
    route_task, verdict, judged_force, tries = judged_route(task, force)
    record = {"verdict": verdict.label, "failed": list(verdict.failed), "kept": verdict.feasible,
              "waypoints": route_task.n, "tries": tries, "verdict_s": time.perf_counter() - begin}
    if not verdict.feasible:
        return None, record
    info = {"status": "route", "success": True, "route_first": record,
            "search": route | {"duration_s": float(route_task.t[-1] - route_task.t[0])}}
    status = (f"route: the searched route, timed by toppra, judged feasible as it is on {route_task.n} waypoints "
              "(solver.route_first: no NLP; its force capability checked, not optimized)")
    return (route_task, route_task.goal.route, True, status, info, verdict, judged_force), record


def said_of_budget(verdict: Verdict, budget: Budget) -> Verdict:
    """``verdict`` with its first failed requirement followed by the plan's time budget when it ran
    out, and what the plan did not try for it (:func:`~forte.planning.nlp.budget.spent_before`): a
    re-solve or a round that might have fixed it;
    ``verdict`` as it is when feasible or when the budget did not run out."""
    if verdict.feasible or not verdict.violations or not (budget.skipped or budget.spent()):
        return verdict
    if not budget.skipped and "solver.time_budget_s" in verdict.violations[0].detail:
        return verdict  # the solver's line names it already (IPOPT stopped at the budget)
    line = (f"the plan's time budget ({budget.cpu_s:g} s of CPU, {budget.wall_s:g} s of wall time: "
            f"solver.time_budget_s) ran out" + (f" ({'; '.join(budget.skipped)})" if budget.skipped else ""))
    first = verdict.violations[0]
    return verdict._replace(violations=(first._replace(detail=f"{first.detail}; {line}"), *verdict.violations[1:]))


def plan(task: Task, method: str | Method = "forte", estimator_options: dict[str, Any] | None = None,
         guess: FloatArray | None = None) -> Plan:
    """Plan ``task`` with ``method`` and judge it; never raises for a solver failure or an
    infeasible plan (see ``Plan.verdict``).

    Examples:
        >>> import forte
        >>> task = forte.load_task("examples/tasks/hold.yaml", mass=0.35)
        >>> result = forte.plan(task, "teaching")
        >>> result.q.shape, result.verdict.label, result.verdict.failed  # the taught posture lacks capacity
        ((1, 10), 'infeasible', ('capacity', 'torque'))
    """
    spec = get_method(method)
    if not spec.applies_to(task):
        if spec.production == "given" and task.mode in spec.modes:
            spec.produce(task)  # raises the precise error (e.g. no teaching configuration)
        raise InvalidInputError(f"method: '{spec.name}' does not apply to mode '{task.mode}'; "
                                f"expected one of {', '.join(methods_for(task))}")
    task = resolve_payload(task, estimator_options)
    start = time.perf_counter()
    unrouted, route = task, {}
    if task.goal is not None and spec.optimized and guess is None:  # found and timed (search, toppra)
        task, route = routed(task)
    if task.goal is not None:  # planned with the force along its initial guess's motion
        task = task.following(start_guess(task) if guess is None else guess)
    force = task.force()
    info: dict[str, Any] = {}
    budget: Budget | None = None
    blocked = (route.get("reason") or blocked_path(task)) if spec.optimized else None
    first, tried_route = route_plan(task, force, route) if route and blocked is None and task.solver.route_first \
        else (None, {})
    if blocked is not None:  # no motion can clear the scene: nothing to optimize
        q, solved, status = start_guess(task) if guess is None else guess, False, blocked
        info = {"status": status, "success": False, "path_blocked": True, **({"search": route} if route else {})}
        verdict, force = judged(task, q, force)
    elif first is not None:
        task, q, solved, status, info, verdict, force = first
    elif spec.optimized:
        # J1 on the wrench when the payload needs a moment; the task's own terms (e.g. tipover) added
        solved_as = with_task_terms(for_requirement(spec, force), task.terms)
        with solve_budget(*budget_of(task.solver)) as budget:  # every solve of the plan, its rounds included
            sol, info = optimize(task, solved_as, force, guess)
            verdict, force = judged(task, sol.q, force, info)
            sol, info, verdict, force = own_force(task, solved_as, force, sol, info, verdict)
            sol, info, verdict, force = apart(task, solved_as, force, guess, sol, info, verdict)
            sol, info, verdict, force = refine(task, solved_as, force, sol, info, verdict)
            if route:
                task, sol, info, verdict, force = slower(unrouted, solved_as, task, sol, info, verdict, force, route)
                task, q, solved, status, info, verdict, force = route_as_plan(task, sol, info, verdict, force)
            else:
                q, solved, status = sol.q, sol.success, sol.status
        if tried_route:
            info["route_first"] = tried_route
        verdict = said_of_budget(verdict, budget)
    else:
        q, solved, status = spec.produce(task), True, spec.status
        verdict, force = judged(task, q, force)
    verdict = said_at_start(task, verdict)  # a start that cannot carry the load is no plan's doing
    verdict = said_at_goal(task, q, verdict)  # nor a goal that cannot hold it
    info["wall_time_s"] = time.perf_counter() - start
    if task.goal is not None:  # the plan's own end-effector motion (its force is the judged one)
        task = task.following(q)
        info["goal"] = {"kind": task.goal.kind, "duration_s": float(task.t[-1] - task.t[0]),
                        "duration_given": task.goal.duration_given} | passing(task)
    metrics = evaluate(task.robot, q, task.t, force, task.settings.capability_params, task.scene,
                       task.start_motion)
    if budget is not None:  # what the plan used of its budget, its closing verdict and metrics included
        info["budget"] = budget.record()
    return Plan(method=spec.name, robot=task.robot, t=task.t, q=q, force=force, payload=task.payload,
                metrics=metrics, solved=solved, status=status, solver=info, task=task, verdict=verdict,
                scene=task.scene, contact=task.contact)


def compare(task: Task, methods: tuple[str, ...] | None = None,
            estimator_options: dict[str, Any] | None = None,
            on_plan: Callable[[int, Plan], None] | None = None) -> list[Plan]:
    """Plan ``task`` with every method that applies (or ``methods``); the payload is resolved once.
    ``on_plan(i, plan)`` is called after the i-th plan (1-based), e.g. to show progress; every
    plan carries its verdict.

    Examples:
        >>> import forte
        >>> task = forte.load_task("examples/tasks/hold.yaml", mass=0.35)
        >>> [p.method for p in forte.compare(task, methods=("teaching",))]
        ['teaching']
    """
    task = resolve_payload(task, estimator_options)
    results = []
    for i, name in enumerate(methods or methods_for(task), 1):
        results.append(plan(task, name))
        if on_plan is not None:
            on_plan(i, results[-1])
    return results
