"""Whole-body trajectory optimization (paper, Section 4.3) with IPOPT through CasADi.

    min_Q  sum_i w_i J_i(Q)
    s.t.   x(q_k) = x_k          (end-effector position and orientation), k = 2..N
           q_a^min <= q_a,k <= q_a^max
           q_1 = q_init          (trajectory mode; free in single-point holding mode)

Design (measured choices, see ``shared/NOTES.md`` and ``benchmarks/``):

- every per-waypoint term is one small SX ``casadi.Function`` ``map``-ped over the horizon,
  so the expression graph and the exact Hessian stay linear in N;
- all task data (time steps, forces, radii, target poses, cone rays) are NLP *parameters*: a
  problem is built once per (robot, N, method, weights) and reused for every task of that size;
- optionally the NLP functions are generated as C, compiled once and cached on disk
  (``~/.cache/forte`` or ``$FORTE_CACHE``), which makes a cold run fast;
- the orientation constraint is ``vee(R_d^T R - R^T R_d) / 2 = 0`` (three equations; the
  initial guess from IK is feasible, far from the 180-degree ambiguity).
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import casadi as ca
import numpy as np
from scipy import sparse

from forte import __version__
from forte.capability.polytope import cone_directions
from forte.exceptions import InvalidInputError, SolverError
from forte.model.robot import N_BASE, MobileManipulator
from forte.model.twin import CasadiTwin
from forte.planning.costs import (
    N_CONE_RAYS,
    CostWeights,
    capability_stage,
    cone_stage,
    dct_penalty_matrix,
    inscribed_radius_stage,
    joint_limit_stage,
    manipulability_stage,
    smoothness_weights,
)
from forte.validation import FloatArray

#: Methods solved by this optimizer (the quintic and teaching baselines are not optimized).
OPTIMIZED_METHODS: tuple[str, ...] = ("forte", "manipulability", "rfp-radius", "rfp-cone")


@dataclass(frozen=True)
class SolverOptions:
    """IPOPT and build options.

    Attributes:
        max_iter: IPOPT iteration limit.
        tol: IPOPT convergence tolerance.
        constraint_tol: accepted constraint violation for a result to count as a success.
        codegen: generate, compile and cache C code for the NLP functions (needs a C compiler;
            falls back to the CasADi virtual machine when none is found).
        cache_dir: where compiled problems are kept; default ``$FORTE_CACHE`` or ``~/.cache/forte``.
        print_level: IPOPT verbosity (0 = silent).
    """

    max_iter: int = 500
    tol: float = 1e-6
    constraint_tol: float = 1e-6
    codegen: bool = True
    cache_dir: str | None = None
    print_level: int = 0
    extra: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not (isinstance(self.max_iter, int) and self.max_iter >= 1):
            raise InvalidInputError(f"max_iter: expected an integer >= 1, got {self.max_iter!r}")
        for name in ("tol", "constraint_tol"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise InvalidInputError(f"{name}: expected a finite number > 0, got {value!r}")
        if not (isinstance(self.print_level, int) and 0 <= self.print_level <= 12):
            raise InvalidInputError(f"print_level: expected an integer in 0..12, got {self.print_level!r}")


#: Franka Panda joint acceleration limits (rad/s^2, datasheet).
PANDA_ACCELERATION_LIMITS: tuple[float, ...] = (15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0)


@dataclass(frozen=True)
class KinematicLimits:
    """Joint velocity and acceleration limits of the planned motion.

    Not part of the paper's NLP, which only bounds joint positions: without them the optimizer
    may leave ``q_init`` for a better posture within one or two waypoints (3-4 rad/s, 20+ rad/s^2
    on the lift task), which no robot can execute. They are linear constraints on the same
    backward differences as the dynamics (the motion starts at rest, so the first steps ramp up).

    Attributes:
        enabled: ``False`` gives the paper's NLP exactly.
        arm_velocity: rad/s per arm joint; ``None``: the URDF's velocity limits.
        arm_acceleration: rad/s^2 per arm joint; ``None``: the Panda datasheet values for a Panda
            arm, no limit otherwise.
        base_velocity: (x, y, yaw) in m/s, m/s, rad/s.
        base_acceleration: (x, y, yaw) in m/s^2, m/s^2, rad/s^2.
    """

    enabled: bool = True
    arm_velocity: tuple[float, ...] | None = None
    arm_acceleration: tuple[float, ...] | None = None
    base_velocity: tuple[float, float, float] = (1.0, 1.0, 1.5)
    base_acceleration: tuple[float, float, float] = (1.0, 1.0, 2.0)

    def __post_init__(self) -> None:
        for name in ("arm_velocity", "arm_acceleration", "base_velocity", "base_acceleration"):
            values = getattr(self, name)
            if values is not None and not np.all(np.asarray(values, dtype=float) > 0):
                raise InvalidInputError(f"{name}: expected limits > 0 (use enabled: false for none), got {values}")

    def resolve(self, robot: MobileManipulator) -> tuple[FloatArray, FloatArray]:
        """Whole-body velocity and acceleration limits (inf where unlimited)."""
        n = robot.n_arm
        if self.arm_velocity is not None:
            vel = np.asarray(self.arm_velocity, dtype=float)
        else:  # URDFs use 0 for "no limit"
            urdf = np.asarray(robot.model.velocityLimit, dtype=float)
            vel = np.where(urdf > 0, urdf, np.inf)
        if self.arm_acceleration is not None:
            acc = np.asarray(self.arm_acceleration, dtype=float)
        elif n == 7 and all(j.startswith("panda_joint") for j in robot.arm_joints or ()):
            acc = np.asarray(PANDA_ACCELERATION_LIMITS)
        else:
            acc = np.full(n, np.inf)
        if vel.shape != (n,) or acc.shape != (n,):
            raise InvalidInputError(f"limits: expected {n} arm velocity and acceleration limits")
        return (np.concatenate([self.base_velocity, vel]), np.concatenate([self.base_acceleration, acc]))


@dataclass
class Solution:
    """Result of one optimization."""

    q: FloatArray
    success: bool
    status: str
    iterations: int
    objective: float
    constraint_violation: float
    build_time: float
    solve_time: float
    codegen: str  # "compiled", "cached", "virtual-machine"


def cache_root(options: SolverOptions) -> Path:
    root = options.cache_dir or os.environ.get("FORTE_CACHE") or Path.home() / ".cache" / "forte"
    return Path(root)


def rotation_error_expr(R: Any, R_d: Any) -> Any:
    """``vee(R_d^T R - R^T R_d) / 2`` (zero iff R = R_d near the solution)."""
    E = R_d.T @ R - R.T @ R_d
    return ca.vertcat(E[2, 1], E[0, 2], E[1, 0]) / 2


class TrajectoryOptimizer:
    """The FORTE NLP (or a baseline) for one robot, horizon ``n`` and method.

    Args:
        robot: The mobile manipulator.
        n: Number of waypoints (1 gives single-point holding).
        method: One of :data:`OPTIMIZED_METHODS`.
        weights: Cost weights and term parameters.
        fix_initial: Fix ``q_1 = q_init`` (trajectory mode). With ``False`` (holding), the
            first configuration is free and ``q_init`` only seeds the solver.
        options: Solver and build options.
    """

    def __init__(
        self, robot: MobileManipulator, n: int, method: str = "forte",
        weights: CostWeights = CostWeights(), fix_initial: bool = True,
        options: SolverOptions = SolverOptions(), limits: KinematicLimits = KinematicLimits(),
    ) -> None:
        if method not in OPTIMIZED_METHODS:
            raise InvalidInputError(f"method: expected one of {', '.join(OPTIMIZED_METHODS)}, got '{method}'")
        if n < 1:
            raise InvalidInputError(f"waypoints: expected at least 1, got {n}")
        self.robot, self.n, self.method = robot, n, method
        self.weights, self.fix_initial, self.options = weights, fix_initial, options
        self.limits = limits
        self._vel, self._acc = limits.resolve(robot)
        start = time.perf_counter()
        self.kernels = load_kernels(robot, method, weights, options)
        self._build()
        self.build_time = time.perf_counter() - start

    @property
    def codegen(self) -> str:
        return self.kernels.origin

    # -- construction -------------------------------------------------------------------
    def _parameter_layout(self) -> dict[str, tuple[int, int]]:
        n = self.n
        sizes = {"dt": n, "f": 3 * n, "r": n, "p_d": 3 * n, "R_d": 9 * n}
        if self.method == "rfp-cone":
            sizes["rays"] = 3 * N_CONE_RAYS * n
        layout, offset = {}, 0
        for name, size in sizes.items():
            layout[name] = (offset, size)
            offset += size
        return layout

    def _window_index(self) -> FloatArray:
        """Global variable index of each entry of the stage window ``[q_{k-2}; q_{k-1}; q_k]``."""
        nq, n = self.robot.nq, self.n
        steps = np.arange(n)
        blocks = np.stack([np.maximum(steps - 2, 0), np.maximum(steps - 1, 0), steps])  # 3 x n
        return (blocks[:, None, :] * nq + np.arange(nq)[None, :, None]).reshape(3 * nq, n)

    def _build(self) -> None:
        robot, n, w, kern = self.robot, self.n, self.weights, self.kernels
        nq = robot.nq
        self._layout = self._parameter_layout()
        P = ca.MX.sym("p", sum(size for _, size in self._layout.values()))

        def par(name: str, rows: int) -> ca.MX:
            off, size = self._layout[name]
            return ca.reshape(P[off:off + size], rows, size // rows)

        x = ca.MX.sym("x", nq * n)
        X = ca.reshape(x, nq, n)
        first = 1 if self.fix_initial else 0
        index = self._window_index()
        Z = ca.reshape(_gather(x, index.T.ravel()), 3 * nq, n)
        dt = par("dt", 1)
        dt_prev = ca.horzcat(ca.MX(1), dt[:, : n - 1])
        stage_args = [Z, dt_prev, dt, par("f", 3), par("r", 1)]
        if self.method == "rfp-cone":
            stage_args.append(par("rays", 3 * N_CONE_RAYS))
        wvec = ca.DM([w.capability, w.manipulability, w.joint_limits])
        stage_args.append(ca.repmat(wvec, 1, n))
        Q = _quadratic_matrix(robot.n_arm, n, w)
        Qx = ca.mtimes(ca.DM(Q), x)
        f_stage = ca.sum2(kern.cost.map(n)(*stage_args))
        cost = f_stage + 0.5 * ca.dot(x, Qx)
        pd, Rd = par("p_d", 3), par("R_d", 9)
        g_pose = ca.vec(kern.pose.map(n)(X, pd, Rd)[:, first:])
        g_kin = self._kinematic_rows(X, dt)
        g = ca.vertcat(g_pose, g_kin)

        # gradient: scatter-add the stage gradients into x
        grad_stage = kern.grad.map(n)(*stage_args)  # 3nq x n
        scatter = _scatter_matrix(index.T.ravel(), nq * n)
        grad = ca.mtimes(ca.DM(scatter), ca.vec(grad_stage)) + Qx

        # constraint Jacobian: 6 x nq blocks on the block diagonal (from waypoint `first`)
        jac_blocks = kern.pose_jac.map(n)(X, pd, Rd)[:, first * nq:]  # 6 x nq(n - first)
        jac_sp, jac_map = _block_diagonal_pattern(6, nq, n - first, col_offset=first * nq, ncol=nq * n)
        jac = ca.MX(jac_sp, ca.mtimes(ca.DM(jac_map), ca.vec(jac_blocks)))
        if g_kin.numel():
            jac = ca.vertcat(jac, ca.jacobian(g_kin, x))  # linear rows: no Hessian contribution

        # Hessian of the Lagrangian, upper triangle
        lam_f = ca.MX.sym("lam_f")
        lam_g = ca.MX.sym("lam_g", g.numel())
        lam = ca.horzcat(ca.DM.zeros(6, first), ca.reshape(lam_g[: 6 * (n - first)], 6, n - first))
        h_stage = kern.hess.map(n)(*stage_args)  # 3nq x 3nq n
        h_pose = kern.pose_hess.map(n)(X, pd, Rd, lam)  # nq x nq n
        hess_sp, maps = _hessian_pattern(index, nq, n, Q)
        h_nz = (lam_f * ca.mtimes(ca.DM(maps[0]), ca.vec(h_stage))
                + ca.mtimes(ca.DM(maps[1]), ca.vec(h_pose))
                + lam_f * ca.DM(maps[2]))
        hess = ca.MX(hess_sp, h_nz)

        opts = self._ipopt_options()
        opts["grad_f"] = ca.Function("nlp_grad_f", [x, P], [cost, grad])
        opts["jac_g"] = ca.Function("nlp_jac_g", [x, P], [g, jac])
        opts["hess_lag"] = ca.Function("nlp_hess_l", [x, P, lam_f, lam_g], [hess])
        try:
            self.solver = ca.nlpsol("forte", "ipopt", {"x": x, "p": P, "f": cost, "g": g}, opts)
        except RuntimeError as exc:  # e.g. an option IPOPT rejects
            raise SolverError(f"IPOPT could not be set up: {str(exc).splitlines()[-1]}", status="setup") from exc
        self._g = ca.Function("g", [x, P], [g])
        terms = kern.terms.map(n)(*stage_args[:-1])  # 3 x n: capability, manipulability, joint limits
        Qs, Qd = _quadratic_parts(robot.n_arm, n, w)
        self._term_names = ["capability", "manipulability", "joint_limits", "smoothness", "base_spectral"]
        self._terms = ca.Function("terms", [x, P], [ca.vertcat(
            ca.sum2(terms), 0.5 * ca.dot(x, ca.mtimes(ca.DM(Qs), x)), 0.5 * ca.dot(x, ca.mtimes(ca.DM(Qd), x)))])

    def _kinematic_rows(self, X: ca.MX, dt: ca.MX) -> ca.MX:
        """Velocity rows ``q_k - q_{k-1}`` and acceleration rows ``dq_k - dq_{k-1}`` (k >= 2), with
        ``dq_1 = 0``; :meth:`_kinematic_bounds` scales the limits by ``dt_k``."""
        self._vel_rows = np.flatnonzero(np.isfinite(self._vel)) if self.limits.enabled else np.array([], int)
        self._acc_rows = np.flatnonzero(np.isfinite(self._acc)) if self.limits.enabled else np.array([], int)
        if self.n < 2 or not self.fix_initial:
            self._vel_rows = self._acc_rows = np.array([], int)
            return ca.MX(0, 1)
        step = X[:, 1:] - X[:, :-1]
        dq = step / ca.repmat(dt[:, 1:], X.shape[0], 1)
        dq_prev = ca.horzcat(ca.MX.zeros(X.shape[0], 1), dq[:, :-1])
        rows = [ca.vec(step[self._vel_rows.tolist(), :]), ca.vec((dq - dq_prev)[self._acc_rows.tolist(), :])]
        return ca.vertcat(*rows)

    def _kinematic_bounds(self, t: FloatArray) -> tuple[FloatArray, FloatArray]:
        if self.n < 2 or not self.fix_initial:
            return np.zeros(0), np.zeros(0)
        dt = np.diff(t)
        vel = (self._vel[self._vel_rows][:, None] * dt[None, :]).ravel(order="F")
        acc = (self._acc[self._acc_rows][:, None] * dt[None, :]).ravel(order="F")
        ub = np.concatenate([vel, acc])
        return -ub, ub

    def _ipopt_options(self) -> dict[str, Any]:
        o = self.options
        opts = {
            "ipopt.max_iter": o.max_iter, "ipopt.tol": o.tol, "ipopt.print_level": o.print_level,
            "ipopt.sb": "yes", "print_time": False, "ipopt.constr_viol_tol": o.constraint_tol,
            "ipopt.mu_strategy": "adaptive", "calc_lam_p": False, "calc_lam_x": False,
            # QAMD ordering: ~25 % faster factorizations than MUMPS' default on this KKT (benchmarks/)
            "ipopt.mumps_pivot_order": 6,
        }
        opts.update({k if "." in k else f"ipopt.{k}": v for k, v in o.extra.items()})
        return opts

    # -- solving ------------------------------------------------------------------------
    def parameters(self, t: FloatArray, targets: FloatArray, f: FloatArray, r: FloatArray) -> FloatArray:
        """Pack the task data into the NLP parameter vector."""
        n = self.n
        t = np.asarray(t, dtype=float)
        dt = np.ones(n)
        dt[1:] = np.diff(t)
        values = {
            "dt": dt,
            "f": np.asarray(f, dtype=float).ravel(),
            "r": np.asarray(r, dtype=float),
            "p_d": targets[:, :3, 3].ravel(),
            "R_d": np.concatenate([T[:3, :3].ravel(order="F") for T in targets]),
        }
        if "rays" in self._layout:
            dirs = []
            for fk in np.asarray(f, dtype=float):
                u = fk if np.linalg.norm(fk) > 1e-9 else np.array([0.0, 0.0, 1.0])
                dirs.append(cone_directions(u).ravel(order="F"))  # column-major M x 3
            values["rays"] = np.concatenate(dirs)
        return np.concatenate([values[name] for name in self._layout])

    def solve(self, t: Any, targets: Any, f: Any, r: Any, q_init: FloatArray, q_guess: FloatArray) -> Solution:
        """Solve for the whole-body trajectory (N x nq) from the initial guess ``q_guess``."""
        n, nq = self.n, self.robot.nq
        targets = np.asarray(targets, dtype=float)
        p = self.parameters(t, targets, f, r)
        lbx = np.tile(np.r_[np.full(N_BASE, -np.inf), self.robot.lower], n)
        ubx = np.tile(np.r_[np.full(N_BASE, np.inf), self.robot.upper], n)
        if self.fix_initial:
            lbx[:nq] = ubx[:nq] = q_init
        x0 = np.clip(np.asarray(q_guess, dtype=float).ravel(), lbx, ubx)
        start = time.perf_counter()
        klb, kub = self._kinematic_bounds(np.asarray(t, dtype=float))
        n_pose = 6 * (n - (1 if self.fix_initial else 0))
        lbg = np.concatenate([np.zeros(n_pose), klb])
        ubg = np.concatenate([np.zeros(n_pose), kub])
        try:
            result = self.solver(x0=x0, p=p, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg)
        except RuntimeError as exc:  # IPOPT refused the problem (bad option values, inconsistent bounds)
            raise SolverError(f"IPOPT refused the problem: {str(exc).splitlines()[-1]}", status="error") from exc
        solve_time = time.perf_counter() - start
        stats = self.solver.stats()
        x = np.array(result["x"]).ravel()
        g = np.array(self._g(x, p)).ravel()
        bounds = np.maximum(np.maximum(lbx - x, x - ubx), 0)
        g_excess = np.maximum(np.maximum(lbg - g, g - ubg), 0)
        violation = float(max(g_excess.max(initial=0.0), bounds.max(initial=0.0)))
        status = str(stats.get("return_status", "unknown"))
        tol = max(1e-5, 10 * self.options.constraint_tol)
        success = bool(stats.get("success", False)) and violation <= tol
        return Solution(
            q=x.reshape(n, nq), success=success, status=status,
            iterations=int(stats.get("iter_count", -1)), objective=float(result["f"]),
            constraint_violation=violation, build_time=self.build_time, solve_time=solve_time,
            codegen=self.codegen,
        )

    def cost_terms(self, q: FloatArray, t: Any, targets: Any, f: Any, r: Any) -> dict[str, float]:
        """Unweighted values of each cost term (the capability term is the smooth surrogate)."""
        p = self.parameters(t, np.asarray(targets, dtype=float), f, r)
        values = np.array(self._terms(np.asarray(q, dtype=float).ravel(), p)).ravel()
        return dict(zip(self._term_names, map(float, values), strict=True))


# -- sparse assembly helpers --------------------------------------------------------------
def _gather(x: ca.MX, index: FloatArray) -> ca.MX:
    """``x[index]`` as a sparse selection product (one MX node)."""
    sel = sparse.csr_matrix((np.ones(len(index)), (np.arange(len(index)), index)), shape=(len(index), x.numel()))
    return ca.mtimes(_dm(sel), x)


def _dm(matrix: Any) -> ca.DM:
    """casadi DM from a scipy sparse matrix (keeps the sparsity)."""
    csc = sparse.csc_matrix(matrix)
    csc.sort_indices()
    sp = ca.Sparsity(csc.shape[0], csc.shape[1], csc.indptr.tolist(), csc.indices.tolist())
    return ca.DM(sp, csc.data)


def _scatter_matrix(index: FloatArray, size: int) -> sparse.csr_matrix:
    """``S`` with ``(S v)_i = sum of v_j over j with index[j] = i``."""
    return sparse.csr_matrix((np.ones(len(index)), (index, np.arange(len(index)))), shape=(size, len(index)))


def _nz_map(rows: FloatArray, cols: FloatArray, shape: tuple[int, int]) -> tuple[ca.Sparsity, FloatArray]:
    """Sparsity of the entries (rows, cols) and the position of each entry among its nonzeros."""
    keys = np.asarray(cols, dtype=np.int64) * shape[0] + np.asarray(rows, dtype=np.int64)
    unique, position = np.unique(keys, return_inverse=True)  # column-major order = CasADi's
    u_cols, u_rows = np.divmod(unique, shape[0])
    colind = np.searchsorted(u_cols, np.arange(shape[1] + 1))
    return ca.Sparsity(shape[0], shape[1], colind.tolist(), u_rows.tolist()), position


def _block_diagonal_pattern(rows: int, cols: int, count: int, col_offset: int, ncol: int) -> tuple[ca.Sparsity, Any]:
    """Pattern of ``count`` dense rows x cols blocks stacked diagonally, and the map from the
    column-major entries of ``horzcat(blocks)`` to its nonzeros."""
    k, c, r = np.meshgrid(np.arange(count), np.arange(cols), np.arange(rows), indexing="ij")
    src = (k * cols + c) * rows + r  # position in vec(horzcat(blocks))
    grow, gcol = (k * rows + r).ravel(), (col_offset + k * cols + c).ravel()
    sp, pos = _nz_map(grow, gcol, (rows * count, ncol))
    m = sparse.csr_matrix((np.ones(src.size), (pos, src.ravel())), shape=(sp.nnz(), rows * cols * count))
    return sp, _dm(m)


def _hessian_pattern(
    index: FloatArray, nq: int, n: int, Q: sparse.spmatrix
) -> tuple[ca.Sparsity, tuple[Any, Any, Any]]:
    """Upper-triangular pattern of the Lagrangian Hessian and the maps that fill it from the
    stage Hessians (3nq x 3nq per waypoint), the pose Hessians (nq x nq) and the constant ``Q``."""
    w = 3 * nq
    # stage blocks: entry (a, b) of waypoint k -> (index[a, k], index[b, k])
    a, b = np.meshgrid(np.arange(w), np.arange(w), indexing="ij")
    ks = np.arange(n)
    s_rows = index[a.ravel()[None, :], ks[:, None]]
    s_cols = index[b.ravel()[None, :], ks[:, None]]
    s_src = (ks[:, None] * w + b.ravel()[None, :]) * w + a.ravel()[None, :]
    # pose blocks: entry (a, b) of waypoint k -> (k nq + a, k nq + b)
    pa, pb = np.meshgrid(np.arange(nq), np.arange(nq), indexing="ij")
    p_rows = ks[:, None] * nq + pa.ravel()[None, :]
    p_cols = ks[:, None] * nq + pb.ravel()[None, :]
    p_src = (ks[:, None] * nq + pb.ravel()[None, :]) * nq + pa.ravel()[None, :]
    Qc = sparse.coo_matrix(Q)
    rows = np.concatenate([s_rows.ravel(), p_rows.ravel(), Qc.row])
    cols = np.concatenate([s_cols.ravel(), p_cols.ravel(), Qc.col])
    keep = rows <= cols
    size = nq * n
    sp, pos = _nz_map(rows[keep], cols[keep], (size, size))
    pos_full = np.full(rows.size, -1)
    pos_full[keep] = pos
    ns, npose = s_rows.size, p_rows.size
    def build(sel: slice, src: FloatArray, length: int) -> Any:
        p_ = pos_full[sel]
        ok = p_ >= 0
        return _dm(sparse.csr_matrix((np.ones(ok.sum()), (p_[ok], src.ravel()[ok])), shape=(sp.nnz(), length)))
    m_stage = build(slice(0, ns), s_src, w * w * n)
    m_pose = build(slice(ns, ns + npose), p_src, nq * nq * n)
    q_vals = np.zeros(sp.nnz())
    qpos = pos_full[ns + npose:]
    ok = qpos >= 0
    np.add.at(q_vals, qpos[ok], Qc.data[ok])
    return sp, (m_stage, m_pose, q_vals)


def _quadratic_parts(n_arm: int, n: int, w: CostWeights) -> tuple[sparse.csr_matrix, sparse.csr_matrix]:
    """Matrices of J4 = x^T Qs x / 2 and J5 = x^T Qd x / 2 (unweighted), x = vec of q_k's."""
    nq = n_arm + N_BASE
    size = nq * n
    if n == 1:
        zero = sparse.csr_matrix((size, size))
        return zero, zero
    D = sparse.diags([-np.ones(n - 1), np.ones(n - 1)], [0, 1], shape=(n - 1, n))  # q_{k+1} - q_k
    Ws = sparse.diags(smoothness_weights(n_arm, w) ** 2)
    Qs = sparse.kron(D.T @ D, Ws).tocsr()
    Pm = dct_penalty_matrix(n, w)
    E = np.zeros((nq, nq))
    for i, eta in enumerate(w.dct_axis):
        E[i, i] = eta
    Qd = sparse.kron(sparse.csr_matrix(Pm), sparse.csr_matrix(E)).tocsr()
    return Qs, Qd


def _quadratic_matrix(n_arm: int, n: int, w: CostWeights) -> sparse.csr_matrix:
    """Weighted ``Q = w4 Qs + w5 Qd``."""
    Qs, Qd = _quadratic_parts(n_arm, n, w)
    return (w.smoothness * Qs + w.base_spectral * Qd).tocsr()


# -- per-stage kernels ---------------------------------------------------------------------
@dataclass
class Kernels:
    """Per-waypoint functions the NLP is assembled from (SX, or compiled C loaded back)."""

    cost: ca.Function  # (z, dt_prev, dt, f, r, [rays], w3) -> weighted stage cost
    grad: ca.Function  # same inputs -> gradient w.r.t. z (3nq)
    hess: ca.Function  # same inputs -> Hessian w.r.t. z (3nq x 3nq, dense)
    terms: ca.Function  # same inputs without w3 -> (capability, manipulability, joint limits)
    pose: ca.Function  # (q, p_d, R_d) -> 6 pose residuals
    pose_jac: ca.Function  # -> 6 x nq
    pose_hess: ca.Function  # (q, p_d, R_d, lambda) -> nq x nq
    origin: str  # "compiled", "cached" or "virtual-machine"


def build_kernels(robot: MobileManipulator, method: str, w: CostWeights) -> dict[str, ca.Function]:
    """SX kernels of one method."""
    twin = CasadiTwin(robot)
    nq = robot.nq
    z = ca.SX.sym("z", 3 * nq)
    q2, q1, q0 = z[:nq], z[nq:2 * nq], z[2 * nq:]
    dt1, dt0, f, r = ca.SX.sym("dt_prev"), ca.SX.sym("dt"), ca.SX.sym("f", 3), ca.SX.sym("r")
    w3 = ca.SX.sym("w", 3)
    inputs = [z, dt1, dt0, f, r]
    tau_max, params = robot.torque_limits, w.capability_params
    if method == "forte":
        cap = capability_stage(twin, tau_max, params)(q2, q1, q0, dt1, dt0, f, r)
    elif method == "rfp-radius":
        cap = inscribed_radius_stage(twin, tau_max, params)(q2, q1, q0, dt1, dt0, f, r)
    elif method == "rfp-cone":
        rays = ca.SX.sym("rays", 3 * N_CONE_RAYS)
        inputs.append(rays)
        cap = cone_stage(twin, tau_max, params)(q2, q1, q0, dt1, dt0, f, r, ca.reshape(rays, N_CONE_RAYS, 3))
    else:
        cap = ca.SX(0)
    manip = manipulability_stage(twin, w)(q0)
    limits = joint_limit_stage(robot.lower, robot.upper, w)(q0)
    cost = w3[0] * cap + w3[1] * manip + w3[2] * limits
    H, grad = ca.hessian(cost, z)
    q, pd, Rd, lam = ca.SX.sym("q", nq), ca.SX.sym("p_d", 3), ca.SX.sym("R_d", 9), ca.SX.sym("lam", 6)
    R, p = twin.ee_pose(q)
    res = ca.vertcat(p - pd, rotation_error_expr(R, ca.reshape(Rd, 3, 3)))
    Hp, _ = ca.hessian(ca.dot(lam, res), q)
    return {
        "stage_cost": ca.Function("stage_cost", [*inputs, w3], [cost]),
        "stage_grad": ca.Function("stage_grad", [*inputs, w3], [grad]),
        "stage_hess": ca.Function("stage_hess", [*inputs, w3], [ca.densify(H)]),
        "stage_terms": ca.Function("stage_terms", inputs, [ca.vertcat(cap, manip, limits)]),
        "pose": ca.Function("pose", [q, pd, Rd], [res]),
        "pose_jac": ca.Function("pose_jac", [q, pd, Rd], [ca.densify(ca.jacobian(res, q))]),
        "pose_hess": ca.Function("pose_hess", [q, pd, Rd, lam], [ca.densify(Hp)]),
    }


def _kernel_key(robot: MobileManipulator, method: str, w: CostWeights) -> str:
    baked = (w.capability_params, w.manipulability_lambda, w.manipulability_eps, w.joint_margin, w.joint_eps)
    text = repr((__version__, robot.fingerprint, method, baked, ca.__version__, _source_digest()))
    return hashlib.sha256(text.encode()).hexdigest()[:20]


def load_kernels(robot: MobileManipulator, method: str, w: CostWeights, options: SolverOptions) -> Kernels:
    """Kernels from the on-disk cache, compiling them first when needed (and possible)."""
    names = ("stage_cost", "stage_grad", "stage_hess", "stage_terms", "pose", "pose_jac", "pose_hess")
    compiler = shutil.which("gcc") or shutil.which("cc")
    if options.codegen and compiler:
        lib = cache_root(options) / f"kernels_{method}_{_kernel_key(robot, method, w)}.so"
        origin = "cached"
        if not lib.exists():
            _compile(build_kernels(robot, method, w), lib, compiler)
            origin = "compiled"
        fns = {name: ca.external(name, str(lib)) for name in names}
    else:
        fns, origin = build_kernels(robot, method, w), "virtual-machine"
    return Kernels(fns["stage_cost"], fns["stage_grad"], fns["stage_hess"], fns["stage_terms"],
                   fns["pose"], fns["pose_jac"], fns["pose_hess"], origin)


def _compile(functions: dict[str, ca.Function], lib: Path, compiler: str) -> None:
    lib.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=lib.parent) as tmp:
        gen = ca.CodeGenerator("kernels.c", {"with_header": False})
        for fn in functions.values():
            gen.add(fn)
        for name in ("stage_cost", "pose"):  # reverse mode, found by name by casadi.external
            gen.add(functions[name].reverse(1))
        cwd = os.getcwd()
        try:
            os.chdir(tmp)
            gen.generate()
        finally:
            os.chdir(cwd)
        src, out = Path(tmp) / "kernels.c", Path(tmp) / "kernels.so"
        cmd = [compiler, "-O1", "-fPIC", "-shared", str(src), "-o", str(out), "-lm"]
        proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
        if proc.returncode != 0:
            raise SolverError(f"compiling the NLP kernels failed: {proc.stderr[-2000:]}", status="codegen")
        os.replace(out, lib)  # atomic: a concurrent run never loads a half-written library


def _source_digest() -> str:
    """Hash of the modules that define the NLP, so editing them invalidates the cache."""
    from forte.capability import metrics
    from forte.model import twin
    from forte.planning import costs

    digest = hashlib.sha256()
    for path in (__file__, costs.__file__, metrics.__file__, twin.__file__):
        digest.update(Path(path).read_bytes())
    return digest.hexdigest()[:12]
