"""Whole-body trajectory optimization (paper, Section 4.3) with IPOPT through CasADi.

    min_Q  sum_i w_i J_i(Q)
    s.t.   x(q_k) = x_k          (end-effector position and orientation), k = 2..N
           q_a^min <= q_a,k <= q_a^max
           q_1 = q_init          (trajectory mode; free in single-point holding mode)

A goal task (``goal``) has a free path: its pose rows are the goal's alone (a pose goal:
``x(q_N) = x_goal``; a configuration goal: none, ``q_N = q_goal`` by the variables' bounds).
``keep_level`` adds ``w . R(q_k) a >= cos(max_tilt)`` at the waypoints the solver orients, after
every other row (:mod:`forte.planning.nlp.keep_level_rows`).

Design:

- the objective is the method's cost terms (:mod:`forte.planning.methods.catalog`): the stage terms are
  compiled per-waypoint kernels (:mod:`forte.planning.nlp.kernels`) ``map``-ped over the horizon,
  the quadratic terms one constant sparse matrix, so the expression graph and the exact
  Hessian stay linear in N;
- a quadratic term whose matrix is dense (J5) enters in its lifted form
  (:meth:`~forte.planning.terms.costs.CostTerm.lifted`): a sparse ``D`` plus variables ``z = A x``
  appended after ``vec(q_1..q_N)`` and equality rows ``A x - z = 0`` appended after all other
  constraints, so the KKT matrix stays sparse (:mod:`forte.planning.terms.spectral`);
- all task data (time steps, forces, radii, target poses, term parameters such as cone rays)
  are NLP *parameters*: a problem is built once per (robot, N, method, weights) and reused for
  every task of that size;
- the gradient, constraint Jacobian and Lagrangian Hessian are scattered into sparse matrices
  by constant matrices (:mod:`forte.planning.nlp.assembly`) and handed to IPOPT;
- the orientation constraint is ``vee(R_d^T R - R^T R_d) / 2 = 0`` (three equations; the
  initial guess from IK is feasible, far from the 180-degree ambiguity).
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from forte import progress
from forte.exceptions import InvalidInputError, SolverError
from forte.model.robot import MobileManipulator
from forte.model.trajectory import StartMotion
from forte.planning.methods.catalog import Method, get_method, method_names
from forte.planning.nlp import layout
from forte.planning.nlp.collision_kernels import load_collision_kernels
from forte.planning.nlp.collision_slots import Slots
from forte.planning.nlp.history import history_parameters
from forte.planning.nlp.ipopt_nlp import warm_options
from forte.planning.nlp.ipopt_progress import margin_of
from forte.planning.nlp.kernels import load_kernels, notice
from forte.planning.nlp.solvers.result import SolverResult, accepted_violation
from forte.planning.nlp.solvers.stage_problem import StageNLP, supported
from forte.planning.nlp.structure import NlpStructure
from forte.planning.tasks.keep_level import KeepLevel
from forte.settings import (
    DEFAULT_WEIGHT_SET,
    WEIGHT_SETS,
    CostWeights,
    KinematicLimits,
    SolverOptions,
    TermSettings,
    WeightSet,
)
from forte.validation import FloatArray

#: The weights a task file gets by default in trajectory mode.
DEFAULT_TRAJECTORY_WEIGHTS = WEIGHT_SETS[DEFAULT_WEIGHT_SET["trajectory"]]


class TrajectoryOptimizer(NlpStructure):
    """The FORTE NLP (or a baseline) for one robot, horizon ``n`` and method.

    Args:
        robot: The mobile manipulator.
        n: Number of waypoints (1 gives single-point holding).
        method: An optimized method of :data:`forte.planning.methods.catalog.METHODS` (name or object).
        weights: Cost weights, or a named set with its term settings (default: forte's
            trajectory set, as a task file gets; the authors' exact set is
            ``WEIGHT_SETS['authors-trajectory']``).
        fix_initial: Fix ``q_1 = q_init`` (trajectory mode). With ``False`` (holding), the
            first configuration is free and ``q_init`` only seeds the solver.
        options: Solver and build options.
        limits: Joint velocity and acceleration limits.
        keep_multipliers: Return the bound and constraint multipliers of every solve, so the
            next solve can start from the last primal-dual point (:meth:`solve`'s ``warm``).
        slots: Robot-versus-scene pairs that get clearance rows (:mod:`forte.planning.nlp.collision_slots`;
            ``None``: no scene, no rows). The rows are part of the problem's structure, so a
            problem with slots serves one assignment of pairs.
        settings: The cost terms' parameters (:class:`~forte.settings.TermSettings`, term ->
            {setting: value}); default: the set's when ``weights`` is a
            :class:`~forte.settings.WeightSet`, else the terms' declared defaults.
        goal: ``None`` (a pose equality at every waypoint after the first), ``pose`` (at the last
            waypoint only) or ``configuration`` (none: :meth:`solve`'s ``q_goal`` bounds the last
            configuration), :mod:`forte.planning.tasks.goals`.
        via_steps: a goal task's via waypoints (0-based), each with a pose equality too
            (:mod:`forte.planning.tasks.goal_poses`).
        keep_level: a tool axis kept near a world axis (``path.keep_level``): one row per waypoint
            the solver orients (:mod:`forte.planning.nlp.keep_level_rows`); ``None``: none.
        on_spline: bound the arm's velocities and accelerations on the executed spline too,
            everywhere (:mod:`forte.planning.nlp.spline_rows`); ``None``:
            ``limits.on_spline``'s choice
            (:class:`~forte.settings.KinematicLimits`).
    """

    def __init__(
        self, robot: MobileManipulator, n: int, method: str | Method = "forte",
        weights: CostWeights | WeightSet = DEFAULT_TRAJECTORY_WEIGHTS, fix_initial: bool = True,
        options: SolverOptions = SolverOptions(), limits: KinematicLimits = KinematicLimits(),
        keep_multipliers: bool = False, slots: Slots | None = None, settings: TermSettings | None = None,
        goal: str | None = None, keep_level: KeepLevel | None = None, via_steps: tuple[int, ...] = (),
        on_spline: bool | None = None,
    ) -> None:
        resolved = get_method(method) if isinstance(method, Method) or method in method_names() else None
        if resolved is None or not resolved.optimized:
            raise InvalidInputError(f"method: expected one of {', '.join(method_names(optimized=True))}, "
                                    f"got '{getattr(method, 'name', method)}'")
        if n < 1:
            raise InvalidInputError(f"waypoints: expected at least 1, got {n}")
        self.robot, self.n, self.method_spec = robot, n, resolved
        self.method = resolved.name
        if isinstance(weights, WeightSet):
            weights, settings = weights.weights, weights.settings if settings is None else settings
        weights, settings = resolved.resolve(weights, settings)
        self.weights, self.settings, self.fix_initial, self.options = weights, settings, fix_initial, options
        self.limits, self.keep_multipliers = limits, keep_multipliers
        if goal not in (None, "pose", "configuration"):
            raise InvalidInputError(f"goal: expected 'pose' or 'configuration', got {goal!r}")
        if via_steps and (goal is None or not all(0 < k < n - 1 for k in via_steps)):
            raise InvalidInputError(f"via_steps: expected waypoints strictly between the first and the last of a "
                                    f"goal task, got {list(via_steps)}")
        self.goal, self.keep_level = goal, keep_level
        self.via_steps = tuple(sorted({int(k) for k in via_steps}))
        self._warm_solver: Any = None
        self._spline_times: tuple[FloatArray, FloatArray | None] | None = None
        self._vel, self._acc = limits.resolve(robot)
        #: velocities and accelerations bounded on the executed spline too (spline_rows); default: on
        asked = limits.on_spline if on_spline is None else on_spline
        self.on_spline = asked is not False and limits.enabled and fix_initial and n >= 3
        self._spline_asked = asked is True  # the stagewise backend has no spline rows: IPOPT then
        terms = resolved.cost_terms(settings)
        self._stage = tuple(t for t in terms if t.kind == "stage")
        self._quadratic = tuple(t for t in terms if t.kind == "quadratic")
        start = time.perf_counter()
        self.slots = slots
        self._clear = [load_collision_kernels(robot, f.frame, f.slots, options, f.other)
                       for f in slots.frames] if slots else []
        self.kernels = load_kernels(robot, resolved, settings, options)
        self._drop_implied = True  # the waypoint rows the spline's imply: out (ipopt_nlp.kinematic_rows)
        self._build()
        self.build_time = time.perf_counter() - start

    @property
    def codegen(self) -> str:
        return self.kernels.origin

    @property
    def term_names(self) -> list[str]:
        return [t.name for t in (*self._stage, *self._quadratic)]

    def warm_solver(self) -> Any:
        """The same NLP with IPOPT set to start from a given primal-dual point (built once; its
        options: :func:`~forte.planning.nlp.ipopt_nlp.warm_options`)."""
        if self._warm_solver is None:
            self._warm_solver = self._nlpsol(dict(self._nlp_options) | warm_options(self.options))
        return self._warm_solver

    # -- solving ------------------------------------------------------------------------
    def parameters(self, t: FloatArray, targets: FloatArray, f: FloatArray, r: FloatArray,
                   nominal: FloatArray | None = None, term_values: dict[str, Any] | None = None,
                   start: StartMotion | None = None) -> FloatArray:
        """Pack the task data into the NLP parameter vector (``nominal``: N x nq, default zeros;
        ``term_values``: values of term parameters given by the caller, by name, e.g. the task's
        moment for ``wrench_capability``, instead of the term's ``parameter_values``; ``start``:
        the first waypoint's motion, :mod:`forte.planning.nlp.history`)."""
        n = self.n
        t = np.asarray(t, dtype=float)
        dt, offsets = history_parameters(self.fix_initial, n, self.robot.nq, t, start)
        f = np.asarray(f, dtype=float)
        r = np.asarray(r, dtype=float)
        values = {
            "dt": dt, "history": offsets.ravel(), "f": f.ravel(), "r": r,
            "q_nom": np.zeros(n * self.robot.nq) if nominal is None else np.asarray(nominal, dtype=float).ravel(),
            "p_d": targets[:, :3, 3].ravel(),
            "R_d": np.concatenate([T[:3, :3].ravel(order="F") for T in targets]),
        }
        given = term_values or {}
        for term in self._stage:
            values |= {name: np.asarray(given[name], dtype=float).ravel() if name in given
                       else term.parameter_values(name, f, r) for name, _ in term.parameters}
        for f, ck in zip(self.slots.frames if self.slots else (), self._clear, strict=True):
            values[ck.name] = f.values.ravel()
        self._spline_times = (t, self._spline_start(start))  # full_x's knot slopes
        return np.concatenate([values[name] for name in self._layout])

    def solve(self, t: Any, targets: Any, f: Any, r: Any, q_init: FloatArray, q_guess: FloatArray,
              nominal: FloatArray | None = None, warm: tuple[FloatArray, FloatArray] | Any | None = None,
              term_values: dict[str, Any] | None = None, start: StartMotion | None = None,
              q_goal: FloatArray | None = None) -> SolverResult:
        """Solve for the whole-body trajectory (N x nq) from the initial guess ``q_guess``.

        ``nominal`` (N x nq) is the nominal trajectory of the nominal and base joint-limit terms
        (default: ``q_guess``). ``warm = (lam_x, lam_g)``, the multipliers of an earlier solve of
        this problem (see ``keep_multipliers``), starts IPOPT from that primal-dual point with a
        small barrier parameter instead of from scratch. ``term_values``: see :meth:`parameters`.
        ``start``: the first waypoint's velocity and acceleration (default: at rest;
        :mod:`forte.planning.nlp.history`). ``q_goal``: the last configuration of a configuration goal.
        """
        if (q_goal is not None) != (self.goal == "configuration"):
            raise InvalidInputError("q_goal: given exactly for a problem built with goal='configuration'")
        n, nq = self.n, self.robot.nq
        targets = np.asarray(targets, dtype=float)
        self._nominal = np.asarray(q_guess if nominal is None else nominal, dtype=float).reshape(n, nq)
        stagewise = self.stagewise()
        if stagewise is not None:
            return stagewise.solve(t, targets, f, r, q_init, q_guess, self._nominal,
                                   warm if warm is None or not isinstance(warm, tuple) else None, term_values, start)
        if warm is not None and not isinstance(warm, tuple):
            warm = None  # a stagewise iterate does not warm-start IPOPT
        if self._restore_rows(t, start):
            warm = None  # multipliers of the problem without those rows
        p = self.parameters(t, targets, f, r, self._nominal, term_values, start)
        lbx, ubx, lbg, ubg = self.bounds(t, q_init, start, q_goal)
        x0 = self.full_x(np.clip(np.asarray(q_guess, dtype=float).ravel(), lbx[: n * nq], ubx[: n * nq]))
        start = time.perf_counter()
        solver, extra = self.solver, {}
        if warm is not None:
            solver, extra = self.warm_solver(), {"lam_x0": warm[0], "lam_g0": warm[1]}
        if self._progress is not None:
            self._progress.start(lbg, ubg, margin_of(self.robot, self.n, np.asarray(t, dtype=float), f, r,
                                                     self.settings.alpha))
        try:
            with progress.step(f"solving with IPOPT ({self.method}, N = {n})"):
                result = solver(x0=x0, p=p, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg, **extra)
        except RuntimeError as exc:  # IPOPT refused the problem (bad option values, inconsistent bounds)
            raise SolverError(f"IPOPT refused the problem: {str(exc).splitlines()[-1]}", status="error") from exc
        solve_time = time.perf_counter() - start
        stats = solver.stats()
        x = np.array(result["x"]).ravel()
        g = np.array(self._g(x, p)).ravel()
        bounds = np.maximum(np.maximum(lbx - x, x - ubx), 0)
        g_excess = np.maximum(np.maximum(lbg - g, g - ubg), 0)
        violation = float(max(g_excess.max(initial=0.0), bounds.max(initial=0.0)))
        tol = accepted_violation(self.options)
        return SolverResult(
            q=x[: n * nq].reshape(n, nq), success=bool(stats.get("success", False)) and violation <= tol,
            status=str(stats.get("return_status", "unknown")), iterations=int(stats.get("iter_count", -1)),
            objective=float(result["f"]), constraint_violation=violation, build_time=self.build_time,
            solve_time=solve_time, codegen=self.codegen,
            lam_x=np.array(result["lam_x"]).ravel() if self.keep_multipliers or warm else None,
            lam_g=np.array(result["lam_g"]).ravel(),
        )

    def _restore_rows(self, t: Any, start: StartMotion | None) -> bool:
        """Build the problem again with every waypoint row when the times ``t`` or the ``start``
        leave some of the rows left out unimplied by the spline's
        (:meth:`~forte.planning.nlp.spline_rows.SplineCoordinates.implied`); True when it did."""
        left_out = self._drop_implied and self._spline_rows and (
            self._vel_rows.size < self._limited[0].size or self._acc_rows.size < self._limited[1].size)
        if not left_out or self._spline.implied(t, self._spline_start(start)):
            return False
        self._drop_implied, self._warm_solver = False, None
        self._build()
        return True

    def stagewise(self) -> Any:
        """The stage-structured solver of this problem when ``options.backend`` asks for it and
        it handles the problem (built once), else None (IPOPT solves). It has no rows on the
        executed spline (:mod:`~forte.planning.nlp.spline_rows`): it solves the waypoint rows alone
        unless ``on_spline`` was asked for explicitly (``true``: IPOPT solves, with them)."""
        if self.options.backend != "stagewise":
            return None
        if not hasattr(self, "_stagewise"):
            from forte.planning.nlp.solvers.stagewise import StagewiseSolver

            nlp = self.stage_nlp()
            why = "goal tasks" if self.goal is not None else "keep_level rows" if self._keep_steps.size \
                else "the executed spline's rows (limits.on_spline: true)" if self.on_spline and self._spline_asked \
                else supported(nlp)
            self._stagewise = StagewiseSolver(nlp) if why is None else None
            if why is not None:
                notice(f"the stagewise solver does not handle {why}; solving with IPOPT")
        return self._stagewise

    def stage_nlp(self) -> StageNLP:
        """This NLP as the stagewise solver receives it
        (:class:`~forte.planning.nlp.solvers.stage_problem.StageNLP`)."""
        weight = self.method_spec.term_weight
        return StageNLP(self.n, self.robot.nq, self.robot.n_arm, self.kernels, self._window_index(), self._pose_steps,
                        self._stage, np.array([weight(t, self.weights) for t in self._stage]), self._quadratic,
                        [weight(t, self.weights) for t in self._quadratic], self.rests_at_end, self.fix_initial,
                        *self._limited, self._vel, self._acc, self.bounds, self.slots is not None,
                        bool(self._lateral), self.options.tol, self.options.constraint_tol, self.options.max_iter,
                        self.build_time, self.codegen)

    def cost_terms(self, q: FloatArray, t: Any, targets: Any, f: Any, r: Any,
                   nominal: FloatArray | None = None, term_values: dict[str, Any] | None = None,
                   start: StartMotion | None = None) -> dict[str, float]:
        """Unweighted value of each cost term (capability-type terms are their smooth surrogates)."""
        if nominal is None:
            nominal = getattr(self, "_nominal", None)
        p = self.parameters(t, np.asarray(targets, dtype=float), f, r, nominal, term_values, start)
        values = np.array(self._terms(self.full_x(q), p)).ravel()
        return dict(zip(self.term_names, map(float, values), strict=True))

    def shifted_multipliers(self, lam_x: FloatArray, lam_g: FloatArray, steps: int) -> tuple[FloatArray, FloatArray]:
        """The multipliers of a solve moved ``steps`` waypoints forward (:func:`layout.shifted_multipliers`)."""
        return layout.shifted_multipliers(lam_x, lam_g, steps, self.n, self.robot.nq, self._pose_steps.tolist(),
                                          (len(self._vel_rows), len(self._acc_rows)))

    def term_weights(self) -> dict[str, float]:
        """The weight ``w_i`` this problem gives each term."""
        return {t.name: self.method_spec.term_weight(t, self.weights) for t in (*self._stage, *self._quadratic)}
