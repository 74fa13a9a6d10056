"""The trajectory NLP's structure, built once per problem: its variables, rows, parameters,
bounds and IPOPT's functions (:class:`NlpStructure`, the construction half of
:class:`~forte.planning.nlp.optimizer.TrajectoryOptimizer`; the solving half is there).

Variables ``x = [vec(q_1..q_N); z; a]`` and rows ``g = [pose; kinematic; lifting; spline;
clearance; lateral; keep_level]`` (:class:`Spans` says where each block lies): the lifted
variables ``z`` and their rows of the quadratic terms solved in lifted form
(:mod:`forte.planning.nlp.layout`), the executed spline's knot accelerations ``a`` and its
continuity and velocity rows when ``on_spline`` (:mod:`forte.planning.nlp.spline_rows`), the
clearance rows of a scene (:mod:`forte.planning.nlp.clearance_rows`), the differential-drive base's
lateral rows (:mod:`forte.planning.nlp.base_rows`) and the ``keep_level`` rows
(:mod:`forte.planning.nlp.keep_level_rows`).
"""

from __future__ import annotations

from typing import Any, NamedTuple

import casadi as ca
import numpy as np
from scipy import sparse

from forte import progress
from forte.exceptions import SolverError
from forte.model.robot import MobileManipulator
from forte.model.trajectory import StartMotion
from forte.planning.methods.catalog import Method
from forte.planning.nlp import layout
from forte.planning.nlp.assembly import dm, gather, hessian_pattern, scatter_matrix
from forte.planning.nlp.base_rows import lateral_hessian, lateral_rows, pin_base
from forte.planning.nlp.clearance_rows import clearance_hessian, clearance_jacobian
from forte.planning.nlp.collision_slots import Slots
from forte.planning.nlp.history import history_windows, shifted_acceleration_bounds
from forte.planning.nlp.ipopt_nlp import constraint_jacobian, ipopt_options, kinematic_rows, lagrangian_hessian
from forte.planning.nlp.ipopt_progress import IpoptProgress
from forte.planning.nlp.keep_level_rows import keep_bounds, keep_rows, keep_steps
from forte.planning.nlp.kernels import Kernels
from forte.planning.nlp.spline_rows import SplineCoordinates, knot_accelerations, knot_bounds
from forte.planning.tasks.keep_level import KeepLevel
from forte.settings import CostWeights, KinematicLimits, SolverOptions
from forte.validation import FloatArray


class Spans(NamedTuple):
    """Where each block of the NLP's variables (``q``, ``lifted``, ``knots``) and rows (the rest)
    lies: ``slice``s of ``x`` and of ``g``, in the order of the module docstring."""

    q: slice
    lifted: slice
    knots: slice
    pose: slice
    kinematic: slice
    lifting: slice
    spline: slice
    clearance: slice
    lateral: slice
    keep_level: slice

    @classmethod
    def of(cls, variables: tuple[int, ...], rows: tuple[int, ...]) -> Spans:
        """From the blocks' sizes, in order (variables, then rows)."""
        def consecutive(sizes: tuple[int, ...]) -> list[slice]:
            stops = np.cumsum(sizes).tolist()
            return [slice(stop - size, stop) for size, stop in zip(sizes, stops, strict=True)]
        return cls(*consecutive(variables), *consecutive(rows))


class NlpStructure:
    """The construction half of :class:`~forte.planning.nlp.optimizer.TrajectoryOptimizer`: it
    reads the attributes the optimizer's ``__init__`` sets (annotated below) and builds the
    problem in :meth:`_build`."""

    robot: MobileManipulator
    n: int
    method_spec: Method
    weights: CostWeights
    options: SolverOptions
    limits: KinematicLimits
    fix_initial: bool
    goal: str | None
    keep_level: KeepLevel | None
    via_steps: tuple[int, ...]
    on_spline: bool
    slots: Slots | None
    kernels: Kernels
    _stage: tuple[Any, ...]
    _quadratic: tuple[Any, ...]
    _clear: list[Any]
    _vel: FloatArray
    _acc: FloatArray
    _spline_times: tuple[FloatArray, FloatArray | None] | None
    #: where each block of variables and rows lies (set by _build)
    spans: Spans

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
        pd, Rd = par("p_d", 3), par("R_d", 9)
        clear_par = [par(ck.name, ck.size) for ck in self._clear]
        g, g_kin, kept, lateral, level = self._rows(x, X, Z, dt, pd, Rd, clear_par, slopes)
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

    def _rows(self, x: ca.MX, X: ca.MX, Z: ca.MX, dt: ca.MX, pd: ca.MX, Rd: ca.MX, clear_par: list[ca.MX],
              slopes: int) -> tuple[ca.MX, ca.MX, list[FloatArray], ca.MX, ca.MX]:
        """``g`` in the order of the module docstring, with its linear rows (kinematic, lifting,
        spline: ``g_kin``), each clearance frame's kept rows, the lateral and the keep_level rows;
        sets :attr:`spans`."""
        robot, n, kern = self.robot, self.n, self.kernels
        first = 1 if self.fix_initial else 0
        self._pose_steps = self._posed_waypoints(first)
        g_kin = kinematic_rows(self, X, dt)
        sizes = [g_kin.numel()]
        if self._lift.shape[0]:  # z = A x
            lift = sparse.hstack([self._lift, -sparse.identity(self._lift.shape[0])], format="csr")
            lift.resize(lift.shape[0], x.numel())  # the knot accelerations after z: no part in these rows
            g_kin = ca.vertcat(g_kin, ca.mtimes(dm(lift), x))
        g_kin = ca.vertcat(g_kin, self._on_spline_rows(X, x[x.numel() - slopes:], dt))  # after the lifting rows
        g = ca.vertcat(ca.vec(kern.pose.map(n)(X, pd, Rd)[:, self._pose_steps.tolist()]), g_kin)
        kept = [np.flatnonzero(f.keep.ravel()) for f in self.slots.frames] if self.slots else []
        self._clear_index = np.concatenate(kept) if kept else np.array([], int)
        for ck, P_f, rows in zip(self._clear, clear_par, kept, strict=True):
            g = ca.vertcat(g, ca.vec(ck.rows.map(n)(Z, P_f))[rows.tolist()])
        lateral = lateral_rows(robot, X, 2 if self.rests_at_end else 0)  # differential drive: last rows
        self._lateral = lateral.numel()
        self._keep_steps = keep_steps(n, first, self._pose_steps, self.rests_at_end, self.goal) \
            if self.keep_level is not None else np.array([], int)
        level = keep_rows(robot, self.keep_level, X, self._keep_steps)  # keep_level: the very last rows
        lifted = self._lift.shape[0]
        spline = g_kin.numel() - sizes[0] - lifted
        self.spans = Spans.of((robot.nq * n, lifted, slopes), (6 * self._pose_steps.size, sizes[0], lifted, spline,
                                                               self._clear_index.size, self._lateral, level.numel()))
        return ca.vertcat(g, lateral, level), g_kin, kept, lateral, level

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

