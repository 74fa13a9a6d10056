"""Real-time iterations: one Newton step of the stagewise solver per control tick.

A converged re-plan (:class:`~forte.planning.online.replan.Replanner`) iterates until the KKT conditions
hold; a controller running at 100 Hz cannot wait for that after a large change. The real-time
iteration (Diehl, Bock and Schloeder's scheme, here on the interior-point equations of
:mod:`forte.planning.nlp.solvers.interior_point`) takes exactly one full Newton step per tick, on the
newest problem (payload mass, horizon shifted to the measured configuration), from the last
iterate: a tangent predictor of the new optimum, and over consecutive ticks a Newton iteration
that converges to it as long as the problem changes slowly.

A step is **published** (becomes the plan the controller follows) only when it is sound: its
configurations are finite, its constraint violation (pose rows, joint and kinematic bounds) is at
most ``violation_tol`` (default 1 mm / 1 mrad), and it finished within its deadline. Otherwise
the last published plan stays in force and the miss is counted (:attr:`RealTimeIteration.misses`
by reason); the solver still continues from the new iterate when it is finite (its next step
corrects it), and from the last sound one when it is not.
"""

from __future__ import annotations

import time
from collections import Counter
from typing import NamedTuple

import numpy as np

from forte.exceptions import InvalidInputError
from forte.force.taskforce import TaskForce
from forte.planning.nlp.blas import single_threaded_blas
from forte.planning.nlp.solvers.result import SolverResult
from forte.planning.online.replan import Problem, Replanner
from forte.planning.tasks.terms_section import term_values
from forte.validation import FloatArray

#: Largest constraint violation (m, rad) of a published real-time step.
VIOLATION_TOL = 1e-3


class RealTimeStep(NamedTuple):
    """One tick: the plan in force after it and what the step did."""

    q: FloatArray  # the plan in force (the new one when published, else the last published)
    force: TaskForce  # its task force
    t: FloatArray  # its waypoint times
    published: bool
    reason: str  # why not published: "deadline", "violation", "not finite", "solver error"; "" if published
    latency_s: float  # the whole tick: new problem data, step, checks
    violation: float  # of the new iterate
    kkt_error: float  # scaled KKT error (IPOPT's) at the step's starting point
    converged: bool  # the starting point already met the convergence test (no step taken)


class RealTimeIteration:
    """Real-time iterations on a :class:`Replanner`'s problem (its backend must be ``stagewise``).

    Args:
        replanner: planned once (its first, converged solve starts the iterations).
        violation_tol: largest constraint violation of a published step.
    """

    def __init__(self, replanner: Replanner, violation_tol: float = VIOLATION_TOL) -> None:
        if replanner.optimizer.stagewise() is None:
            raise InvalidInputError("real-time iterations need the stagewise backend "
                                    "(Replanner(..., backend='stagewise')) on a problem it handles")
        if not violation_tol > 0:
            raise InvalidInputError(f"violation_tol: expected a number > 0, got {violation_tol!r}")
        self.replanner, self.violation_tol = replanner, violation_tol
        self.solver = replanner.optimizer.stagewise()
        self.published = replanner.last.q.copy()
        self.published_force, self.published_t = replanner.force, replanner.task.t.copy()
        self.misses: Counter[str] = Counter()
        self.steps = 0

    def step(self, mass: float | None = None, steps: int = 0, q_now: FloatArray | None = None,
             deadline_s: float | None = None, v_now: FloatArray | None = None,
             a_now: FloatArray | None = None) -> RealTimeStep:
        """One tick: the problem after the changes (a new payload ``mass``; the horizon moved
        ``steps`` waypoints, starting at ``q_now`` with ``v_now, a_now``, default: the plan's,
        :meth:`~forte.planning.online.replan.Replanner.shift`), one Newton step, the checks."""
        start = time.perf_counter()
        rp = self.replanner
        with single_threaded_blas():
            if steps:
                pb = rp._shifted(steps, q_now, mass, v_now, a_now)
            elif mass is not None or q_now is not None:
                pb = rp._changed(mass, None, None, q_now)
            else:
                pb = Problem(rp.task, rp.force, rp.nominal, rp.last.q, rp.last.iterate)
            new, error, converged, reason, violation = self._newton(pb)
        latency = time.perf_counter() - start
        if not reason and deadline_s is not None and latency > deadline_s:
            reason = "deadline"
        self.steps += 1
        if reason:
            self.misses[reason] += 1
        else:
            self.published = new.q
            self.published_force, self.published_t = pb.force, pb.task.t.copy()
        return RealTimeStep(self.published, self.published_force, self.published_t, not reason, reason,
                            latency, violation, error, converged)

    def _newton(self, pb: Problem) -> tuple[SolverResult, float, bool, str, float]:
        """The step on ``pb`` from its warm iterate; the replanner moves on to ``pb`` and the new
        iterate (or keeps the last one when the step is not finite)."""
        rp, solver, ip = self.replanner, self.solver, self.solver.ip
        task = pb.task
        data = solver.data(task.t, task.targets, pb.force.f, pb.force.r, task.q_init, pb.nominal,
                           term_values(rp.optimizer.method_spec, pb.force, task.terms), task.start_motion)
        it = solver.start(pb.guess, data, pb.warm)
        ev = ip.evaluate(it, data)
        error, start_violation = ip.error(ev, it, data, 0.0)
        converged = error <= ip.tol and start_violation <= ip.constraint_tol
        reason = ""
        if not converged:
            # each tick's problem is new: no filter entries from another one, and the inertia
            # correction starts again from the smallest (carrying the last tick's on, 1.9 Cholesky
            # factorizations per tick instead of 3.7, damped the steps: after shifts with a new mass
            # 5 of 60 steps were sound instead of 35)
            ip.reset()
            try:
                it, _, _ = ip.iteration(it, ev, data, line_search=True)
            except (np.linalg.LinAlgError, FloatingPointError):
                reason = "solver error"
        q = solver.problem.x_of(it.y, data).reshape(task.n, task.robot.nq).copy()
        violation = np.inf
        if not reason and not (np.isfinite(q).all() and np.isfinite(it.lam).all()):
            reason = "not finite"
        if not reason:
            violation = ip.violation(ip.pose_rows(it.y, data), it.y, data)
            reason = "violation" if not violation <= self.violation_tol else ""
        result = SolverResult(q=q, success=converged, status="Solve_Succeeded" if converged else "Real_Time_Step",
                              iterations=0 if converged else 1, objective=float(ev.f) / it.scale,
                              constraint_violation=violation, build_time=0.0, solve_time=0.0,
                              codegen=rp.optimizer.codegen, iterate=it)
        if reason not in ("not finite", "solver error"):  # the replanner follows the newest problem
            rp.task, rp.force, rp.nominal, rp.last = task, pb.force, pb.nominal, result
        return result, error, converged, reason, violation

