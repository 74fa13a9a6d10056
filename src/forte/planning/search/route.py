"""A goal task's route: the motion its NLP starts from, found and timed before the solve.

For a goal task (:mod:`forte.planning.tasks.goals`) the end effector's path is free. Its route is:

1. the straight line in configuration space from the start to the goal when it keeps the task's
   clearance the search keeps (:func:`~forte.planning.search.sampling.kept`: the verdict's, the
   executor's margin of the base kind at least, plus the slip between checked states) at every state
   :data:`~forte.planning.search.sampling.DENSE_STEP` apart (forte's exact model:
   :func:`~forte.planning.search.validity.segment_free`), else the path of a sampling-based
   search (:func:`~forte.planning.search.sampling.find_path`: RRT-Connect, shortcut);
2. timed by the time-optimal law along it under the velocity and acceleration limits
   (:func:`~forte.planning.search.timing.retime`, toppra; with knots at the path's corners where
   its spline would cut them below the path's clearance, :mod:`~forte.planning.search.corners`):
   without ``duration:`` in the task, the plan's duration is toppra's times :data:`DURATION_MARGIN` (at least
   :data:`~forte.planning.tasks.goals.MIN_GOAL_DURATION_S`; the payload's torques and the capacity
   margin are not in toppra's problem, the planner lengthens a plan that fails on them); with it,
   the route keeps its shape on the given time span. The route arrives at ``t_{N-3}`` and rests over
   the last two samples, as the NLP's end at rest asks.

The route is the NLP's initial guess and its nominal trajectory (the ``nominal`` term pulls toward
it, not toward a straight line through an obstacle). The goal keeps the time law the route was
sampled from (``Goal.law``), so the route judged as the plan can be sampled again on more
waypoints (:func:`on_samples`, :func:`forte.planning.rounds.judged_route`). :func:`routed` returns
the task with its route and times, and the facts the plan records (``solver.search``).
"""

from __future__ import annotations

import time
from dataclasses import replace
from typing import Any

import numpy as np

from forte.planning.search.corners import hugging_law
from forte.planning.search.goal_ik import free_goal
from forte.planning.search.sampling import DENSE_STEP, find_path, kept
from forte.planning.search.validity import StateChecker, segment_free
from forte.planning.tasks.goals import MIN_GOAL_DURATION_S, goal_targets
from forte.planning.tasks.tasks import Task
from forte.validation import FloatArray

#: The planned duration over toppra's time-optimal one when the task gives none.
DURATION_MARGIN = 1.5
#: State checks the search may spend (about 5 s on this project's 2-core machine when idle): a
#: budget of checks, not of seconds, so that a busy machine finds the same routes, only later.
SEARCH_CHECKS = 150_000
#: Seconds the search may take all the same.
SEARCH_TIME_LIMIT = 30.0
#: Dense samples of the timed path, interpolated onto the task's times.
DENSE_SAMPLES = 400


def needs_search(task: Task) -> bool:
    """Whether the world can be in the way: scene bodies, or a floor."""
    return bool(task.scene.objects) or task.scene.floor is not None


def arriving(t: FloatArray, dense_t: FloatArray, dense_q: FloatArray) -> FloatArray:
    """The timed motion (``dense_t``, ``dense_q``) stretched onto ``t`` so that it arrives at
    ``t_{N-3}`` and rests over the last two samples."""
    t = np.asarray(t, dtype=float)
    arrive = t[-3] if t.size >= 4 else t[-1]
    scale = dense_t[-1] / max(float(arrive - t[0]), 1e-12)
    s = np.clip((t - t[0]) * scale, 0.0, dense_t[-1])
    return np.column_stack([np.interp(s, dense_t, dense_q[:, j]) for j in range(dense_q.shape[1])])


def segment_path(task: Task, q0: FloatArray, q1: FloatArray) -> tuple[FloatArray | None, dict[str, Any]]:
    """A collision-free path (M x nq) from ``q0`` to ``q1``: the straight line when it is free,
    else the search's; and what finding it took."""
    begin = time.perf_counter()
    facts: dict[str, Any] = {"searched": False}
    if needs_search(task):  # the straight line keeps what a searched path keeps, checked as densely
        checker = StateChecker(task.robot, task.scene, kept(task.robot, task.scene, task.clearance, q0, q1))
        if not segment_free(checker, q0, q1, DENSE_STEP):
            found = find_path(task.robot, task.scene, q0, q1, task.clearance, time_limit=SEARCH_TIME_LIMIT,
                              seed=task.solver.hold_seed, checks=SEARCH_CHECKS)
            facts |= {"searched": True, "states": found.states, "checks": found.checks,
                      "shortcut_s": found.shortcut_s, "kept_clearance_m": found.clearance, "repairs": found.repairs,
                      "planner": found.planner}
            if not found.found:
                return None, facts | {"time_s": time.perf_counter() - begin, "reason": f"search: {found.reason}"}
            facts["time_s"] = time.perf_counter() - begin
            return found.q, facts
    facts["time_s"] = time.perf_counter() - begin
    return np.vstack([q0, q1]), facts


def clear_goal(task: Task) -> tuple[Task, str]:
    """A pose goal whose IK configuration is in collision gets one clear of the scene
    (:func:`~forte.planning.search.goal_ik.free_goal`); what was done, in words (``""``: nothing)."""
    if task.goal.pose is None or not needs_search(task):
        return task, ""
    free = free_goal(task.robot, task.scene, task.clearance, np.asarray(task.q_init, dtype=float),
                     np.asarray(task.goal.q_end, dtype=float), task.goal.pose, task.solver.hold_seed)
    if free.q is not None and free.tried:
        task = replace(task, goal=replace(task.goal, q_end=free.q))
    return task, free.reason


def route_path(task: Task) -> tuple[FloatArray | None, dict[str, Any]]:
    """The collision-free path (M x nq) from the start to the goal, and what finding it took."""
    return segment_path(task, np.asarray(task.q_init, dtype=float), np.asarray(task.goal.q_end, dtype=float))


def via_paths(task: Task) -> tuple[list[FloatArray] | None, dict[str, Any]]:
    """The paths from the start through the vias' IK configurations to the goal, one per leg, and
    the facts (summed over the legs; ``reason`` names the leg that has no path)."""
    knots = [np.asarray(task.q_init, dtype=float), *[v.q for v in task.goal.vias], np.asarray(task.goal.q_end)]
    paths, facts = [], {"searched": False, "time_s": 0.0}
    for i, (a, b) in enumerate(zip(knots[:-1], knots[1:], strict=True)):
        path, leg = segment_path(task, a, b)
        facts["searched"] |= leg["searched"]
        facts["time_s"] += leg["time_s"]
        for key in ("states", "checks", "shortcut_s"):
            if key in leg:
                facts[key] = facts.get(key, 0) + leg[key]
        if path is None:
            to = f"via {i}" if i < len(knots) - 2 else "the goal"
            return None, facts | {"reason": f"{leg['reason']} (the leg to {to})"}
        paths.append(path)
    return paths, facts


def through_legs(t: FloatArray, knot_t: FloatArray, legs: list[Any]) -> FloatArray:
    """The timed legs (:class:`~forte.planning.search.timing.Timed`) stretched onto the task's
    times: leg ``i`` from ``knot_t[i]`` to ``knot_t[i + 1]`` (each at rest at its ends), held after the last."""
    t = np.asarray(t, dtype=float)
    route = np.empty((t.size, legs[0].q.shape[1]))
    for i, leg in enumerate(legs):
        at = t >= knot_t[i] if i else np.ones(t.size, bool)
        s = np.clip((t - knot_t[i]) / max(knot_t[i + 1] - knot_t[i], 1e-12) * leg.t[-1], 0.0, leg.t[-1])
        route[at] = np.column_stack([np.interp(s[at], leg.t, leg.q[:, j]) for j in range(leg.q.shape[1])])
    return route


def _via_route(task: Task, stretch: float, paths: list[FloatArray], facts: dict[str, Any]
               ) -> tuple[Task, dict[str, Any]]:
    """:func:`routed` through vias: each leg timed by toppra at rest at its ends; without
    ``duration:`` the duration is ``DURATION_MARGIN stretch max_i(d_i / w_i)`` (``d_i`` the leg's
    time-optimal duration, ``w_i`` its share of the arrival time under the vias' rule, the share of
    the slowest leg setting it), as a route without vias gets ``DURATION_MARGIN stretch d``."""
    begin = time.perf_counter()
    legs = [hugging_law(task.robot, task.scene, p, task.clearance, samples=DENSE_SAMPLES, limits=task.limits)[0]
            for p in paths]
    shares = np.diff(np.r_[0.0, [v.fraction for v in task.goal.vias], 1.0])
    slowest = int(np.argmax([leg.duration / max(w, 1e-9) for leg, w in zip(legs, shares, strict=True)]))
    facts |= {"toppra_duration_s": float(sum(leg.duration for leg in legs)), "limiting": legs[slowest].limiting,
              "waypoints": int(sum(len(p) for p in paths)), "retime_s": time.perf_counter() - begin}
    t = task.t
    if not task.goal.duration_given:  # as without vias: the duration is the margin times the time-optimal one
        duration = DURATION_MARGIN * stretch * legs[slowest].duration / max(shares[slowest], 1e-9)
        t = np.linspace(0.0, max(MIN_GOAL_DURATION_S, duration), task.n)
    knot_t = np.r_[t[0], t[task.goal.steps(t)], t[-3] if t.size >= 4 else t[-1]]
    route = through_legs(t, knot_t, legs)
    route[0] = task.q_init
    goal = replace(task.goal, route=route)
    return replace(task, t=t, goal=goal, targets=goal_targets(task.robot, goal, route, t)), facts


def routed(task: Task, stretch: float = 1.0) -> tuple[Task, dict[str, Any]]:
    """``task`` with its route (initial guess and nominal) and its times; the facts (search, toppra's
    duration and the limit that sets it). ``stretch`` (>= 1) lengthens a chosen duration. A task
    that is not a goal task is returned as it is; a route that cannot be found leaves the task as
    it is with ``facts["reason"]``. A task with vias routes through their configurations
    (:func:`via_paths`, :func:`_via_route`)."""
    if task.goal is None:
        return task, {}
    if task.goal.vias:
        paths, facts = via_paths(task)
        return (task, facts) if paths is None else _via_route(task, stretch, paths, facts)
    task, goal_ik = clear_goal(task)
    path, facts = route_path(task)
    if goal_ik:
        facts["goal_ik"] = goal_ik
    if path is None:
        return task, facts | ({"reason": f"{facts['reason']} ({goal_ik})"} if goal_ik else {})
    begin = time.perf_counter()
    dense, corner_facts = hugging_law(task.robot, task.scene, path, task.clearance, samples=DENSE_SAMPLES,
                                      limits=task.limits)
    facts |= corner_facts | {"toppra_duration_s": dense.duration, "limiting": dense.limiting,
                             "waypoints": len(path), "retime_s": time.perf_counter() - begin}
    if task.goal.duration_given:
        t = task.t
    else:
        duration = max(MIN_GOAL_DURATION_S, DURATION_MARGIN * stretch * dense.duration)
        t = np.linspace(0.0, duration, task.n)
    goal = replace(task.goal, law=(dense.t, dense.q))
    return on_samples(replace(task, goal=goal), t), facts


def on_samples(task: Task, t: FloatArray) -> Task:
    """``task`` on the sample times ``t`` with its route sampled from its time law
    (``task.goal.law``, :func:`arriving`: arrives at ``t_{N-3}``, at rest over the last two samples)
    and the targets along it. A route judged as the plan goes on more samples than the NLP's: the
    executed spline through them then keeps closer to the searched path (fewer cut corners, less
    overshoot); a task without a law is returned as it is."""
    if task.goal is None or task.goal.law is None:
        return task
    route = arriving(t, *task.goal.law)
    route[0] = task.q_init
    goal = replace(task.goal, route=route)
    return replace(task, t=np.asarray(t, dtype=float), goal=goal, targets=goal_targets(task.robot, goal, route, t))
