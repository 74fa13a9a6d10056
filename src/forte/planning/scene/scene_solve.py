"""Solving in a scene: the rounds of clearance rows, and paths no motion can follow clear.

:func:`solve_in_scene` is the planner's solve when the task has a scene: the broad phase
(:mod:`forte.planning.nlp.collision_slots`) gives the rows for the pairs near the start, and while
the solution brings a pair within its margin that had no rows, the problem is built again with
that pair and solved from the solution. :func:`blocked_path` finds, before any solve, a path
that the parts rigid with the end effector cannot follow clear of the scene or the floor.

The floor is in every world but a task without bodies is solved in free space (no rows, the
paper's NLP) unless the robot comes near the floor (:func:`needs_rows`): a primitive of the
cover off the base frame (an arm link, the payload) within the clearance plus
:data:`~forte.planning.nlp.collision_slots.ACTIVATION` of it on the trajectory the solve starts
from; a free-space solution that comes within the clearance of it is solved again, with rows,
from there (:func:`floor_near`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from forte.force.taskforce import TaskForce
from forte.model.body_spheres import BASE_FRAME, primitive_centres, robot_primitives
from forte.planning.methods.catalog import Method
from forte.planning.nlp.budget import spent_before
from forte.planning.nlp.collision_slots import ACTIVATION, assign_slots, missing_pairs
from forte.planning.nlp.optimizer import SolverResult, TrajectoryOptimizer
from forte.planning.tasks.tasks import Task
from forte.planning.tasks.terms_section import term_values
from forte.validation import FloatArray


def blocked_path(task: Task) -> str | None:
    """Why no plan of ``task`` can keep its clearance, or ``None``: the parts rigid with the end
    effector (the hand, the fingers) come closer to a scene body than the clearance at a target
    pose of the path itself (:func:`forte.model.clearance.path_clearances`), so the optimizer is
    not run (it could only fail, slowly)."""
    if not task.scene.solid:
        return None
    from forte.model.clearance import path_clearances

    # a goal task's path is free: its goal pose and via poses only
    posed = np.arange(task.n) if task.goal is None else np.r_[task.goal.steps(task.t), task.n - 1].astype(int)
    found = path_clearances(task.robot, task.scene, task.targets[posed])
    k = found.closest()
    if found.distance[k] >= task.clearance:
        return None
    what = "path" if task.goal is None else "goal" if posed[k] == task.n - 1 else "via pose"
    return (f"{what} blocked: at t = {task.t[posed[k]]:.3g} s the {what} puts {found.robot[k]} "
            f"{found.distance[k]:.3g} m "
            f"from {found.body[k]} (clearance {task.clearance:g} m)")


def goal_kind(task: Task) -> str | None:
    """The NLP's goal of ``task`` (:class:`~forte.planning.nlp.optimizer.TrajectoryOptimizer`'s ``goal``)."""
    return None if task.goal is None else task.goal.kind


def goal_vias(task: Task) -> tuple[int, ...]:
    """The waypoints of a goal task's via poses (the NLP's ``via_steps``), else none."""
    return () if task.goal is None else tuple(int(k) for k in task.goal.steps(task.t))


def goal_configuration(task: Task) -> FloatArray | None:
    """The last configuration of a configuration goal (the NLP's ``q_goal``), else ``None``."""
    return None if task.goal is None else task.goal.configuration


def floor_near(task: Task, q: FloatArray, within: float) -> bool:
    """Whether a primitive of the robot's cover off the base frame (an arm link's sphere, the
    payload's) comes within ``within`` (m) of the floor at some configuration of ``q`` (N x nq)."""
    if task.scene.floor is None:
        return False
    moving = tuple(p for p in robot_primitives(task.robot) if p.frame != BASE_FRAME)
    radius = np.array([p.radius for p in moving])
    lowest = min(float(np.min(primitive_centres(task.robot, qk, moving)[:, 2] - radius))
                 for qk in np.atleast_2d(q))
    return lowest - task.scene.floor < within


def needs_rows(task: Task, q: FloatArray) -> bool:
    """Whether the solve from ``q`` needs clearance rows: the task has scene bodies, or the robot
    comes within the clearance plus ``ACTIVATION`` of the floor (:func:`floor_near`)."""
    return bool(task.scene) or floor_near(task, q, task.clearance + ACTIVATION)


#: Solves from the last solution when it brought a pair close that had no clearance rows.
SCENE_ROUNDS = 3


def solve_in_scene(task: Task, method: Method, force: TaskForce, q_guess: FloatArray, nominal: FloatArray,
                   options: Any, keep_multipliers: bool = False
                   ) -> tuple[TrajectoryOptimizer, SolverResult, dict[str, Any]]:
    """Solve with clearance rows for the pairs the broad phase finds near ``q_guess``; while the
    solution brings a pair within the clearance that had no rows, solve again from it with those
    pairs added (at most :data:`SCENE_ROUNDS` times). Returns the last problem, its solution and
    the rounds' facts."""
    fix = task.mode != "hold"
    extra: set[tuple[int, int, int]] = set()
    start, rounds = q_guess, []
    for _ in range(SCENE_ROUNDS + 1):
        slots = assign_slots(task.robot, start, task.scene, task.clearance, fix, extra,
                             clear=None if task.goal is None else task.goal.route)
        opt = TrajectoryOptimizer(task.robot, task.n, method, task.weights, fix_initial=fix, options=options,
                                  limits=task.limits, slots=slots, keep_multipliers=keep_multipliers,
                                  settings=task.settings, goal=goal_kind(task), keep_level=task.keep_level,
                                  via_steps=goal_vias(task))
        sol = opt.solve(task.t, task.targets, force.f, force.r, task.q_init, start, nominal,
                        term_values=term_values(method, force, task.terms), start=task.start_motion,
                        q_goal=goal_configuration(task))
        missing = missing_pairs(task.robot, sol.q, task.scene, task.clearance, slots, fix_initial=fix)
        rounds.append({"rows": slots.rows, "slots": {ck.name: ck.slots for ck in opt._clear},
                       "iterations": sol.iterations, "missing_pairs": len(missing)})
        if not missing or not sol.success or spent_before("clearance round"):
            break
        extra |= missing | slots.triples()
        # from the solution (it kept the rows it had), or a goal task's route: clear of the scene on
        # the exact geometry, where a solution that ran into pairs without rows is not
        start = q_guess if task.goal is not None and task.goal.route is not None else sol.q
    return opt, sol, {"rounds": rounds}
