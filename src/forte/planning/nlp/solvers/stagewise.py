"""The stage-structured interior-point solver behind the optimizer's interface.

:class:`StagewiseSolver` solves a :class:`~forte.planning.nlp.optimizer.TrajectoryOptimizer`'s problem
with :class:`~forte.planning.nlp.solvers.interior_point.InteriorPoint` and returns the same
:class:`~forte.planning.nlp.optimizer.SolverResult` as IPOPT (``iterate`` carries the primal-dual
point for a warm start). ``solver: {backend: stagewise}`` in a task file, or
``Replanner(..., backend="stagewise")``, selects it; IPOPT stays the default and the reference
(the tests compare both on the same problems).
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from forte.model.trajectory import StartMotion
from forte.planning.nlp.blas import single_threaded_blas
from forte.planning.nlp.solvers.interior_point import InteriorPoint, IPResult, Iterate
from forte.planning.nlp.solvers.result import SolverResult
from forte.planning.nlp.solvers.stage_problem import StageNLP, StageProblem, TaskData
from forte.validation import FloatArray


class StagewiseSolver:
    """``nlp`` solved by the stage-structured interior-point method."""

    def __init__(self, nlp: StageNLP) -> None:
        self.nlp = nlp
        self.problem = StageProblem(nlp)
        self.ip = InteriorPoint(self.problem, tol=nlp.tol, constraint_tol=nlp.constraint_tol, max_iter=nlp.max_iter)

    def data(self, t: Any, targets: Any, f: Any, r: Any, q_init: FloatArray, nominal: FloatArray,
             term_values: dict[str, FloatArray] | None = None, start: StartMotion | None = None) -> TaskData:
        return self.problem.task_data(t, targets, f, r, q_init, nominal, term_values, start)

    def start(self, q_guess: FloatArray, data: TaskData, warm: Iterate | None) -> Iterate:
        """A cold start from ``q_guess`` or ``warm`` (its barrier parameter at the floor)."""
        if warm is None:
            return self.ip.start(self.problem.y_of(q_guess), data)
        it = self.ip.warm(warm, data)
        it.mu = self.ip.mu_min
        if warm.zl is None:  # a shifted iterate: bound multipliers on the central path
            lo, up = data.lo, data.up
            it.zl = np.where(lo, it.mu / np.where(lo, it.s - data.lower, 1.0), 0.0)
            it.zu = np.where(up, it.mu / np.where(up, data.upper - it.s, 1.0), 0.0)
        return it

    def solve(self, t: Any, targets: Any, f: Any, r: Any, q_init: FloatArray, q_guess: FloatArray,
              nominal: FloatArray, warm: Iterate | None = None, term_values: dict[str, FloatArray] | None = None,
              start: StartMotion | None = None) -> SolverResult:
        """Solve to convergence (``warm``: the iterate of an earlier solve of this problem;
        ``start``: the first waypoint's motion, :mod:`forte.planning.nlp.history`)."""
        data = self.data(t, targets, f, r, q_init, nominal, term_values, start)
        begin = time.perf_counter()
        with single_threaded_blas():  # small dense factorizations: threads only wait (forte.planning.nlp.blas)
            res = self.ip.solve(self.start(q_guess, data, warm), data)
        return self.result(res, data, time.perf_counter() - begin)

    def result(self, res: IPResult, data: TaskData, solve_time: float) -> SolverResult:
        pb = self.problem
        q = pb.x_of(res.iterate.y, data).reshape(pb.n, pb.nq).copy()
        ok = res.converged and np.isfinite(q).all()
        return SolverResult(q=q, success=ok, status=res.status, iterations=res.iterations, objective=res.objective,
                   constraint_violation=res.violation, build_time=self.nlp.build_time, solve_time=solve_time,
                   codegen=self.nlp.codegen, iterate=res.iterate, backend="stagewise")

    def shifted(self, it: Iterate, steps: int) -> Iterate:
        """``it`` moved ``steps`` waypoints forward (the tail holds the last): configurations and
        pose multipliers move with their waypoints; the rows' slacks and bound multipliers are
        set again for the new data by :meth:`start` (``mu / slack``)."""
        pb = self.problem
        src = pb.block_of[np.minimum(pb.owner + steps, pb.n - 1)]
        y = it.y.reshape(pb.blocks, pb.nq)[src].ravel()
        posed = {int(k): i for i, k in enumerate(pb.posed)}
        lam_src = [posed.get(min(int(k) + steps, pb.n - 1), pb.posed.size - 1) for k in pb.posed]
        return Iterate(y, it.lam[lam_src], it.s.copy(), None, None, it.mu, it.scale)  # type: ignore[arg-type]
