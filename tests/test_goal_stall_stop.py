"""A goal task's NLP stops on a feasible stall (IPOPT's acceptable exit, issue 38's time per
problem): the exit is set for goal tasks' cold solves only, it needs the iterate within the
constraint tolerance, and what it returns is feasible and near the converged optimum."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from forte.model.description import N_BASE
from forte.planning.methods.catalog import get_method
from forte.planning.nlp.ipopt_nlp import STALL_CHANGE, STALL_ITERATIONS, ipopt_options, warm_options
from forte.planning.nlp.optimizer import TrajectoryOptimizer
from forte.planning.solve import goal_guess
from forte.planning.tasks.tasks import task_from_dict
from forte.planning.tasks.terms_section import term_values
from forte.settings import SolverOptions

PANDA = {"urdf": "erd:panda_description/urdf/panda.urdf", "ee_frame": "panda_hand", "base": "fixed"}
GOAL = [0.0, 0.0, 0.0, 0.5, -0.3, 0.0, -2.0, 0.0, 1.8, 0.785398]


def goal_task() -> object:
    return task_from_dict({"robot": PANDA, "path": {"samples": 12, "kind": "goal", "configuration": GOAL},
                           "payload": {"mass": 1.5}})


def solve(task: object, options: SolverOptions) -> tuple[TrajectoryOptimizer, object]:
    method = get_method("forte")
    opt = TrajectoryOptimizer(task.robot, task.n, method, task.weights, options=options, limits=task.limits,
                              settings=task.settings, goal="configuration")
    force = task.force()
    sol = opt.solve(task.t, task.targets, force.f, force.r, task.q_init, goal_guess(task),
                    term_values=term_values(method, force, task.terms), q_goal=np.array(GOAL))
    return opt, sol


def kinematic_excess(task: object, opt: TrajectoryOptimizer, q: np.ndarray) -> float:
    """The largest excess over the joint limits and the velocity limits ``|q_k - q_{k-1}| <= v dt_k``,
    measured here with numpy from the robot's limits (not from the NLP's rows)."""
    arm = q[:, N_BASE:]
    limits = np.maximum(np.maximum(task.robot.lower - arm, arm - task.robot.upper), 0).max()
    dt = np.diff(task.t)[:, None]
    rows = opt._vel_rows
    speed = np.abs(np.diff(q, axis=0))[:, rows] - opt._vel[rows][None, :] * dt
    return float(max(limits, speed.max(initial=0.0)))


def test_the_stall_exit_is_set_for_goal_tasks_and_off_for_warm_solves():
    task = goal_task()
    options = SolverOptions(constraint_tol=3e-7)
    goal = TrajectoryOptimizer(task.robot, task.n, options=options, limits=task.limits, goal="configuration")
    opts = ipopt_options(goal)
    assert opts["ipopt.acceptable_iter"] == STALL_ITERATIONS > 1
    assert opts["ipopt.acceptable_obj_change_tol"] == STALL_CHANGE < 1e-3
    assert opts["ipopt.acceptable_constr_viol_tol"] == 3e-7  # the task's own tolerance, not IPOPT's 1e-2
    assert (opts | warm_options(options))["ipopt.acceptable_iter"] == 0  # a warm solve converges or fails
    path = TrajectoryOptimizer(task.robot, task.n, options=options, limits=task.limits)
    assert "ipopt.acceptable_iter" not in ipopt_options(path)  # a given path: IPOPT's defaults
    # the task file's extra options still win
    given = TrajectoryOptimizer(task.robot, task.n, options=replace(options, extra={"acceptable_iter": 3}),
                                limits=task.limits, goal="configuration")
    assert ipopt_options(given)["ipopt.acceptable_iter"] == 3


def test_a_stalled_goal_solve_is_feasible_and_near_the_converged_optimum():
    """With the stall test made trivial (any objective change, one iteration), IPOPT stops at its
    first iterate within the constraint tolerance: the result counts as a success only because
    the iterate is feasible (checked here against the robot's limits), and the default stall
    test returns an objective within ``STALL_ITERATIONS * STALL_CHANGE`` (relative, with slack) of
    the fully converged solve's."""
    task = goal_task()
    base = replace(task.solver, max_iter=300)
    opt_full, full = solve(task, replace(base, extra={"acceptable_iter": 0}))  # no acceptable exit
    assert full.success and full.status == "Solve_Succeeded"
    opt_stall, stall = solve(task, base)
    assert stall.success and stall.iterations <= full.iterations
    assert abs(stall.objective - full.objective) <= 10 * STALL_ITERATIONS * STALL_CHANGE * abs(full.objective)
    assert kinematic_excess(task, opt_stall, stall.q) <= base.constraint_tol
    np.testing.assert_allclose(stall.q[-1], GOAL, atol=1e-9)
    opt_early, early = solve(task, replace(base, extra={"acceptable_iter": 1, "acceptable_obj_change_tol": 1e20}))
    assert early.status == "Solved_To_Acceptable_Level" and early.iterations < full.iterations
    assert early.success and early.constraint_violation <= base.constraint_tol
    assert kinematic_excess(task, opt_early, early.q) <= base.constraint_tol
