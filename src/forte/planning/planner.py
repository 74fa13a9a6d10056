"""Planning: from a validated :class:`~forte.planning.tasks.Task` to a whole-body plan and its metrics.

Methods (paper, Section 5):

- ``forte``: the full cost ``J1 + J2 + J3 + J4 + J5``;
- ``manipulability``: the same problem without ``J1``;
- ``rfp-radius`` / ``rfp-cone``: ``J1`` replaced by ``1 / max(|value|, eps)`` of the centred
  inscribed radius or the cone measure of the RFP (Ferrolho et al. 2021);
- ``quintic`` (trajectory mode): the interpolated path followed by damped least-squares IK,
  no optimization (also the optimizer's initial guess);
- ``teaching`` (hold mode): the user's teaching configuration, no optimization.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from forte.capability.metrics import capability_margin, yoshikawa
from forte.capability.polytope import directional_capacity, inscribed_radius, trajectory_rfp
from forte.exceptions import InfeasibleTaskError, InvalidInputError, TaskFileError
from forte.force.taskforce import TaskForce
from forte.model.robot import MobileManipulator
from forte.planning.ik import follow_path, solve_pose
from forte.planning.optimizer import OPTIMIZED_METHODS, Solution, TrajectoryOptimizer
from forte.planning.tasks import Task
from forte.validation import FloatArray

TRAJECTORY_METHODS: tuple[str, ...] = (*OPTIMIZED_METHODS, "quintic")
HOLD_METHODS: tuple[str, ...] = (*OPTIMIZED_METHODS, "teaching")
ALL_METHODS: tuple[str, ...] = (*OPTIMIZED_METHODS, "quintic", "teaching")


@dataclass
class PlanResult:
    """A plan: configurations, the desired force, per-waypoint metrics and solver facts."""

    task: Task
    method: str
    q: FloatArray
    force: TaskForce
    metrics: dict[str, FloatArray]
    success: bool
    status: str
    solver: dict[str, Any] = field(default_factory=dict)
    estimate: dict[str, Any] | None = None

    @property
    def t(self) -> FloatArray:
        return self.task.t


def methods_for(task: Task) -> tuple[str, ...]:
    """Methods that apply to the task (``teaching`` only with a teaching configuration)."""
    if task.mode == "hold":
        return HOLD_METHODS if task.teaching is not None else OPTIMIZED_METHODS
    return TRAJECTORY_METHODS


def evaluate(
    robot: MobileManipulator, q: FloatArray, t: FloatArray, force: TaskForce, alpha: float
) -> dict[str, FloatArray]:
    """Exact per-waypoint metrics of a plan (the quantities reported in metrics.csv).

    ``d`` uses the metric's ``alpha``; the directional capacity (along the desired force) and
    the inscribed radius are those of the paper's RFP ``P_r,k`` itself (``alpha = 1``).
    """
    rfp = trajectory_rfp(robot, q, t, alpha=1.0)
    capacity = directional_capacity(rfp.A, rfp.b, force.direction)
    return {
        "t": np.asarray(t, dtype=float),
        "fx": force.f[:, 0], "fy": force.f[:, 1], "fz": force.f[:, 2],
        "radius": force.r,
        "d": capability_margin(rfp.A, alpha * rfp.b, force.f, force.r),  # b scales with alpha
        "directional_capacity": capacity,
        "capacity_margin": capacity - (force.magnitude + force.r),
        "inscribed_radius": inscribed_radius(rfp.A, rfp.b),
        "manipulability": yoshikawa(rfp.J),
        "max_torque_ratio": np.max(np.abs(rfp.tau_nom) / robot.torque_limits, axis=1),
        # nominal torque plus the torque that applies the desired force, tau_nom + J^T f
        "max_torque_ratio_with_force": np.max(
            np.abs(rfp.tau_nom + np.einsum("kij,ki->kj", rfp.J, force.f)) / robot.torque_limits, axis=1),
    }


def resolve_mass(task: Task, estimator_options: dict[str, Any] | None = None) -> dict[str, Any] | None:
    """Fill ``task.payload['mass']`` from the estimator when only a description/image is given."""
    if task.force_profile is not None or task.payload.get("mass") is not None:
        return task.payload.get("estimate")
    if not (task.payload.get("description") or task.payload.get("image")):
        raise TaskFileError(f"{task.source}: payload: give a mass, a description or an image")
    from forte.force.estimate import estimate_payload

    estimate = estimate_payload(task.payload.get("description"), task.payload.get("image"),
                                **(estimator_options or {}))
    task.payload["mass"] = float(estimate.mass_kg)
    task.payload["estimate"] = estimate.to_dict()  # every later plan of this task reports it too
    return task.payload["estimate"]


def initial_guess(task: Task) -> FloatArray:
    """Feasible, smooth start: IK along the path (trajectory) or onto the pose (hold)."""
    if task.mode == "hold":
        q, err = solve_pose(task.robot, task.targets[0], task.q_init)
        if np.linalg.norm(err[:3]) > 1e-4:
            raise InfeasibleTaskError(f"hold pose unreachable from initial_configuration: position error "
                                      f"{np.linalg.norm(err[:3]):.4f} m")
        return q[None]
    return follow_path(task.robot, task.targets, task.q_init)


#: Trajectories longer than this are solved coarse-to-fine (see :func:`coarse_guess`).
COARSE_WAYPOINTS = 25


def coarse_guess(task: Task, method: str) -> tuple[FloatArray, dict[str, Any]] | None:
    """Solve the same task on ``COARSE_WAYPOINTS`` samples and interpolate the result in time.

    A fine horizon makes the finite-difference accelerations stiff (``1 / dt^2``) and IPOPT slow
    from the IK guess; starting from the interpolated coarse optimum halves the iterations at
    N = 100 (see ``benchmarks/bench_planner.py``). Returns ``None`` when it does not apply.
    """
    if task.mode != "trajectory" or task.n <= 2 * COARSE_WAYPOINTS or not task.raw:
        return None
    from forte.planning.tasks import task_from_dict

    coarse = task_from_dict(task.raw, task.source, mass=task.payload.get("mass"), waypoints=COARSE_WAYPOINTS)
    coarse.weights, coarse.solver = task.weights, task.solver
    force = coarse.force()
    opt = TrajectoryOptimizer(task.robot, coarse.n, method, task.weights, options=task.solver, limits=task.limits)
    sol = opt.solve(coarse.t, coarse.targets, force.f, force.r, coarse.q_init, initial_guess(coarse))
    if not sol.success:
        return None
    q = np.column_stack([np.interp(task.t, coarse.t, sol.q[:, j]) for j in range(sol.q.shape[1])])
    q[0] = task.q_init
    return q, {"waypoints": coarse.n, "iterations": sol.iterations, "solve_time_s": sol.solve_time}


def plan(task: Task, method: str = "forte", estimator_options: dict[str, Any] | None = None,
         guess: FloatArray | None = None) -> PlanResult:
    """Plan ``task`` with ``method``; never raises for a solver failure (see ``success``)."""
    if method == "teaching" and task.mode == "hold" and task.teaching is None:
        raise TaskFileError(f"{task.source}: teaching_configuration: required for method 'teaching'")
    allowed = methods_for(task)
    if method not in allowed:
        raise InvalidInputError(f"method: '{method}' does not apply to mode '{task.mode}'; "
                                f"expected one of {', '.join(allowed)}")
    estimate = resolve_mass(task, estimator_options)
    force = task.force()
    robot = task.robot
    start = time.perf_counter()
    solver_info: dict[str, Any] = {}
    if method == "teaching":
        if task.teaching is None:
            raise TaskFileError(f"{task.source}: teaching_configuration: required for method 'teaching'")
        q, success, status = task.teaching[None], True, "not optimized (teaching point)"
    else:
        q_guess = initial_guess(task) if guess is None else guess
        if method == "quintic":
            q, success, status = q_guess, True, "not optimized (quintic path + IK)"
        else:
            options = task.solver
            warm = coarse_guess(task, method) if guess is None else None
            if warm is not None:
                q_guess = warm[0]
                solver_info["coarse"] = warm[1]
                # a near-optimal start: begin with a small barrier parameter
                options = replace(options, extra={"mu_strategy": "monotone", "mu_init": 1e-4} | options.extra)
            opt = TrajectoryOptimizer(robot, task.n, method, task.weights, fix_initial=task.mode != "hold",
                                      options=options, limits=task.limits)
            sol: Solution = opt.solve(task.t, task.targets, force.f, force.r, task.q_init, q_guess)
            q, success, status = sol.q, sol.success, sol.status
            solver_info |= {
                "status": sol.status, "success": sol.success, "iterations": sol.iterations,
                "objective": sol.objective, "constraint_violation": sol.constraint_violation,
                "build_time_s": sol.build_time, "solve_time_s": sol.solve_time, "kernels": sol.codegen,
                "cost_terms": opt.cost_terms(sol.q, task.t, task.targets, force.f, force.r),
            }
    solver_info["wall_time_s"] = time.perf_counter() - start
    metrics = evaluate(robot, q, task.t, force, task.weights.capability_params.alpha)
    return PlanResult(task=task, method=method, q=q, force=force, metrics=metrics, success=success,
                      status=status, solver=solver_info, estimate=estimate)
