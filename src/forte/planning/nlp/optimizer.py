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

import casadi as ca
import numpy as np
from scipy import sparse

from forte import progress
from forte.exceptions import InvalidInputError, SolverError
from forte.model.robot import MobileManipulator
from forte.model.trajectory import StartMotion
from forte.planning.methods.catalog import Method, get_method, method_names
from forte.planning.nlp import layout
from forte.planning.nlp.assembly import dm, gather, hessian_pattern, scatter_matrix
from forte.planning.nlp.base_rows import lateral_hessian, lateral_rows, pin_base
from forte.planning.nlp.clearance_rows import clearance_hessian, clearance_jacobian
from forte.planning.nlp.collision_kernels import load_collision_kernels
from forte.planning.nlp.collision_slots import Slots
from forte.planning.nlp.history import history_parameters, history_windows, shifted_acceleration_bounds
from forte.planning.nlp.ipopt_nlp import (
    constraint_jacobian,
    ipopt_options,
    kinematic_rows,
    lagrangian_hessian,
    warm_options,
)
from forte.planning.nlp.ipopt_progress import IpoptProgress, margin_of
from forte.planning.nlp.keep_level_rows import keep_bounds, keep_rows, keep_steps
from forte.planning.nlp.kernels import load_kernels, notice
from forte.planning.nlp.solvers.result import SolverResult, accepted_violation
from forte.planning.nlp.solvers.stage_problem import StageNLP, supported
from forte.planning.nlp.spline_rows import SplineCoordinates, knot_accelerations, knot_bounds
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


class TrajectoryOptimizer:
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
        #: velocities and accelerations bounded on the executed spline too (spline_rows); default: goal tasks'
        asked = limits.on_spline if on_spline is None else on_spline
        self.on_spline = (goal is not None if asked is None else asked) and limits.enabled and fix_initial and n >= 3
        terms = resolved.cost_terms(settings)
        self._stage = tuple(t for t in terms if t.kind == "stage")
        self._quadratic = tuple(t for t in terms if t.kind == "quadratic")
        start = time.perf_counter()
        self.slots = slots
        self._clear = [load_collision_kernels(robot, f.frame, f.slots, options, f.other)
                       for f in slots.frames] if slots else []
        self.kernels = load_kernels(robot, resolved, settings, options)
        self._build()
        self.build_time = time.perf_counter() - start

    @property
    def codegen(self) -> str:
        return self.kernels.origin

    @property
    def term_names(self) -> list[str]:
        return [t.name for t in (*self._stage, *self._quadratic)]

    # -- construction -------------------------------------------------------------------
    def _parameter_layout(self) -> dict[str, tuple[int, int]]:
        n, nq = self.n, self.robot.nq
        sizes = {"dt": n, "history": 2 * nq, "f": 3 * n, "r": n, "q_nom": nq * n, "p_d": 3 * n, "R_d": 9 * n}
        for term in self._stage:
            sizes |= {name: size * n for name, size in term.parameters}
        for ck in self._clear:
            sizes[ck.name] = ck.size * n
        spans, offset = {}, 0
        for name, size in sizes.items():
            spans[name] = (offset, size)
            offset += size
        return spans

    def _window_index(self) -> FloatArray:
        """Global variable index of each entry of the stage window ``[q_{k-2}; q_{k-1}; q_k]``."""
        nq, n = self.robot.nq, self.n
        steps = np.arange(n)
        blocks = np.stack([np.maximum(steps - 2, 0), np.maximum(steps - 1, 0), steps])  # 3 x n
        return (blocks[:, None, :] * nq + np.arange(nq)[None, :, None]).reshape(3 * nq, n)

    def _quadratic_matrices(self) -> list[sparse.csr_matrix]:
        """Unweighted ``Q_i`` of the quadratic terms (``J_i = x^T Q_i x / 2``)."""
        return [t.matrix(self.robot.n_arm, self.n) for t in self._quadratic]

    @property
    def quadratic_forms(self) -> dict[str, str]:
        """How the optimizer solves each quadratic term (e.g. J5's ``dense``, ``lifted``, ``banded``)."""
        return {t.name: t.solved_as(self.n) for t in self._quadratic}

    def full_x(self, q: FloatArray) -> FloatArray:
        """The NLP's variables for configurations ``q`` (N x nq): ``vec(q)`` and the lifted
        ``z = A vec(q)`` (:mod:`forte.planning.nlp.layout`)."""
        x = layout.full_x(q, self._lift)
        if not self._spline_rows:
            return x
        if self._spline_times is None:  # no times yet (no parameters packed): 0
            return np.concatenate([x, np.zeros(len(self._spline_rows) * self.n)])
        t, v_start = self._spline_times
        q = np.asarray(q, dtype=float).reshape(self.n, self.robot.nq)[:, self._spline_rows]
        return np.concatenate([x, knot_accelerations(t, q, v_start).ravel()])

    def bounds(self, t: Any, q_init: FloatArray, start: StartMotion | None = None,
               q_goal: FloatArray | None = None) -> layout.Bounds:
        """Bounds of a solve at times ``t``: joint limits, ``q_1 = q_init`` (trajectory mode), free
        lifted variables; pose and lifting rows equal 0, kinematic rows within ``v dt``, ``a dt``
        (the first acceleration rows moved by the ``start`` velocity, :mod:`forte.planning.nlp.history`);
        ``q_N = q_goal`` when given (a configuration goal)."""
        lifted = self._lift.shape[0]
        lbx, ubx = layout.variable_bounds(self.robot, self.n, lifted, q_init if self.fix_initial else None)
        if self._spline_rows:  # the knot accelerations, last (spline_rows)
            low, high = knot_bounds(self._spline.acceleration, self.n)
            lbx, ubx = np.concatenate([lbx, low]), np.concatenate([ubx, high])
        pin_base(self.robot, self.n, lbx, ubx, q_init)
        if q_goal is not None:
            nq = self.robot.nq
            last = slice((self.n - 1) * nq, self.n * nq)
            lbx[last] = ubx[last] = np.asarray(q_goal, dtype=float)
        kinematic = layout.kinematic_bounds(self._vel[self._vel_rows], self._acc[self._acc_rows], t,
                                            2 * self.robot.nq if self.rests_at_end else 0)
        # a free path (goal task) leaves and enters its rests as the executed spline can follow
        # (layout.rest_entries); a given path shapes them itself (the stagewise solver takes no goal)
        rest_start = start is None or not np.any(start.velocity)
        ends = [] if self.goal is None else ([0] if rest_start else []) + ([self.n - 3] if self.rests_at_end else [])
        kinematic = layout.rest_entries(kinematic, self._vel_rows.size * (self.n - 1), self._acc_rows.size, ends)
        kinematic = shifted_acceleration_bounds(kinematic, start, self._vel_rows.size * (self.n - 1), self._acc_rows)
        lbg, ubg = layout.constraint_bounds(self._pose_steps.size, kinematic, lifted)
        if self._spline_rows:
            low, high = self._spline.bounds(t, self._spline_start(start))
            lbg, ubg = np.concatenate([lbg, low]), np.concatenate([ubg, high])
        clear = self._clear_index.size  # clearance rows: >= 0; then the base's lateral rows: = 0
        lateral = np.zeros(self._lateral)
        keep_low, keep_high = keep_bounds(self.keep_level, self._keep_steps.size)  # last: h >= cos(max_tilt)
        return layout.Bounds(lbx, ubx, np.concatenate([lbg, np.zeros(clear), lateral, keep_low]),
                             np.concatenate([ubg, np.full(clear, np.inf), lateral, keep_high]))

    def _build(self) -> None:
        robot, n, kern = self.robot, self.n, self.kernels
        nq = robot.nq
        self._layout = self._parameter_layout()
        P = ca.MX.sym("p", sum(size for _, size in self._layout.values()))

        def par(name: str, rows: int) -> ca.MX:
            off, size = self._layout[name]
            return ca.reshape(P[off:off + size], rows, size // rows)

        Q, self._lift = layout.lifted_quadratic(self._quadratic, [self.method_spec.term_weight(t, self.weights)
                                                           for t in self._quadratic], robot.n_arm, n, nq * n)
        Q, slopes = self._knot_variables(Q)
        x = ca.MX.sym("x", Q.shape[0])
        xq = x[: nq * n]
        X = ca.reshape(xq, nq, n)
        index = self._window_index()
        Z = ca.reshape(gather(x, index.T.ravel()), 3 * nq, n) + history_windows(par("history", 2 * nq), nq, n)
        dt = par("dt", 1)
        stage_args = [Z, ca.horzcat(dt[:, :1], dt[:, : n - 1]), dt, par("f", 3), par("r", 1), par("q_nom", nq)]
        stage_args += [par(name, size) for t in self._stage for name, size in t.parameters]
        stage_args.append(ca.repmat(ca.DM([self.method_spec.term_weight(t, self.weights) for t in self._stage]), 1, n))
        Qx = ca.mtimes(dm(Q), x)
        cost = ca.sum2(kern.cost.map(n)(*stage_args)) + 0.5 * ca.dot(x, Qx)
        first = 1 if self.fix_initial else 0
        self._pose_steps = self._posed_waypoints(first)
        pd, Rd = par("p_d", 3), par("R_d", 9)
        g_kin = kinematic_rows(self, X, dt)
        if self._lift.shape[0]:  # z = A x
            lift = sparse.hstack([self._lift, -sparse.identity(self._lift.shape[0])], format="csr")
            lift.resize(lift.shape[0], x.numel())  # the knot accelerations after z: no part in these rows
            g_kin = ca.vertcat(g_kin, ca.mtimes(dm(lift), x))
        g_kin = ca.vertcat(g_kin, self._on_spline_rows(X, x[x.numel() - slopes:], dt))  # after the lifting rows
        g = ca.vertcat(ca.vec(kern.pose.map(n)(X, pd, Rd)[:, self._pose_steps.tolist()]), g_kin)
        kept = [np.flatnonzero(f.keep.ravel()) for f in self.slots.frames] if self.slots else []
        self._clear_index = np.concatenate(kept) if kept else np.array([], int)
        clear_par = [par(ck.name, ck.size) for ck in self._clear]
        for ck, P_f, rows in zip(self._clear, clear_par, kept, strict=True):
            g = ca.vertcat(g, ca.vec(ck.rows.map(n)(Z, P_f))[rows.tolist()])
        lateral = lateral_rows(robot, X, 2 if self.rests_at_end else 0)  # differential drive: last rows
        self._lateral = lateral.numel()
        self._keep_steps = keep_steps(n, first, self._pose_steps, self.rests_at_end, self.goal) \
            if self.keep_level is not None else np.array([], int)
        level = keep_rows(robot, self.keep_level, X, self._keep_steps)  # keep_level: the very last rows
        g = ca.vertcat(g, lateral, level)
        scatter = dm(scatter_matrix(index.T.ravel(), x.numel()))
        # dense: IPOPT reads every entry (a structural zero would be read as garbage)
        grad = ca.densify(ca.mtimes(scatter, ca.vec(kern.grad.map(n)(*stage_args))) + Qx)
        jac = constraint_jacobian(self, x, X, pd, Rd, g_kin)
        for ck, P_f, rows in zip(self._clear, clear_par, kept, strict=True):
            jac = ca.vertcat(jac, clearance_jacobian(ck, Z, P_f, index, rows, x.numel()))
        if self._lateral:
            jac = ca.vertcat(jac, ca.jacobian(lateral, x))
        if level.numel():
            jac = ca.vertcat(jac, ca.jacobian(level, x))
        lam_f, lam_g = ca.MX.sym("lam_f"), ca.MX.sym("lam_g", g.numel())
        pattern = hessian_pattern(index, nq, n, Q)  # one pattern: the stage, pose and clearance blocks
        hess = lagrangian_hessian(self, pattern, X, pd, Rd, stage_args, lam_f, lam_g)
        offset = g.numel() - self._clear_index.size - self._lateral - level.numel()
        for ck, P_f, rows in zip(self._clear, clear_par, kept, strict=True):
            hess += clearance_hessian(ck, Z, P_f, lam_g[offset:offset + rows.size], rows, pattern, n)
            offset += rows.size
        if self._lateral:
            hess += lateral_hessian(lateral, lam_g[offset:offset + self._lateral], x, hess.sparsity())
        if level.numel():  # one waypoint per row: the diagonal stage blocks
            hess += lateral_hessian(level, lam_g[offset + self._lateral:], x, hess.sparsity())
        opts = ipopt_options(self)
        opts["grad_f"] = ca.Function("nlp_grad_f", [x, P], [cost, grad])
        opts["jac_g"] = ca.Function("nlp_jac_g", [x, P], [g, jac])
        opts["hess_lag"] = ca.Function("nlp_hess_l", [x, P, lam_f, lam_g], [hess])
        self._progress = None
        if progress.active() is not None:  # IPOPT's iterations on the progress line (off in the library)
            opts["iteration_callback"] = self._progress = IpoptProgress(x.numel(), g.numel(), P.numel())
        self._nlp = {"x": x, "p": P, "f": cost, "g": g}
        self._nlp_options = opts
        self.solver = self._nlpsol(opts)
        self._g = ca.Function("g", [x, P], [g])
        stage_values = ca.sum2(kern.terms.map(n)(*stage_args[:-1])) if self._stage else ca.MX(0, 1)
        quadratic = [0.5 * ca.dot(xq, ca.mtimes(dm(M), xq)) for M in self._quadratic_matrices()]
        self._terms = ca.Function("terms", [x, P], [ca.vertcat(stage_values, *quadratic)])

    def _knot_variables(self, Q: sparse.csr_matrix) -> tuple[sparse.csr_matrix, int]:
        """``Q`` over the variables with the spline's knot accelerations after ``z`` (outside every
        cost; :mod:`forte.planning.nlp.spline_rows`), and their count (0 unless ``on_spline``): of
        the arm's joints with a velocity or acceleration limit. Not the base's: its velocity rows
        cost 3 of 6 holonomic MotionBenchMaker goals (per-scenario 2) their NLP's convergence within
        the budget (441 IPOPT iterations in all without any velocity rows, 560 with the base's and
        the arm's, 484 with the arm's), and its velocity stays to the waypoint rows and the rounds."""
        none = np.full(self.robot.nq, np.inf)
        self._spline = SplineCoordinates.of(self._vel if self.on_spline else none, self._acc if self.on_spline
                                            else none, with_base=False)
        self._spline_rows = self._spline.coordinates
        count = len(self._spline_rows) * self.n
        if count:
            Q = sparse.block_diag([Q, sparse.csr_matrix((count, count))], format="csr")
        return Q, count

    def _on_spline_rows(self, X: ca.MX, slopes: ca.MX, dt: ca.MX) -> ca.MX:
        """The rows that make ``slopes`` the executed spline's knot accelerations, and its velocity
        rows (none unless ``on_spline``; :mod:`forte.planning.nlp.spline_rows`)."""
        if not self._spline_rows:
            return ca.MX(0, 1)
        M = ca.reshape(slopes, len(self._spline_rows), self.n)
        return self._spline.rows(X, M, dt[:, 1:])

    def _spline_start(self, start: StartMotion | None) -> FloatArray | None:
        """The spline's start slopes: the start's velocity of its joints (``None``: at rest)."""
        return None if start is None else np.asarray(start.velocity, dtype=float)[self._spline_rows]

    @property
    def rests_at_end(self) -> bool:
        """Whether the plan is constrained to end at rest (``q_N = q_{N-1} = q_{N-2}``)."""
        return self.limits.end_at_rest and self.fix_initial and self.n >= 3

    def _posed_waypoints(self, first: int) -> FloatArray:
        """Waypoints with a pose equality: from ``first``; with the end at rest, not N-1 and N-2,
        whose configurations equal the last one, so their poses are implied (the task holds its
        final pose over them, :func:`forte.planning.tasks.paths.ending_at_rest`)."""
        steps = np.arange(first, self.n)
        if self.goal is not None:  # a free path: the vias' poses and the goal's only
            return np.array([*self.via_steps, *([self.n - 1] if self.goal == "pose" else [])], dtype=int)
        if self.rests_at_end:
            steps = steps[(steps < self.n - 3) | (steps == self.n - 1)]
        return steps

    def _nlpsol(self, opts: dict[str, Any]) -> Any:
        try:
            return ca.nlpsol("forte", "ipopt", self._nlp, opts)
        except RuntimeError as exc:  # e.g. an option IPOPT rejects
            raise SolverError(f"IPOPT could not be set up: {str(exc).splitlines()[-1]}", status="setup") from exc

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

    def stagewise(self) -> Any:
        """The stage-structured solver of this problem when ``options.backend`` asks for it and
        it handles the problem (built once), else None (IPOPT solves)."""
        if self.options.backend != "stagewise":
            return None
        if not hasattr(self, "_stagewise"):
            from forte.planning.nlp.solvers.stagewise import StagewiseSolver

            nlp = self.stage_nlp()
            why = "goal tasks" if self.goal is not None else "keep_level rows" if self._keep_steps.size \
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
                        self._vel_rows, self._acc_rows, self._vel, self._acc, self.bounds, self.slots is not None,
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
