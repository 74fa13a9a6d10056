"""Warm re-planning: keep the compiled problem and the last primal-dual solution, re-solve fast.

A :class:`Replanner` builds the NLP of one task once (its horizon ``N`` fixed) and solves it.
After a change of payload mass, force profile, targets or start configuration it re-solves
from the last solution: the configurations as the initial guess and the last bound and
constraint multipliers as IPOPT's warm start (small barrier parameter, tiny bound pushes), so
a re-plan typically takes a handful of iterations instead of tens.

:meth:`Replanner.shift` moves the horizon forward (receding horizon): the targets, the guess and
the multipliers are shifted by whole waypoints and the tail holds the last target, so ``N``
and the compiled problem stay the same.

A re-plan that IPOPT does not converge is retried once from the cold initial guess; if that
fails too the result says so (``success`` false) and the last good solution is kept: a
re-plan never returns an unconverged plan as a success.
"""

from __future__ import annotations

import time
from dataclasses import replace
from typing import Any, NamedTuple

import numpy as np

from forte.exceptions import InvalidInputError
from forte.force.taskforce import TaskForce
from forte.planning.ik import initial_guess
from forte.planning.methods import get_method
from forte.planning.optimizer import SolverResult, TrajectoryOptimizer, shift_rows
from forte.planning.planner import Plan, evaluate, resolve_payload
from forte.planning.tasks import Task
from forte.validation import FloatArray


class ReplanResult(NamedTuple):
    """One re-plan: the plan, its latency and how it was reached."""

    plan: Plan
    latency_s: float
    iterations: int
    warm: bool  # solved from the last primal-dual point (else: a cold retry)


class Replanner:
    """Plans ``task`` once and re-plans it quickly after changes (see the module docstring).

    Args:
        task: A trajectory task (payload resolved or resolvable).
        method: An optimized method.
        estimator_options: For a payload that still needs a mass estimate.
    """

    def __init__(self, task: Task, method: str = "forte", estimator_options: dict[str, Any] | None = None) -> None:
        self.method = get_method(method)
        if not self.method.optimized:
            raise InvalidInputError(f"method: re-planning needs an optimized method, got '{self.method.name}'")
        self.task = resolve_payload(task, estimator_options)
        self.optimizer = TrajectoryOptimizer(
            task.robot, task.n, self.method, task.weights, fix_initial=task.mode != "hold",
            options=task.solver, limits=task.limits, keep_multipliers=True)
        self.force = self.task.force()
        first = self._solve(initial_guess(self.task), warm=None)
        if not first.success:
            raise InvalidInputError(f"re-planning: the first solve failed ({first.status}); nothing to warm-start")
        self.last = first

    # -- changes ------------------------------------------------------------------------
    def replan(self, mass: float | None = None, force: TaskForce | None = None, targets: FloatArray | None = None,
               q_init: FloatArray | None = None) -> ReplanResult:
        """Re-solve after a new payload ``mass``, ``force`` profile, ``targets`` or start ``q_init``."""
        task = self.task
        if targets is not None:
            task = replace(task, targets=np.asarray(targets, dtype=float))
        if q_init is not None:
            task = replace(task, q_init=task.robot.check_configuration(q_init, "q_init"))
        if mass is not None:
            task = task.with_payload(task.payload.with_mass(mass, source="replan"))
        new_force = force if force is not None else (task.force() if (mass is not None or targets is not None)
                                                     else self.force)
        guess = self.last.q.copy()
        guess[0] = task.q_init
        return self._commit(task, new_force, guess, (self.last.lam_x, self.last.lam_g))

    def shift(self, steps: int, q_now: FloatArray | None = None, mass: float | None = None) -> ReplanResult:
        """Move the horizon ``steps`` waypoints forward; the tail holds the last target.

        ``q_now`` (the measured configuration) becomes the new first waypoint (default: the
        planned one at the new start); ``mass``, when given, is the payload's new mass. The new
        first waypoint starts at rest, as every plan does (the backward differences need it).
        """
        n = self.task.n
        if not 0 < steps < n:
            raise InvalidInputError(f"steps: expected 0 < steps < {n}, got {steps}")
        targets = shift_rows(self.task.targets, steps)
        guess = shift_rows(self.last.q, steps)
        guess[0] = guess[0] if q_now is None else self.task.robot.check_configuration(q_now, "q_now")
        task = replace(self.task, targets=targets, q_init=guess[0].copy())
        if mass is not None:
            task = task.with_payload(task.payload.with_mass(mass, source="replan"))
        force = self.force if self.task.force_profile is not None else task.force()
        if self.task.force_profile is not None:
            force = TaskForce(self.force.t, shift_rows(self.force.f, steps), shift_rows(self.force.r, steps))
        lam_x, lam_g = self.optimizer.shifted_multipliers(self.last.lam_x, self.last.lam_g, steps)
        return self._commit(task, force, guess, (lam_x, lam_g))

    # -- solving ------------------------------------------------------------------------
    def _commit(self, task: Task, force: TaskForce, guess: FloatArray,
                warm: tuple[FloatArray, FloatArray]) -> ReplanResult:
        start = time.perf_counter()
        sol, used_warm = self._solve(guess, warm, task, force), True
        iterations = sol.iterations
        if not sol.success:  # one cold retry before giving up
            sol, used_warm = self._solve(initial_guess(task), None, task, force), False
            iterations += sol.iterations
        latency = time.perf_counter() - start
        if sol.success:
            self.task, self.force, self.last = task, force, sol
        plan = Plan(method=self.method.name, robot=task.robot, t=task.t, q=sol.q, force=force, payload=task.payload,
                    metrics=evaluate(task.robot, sol.q, task.t, force, task.weights.capability_params),
                    success=sol.success, status=sol.status,
                    solver={"iterations": iterations, "latency_s": latency, "warm": used_warm}, task=task)
        return ReplanResult(plan, latency, iterations, used_warm)

    def _solve(self, guess: FloatArray, warm: tuple[FloatArray, FloatArray] | None, task: Task | None = None,
               force: TaskForce | None = None) -> SolverResult:
        task = task or self.task
        force = force or self.force
        return self.optimizer.solve(task.t, task.targets, force.f, force.r, task.q_init, guess, warm=warm)


