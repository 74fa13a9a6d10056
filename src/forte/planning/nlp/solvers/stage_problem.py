"""The trajectory NLP of a :class:`~forte.planning.nlp.optimizer.TrajectoryOptimizer` in the form the
structure-exploiting solver works on.

Variables. The optimizer's ``x = vec(q_1..q_N)`` holds configurations that are not free: ``q_1``
is fixed in trajectory mode, and a plan that ends at rest has ``q_{N-2} = q_{N-1} = q_N`` (its
end-at-rest rows). Here they are eliminated: ``x = T y + x_fix`` with ``y`` the free waypoints'
configurations, stacked waypoint by waypoint (``T`` a 0/1 selection; the tied waypoints copy the
last one). The problem is then

    min_y   f(y) = sum_k c_k(q_{k-2}, q_{k-1}, q_k) + 1/2 x^T Q x
    s.t.    pose_k(q_k) = 0            (6 rows per posed waypoint, each on one block of y)
            l <= A y + b <= u          (joint bounds, velocity and acceleration rows; linear)

with the same stage kernels (:mod:`forte.planning.nlp.kernels`), the same ``Q`` (the quadratic terms
in the form IPOPT solves them: the lifted rows folded back, ``Q = D + R^T diag(g) R``), the same
bounds. Its Lagrangian Hessian has one fixed sparsity pattern (stage windows, pose blocks,
``Q``, and ``A^T Sigma A`` of the barrier), filled by constant scatter matrices.

Supported: every optimized method without a scene and with a holonomic or fixed base (the
differential base's lateral rows and a scene's clearance rows stay with IPOPT).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np
from scipy import sparse

from forte.exceptions import InvalidInputError
from forte.model.trajectory import StartMotion
from forte.planning.nlp import layout
from forte.planning.nlp.history import acceleration_shift, add_history, history_parameters
from forte.planning.nlp.solvers.native import StageKernels
from forte.validation import FloatArray


class StageNLP(NamedTuple):
    """The trajectory NLP as this solver receives it: what the optimizer built
    (:meth:`~forte.planning.nlp.optimizer.TrajectoryOptimizer.stage_nlp`), not the optimizer."""

    n: int  # waypoints
    nq: int
    n_arm: int
    kernels: Any  # the compiled stage kernels (forte.planning.nlp.kernels)
    window_index: FloatArray  # x index of each window entry, 3nq x n
    pose_steps: FloatArray  # waypoints with pose rows
    stage_terms: tuple[Any, ...]
    stage_weights: FloatArray
    quadratic_terms: tuple[Any, ...]
    quadratic_weights: list[float]
    rests_at_end: bool
    fix_initial: bool
    vel_rows: FloatArray  # the dofs with velocity rows
    acc_rows: FloatArray
    vel: FloatArray  # velocity limits, nq
    acc: FloatArray
    bounds: Callable[[FloatArray, FloatArray], tuple[FloatArray, FloatArray, FloatArray, FloatArray]]
    clearance_rows: bool  # the NLP has a scene's clearance rows
    lateral_rows: bool  # ... a differential base's lateral rows
    tol: float
    constraint_tol: float
    max_iter: int
    build_time: float
    codegen: str


class TaskData(NamedTuple):
    """Per-solve data: kernel inputs, the fixed part of ``x`` and the rows' offsets and bounds."""

    stage_args: list[FloatArray]  # dt_prev, dt, f, r, q_nom, the terms' parameters, weights (after the window)
    p_d: FloatArray  # n x 3
    R_d: FloatArray  # n x 9 (column-major rotations)
    x_fix: FloatArray
    b: FloatArray  # A y + b: the rows' values
    lower: FloatArray
    upper: FloatArray
    lo: FloatArray  # which lower bounds are finite
    up: FloatArray  # which upper bounds are finite
    offsets: FloatArray | None = None  # the windows' history offsets (2 x nq, forte.planning.nlp.history); None at rest


def supported(nlp: StageNLP) -> str | None:
    """None when the solver handles ``nlp``, else why not."""
    if nlp.clearance_rows:
        return "a scene's clearance rows"
    if nlp.lateral_rows:
        return "a differential base's lateral rows"
    return None


class StageProblem:
    """``nlp`` over the free configurations (see the module docstring)."""

    def __init__(self, nlp: StageNLP) -> None:
        why = supported(nlp)
        if why is not None:
            raise InvalidInputError(f"solver: the interior-point solver does not handle {why}; use ipopt")
        self.nlp, self.n, self.nq = nlp, nlp.n, nlp.nq
        self.kernels = StageKernels(nlp.kernels)
        self._free_stages()
        self._widx = nlp.window_index.T.copy()  # x index of each window entry [q_{k-2}; q_{k-1}; q_k]
        self.posed = nlp.pose_steps  # x waypoints with pose rows
        self.posed_block = self.block_of[self.posed]
        if np.unique(self.posed_block).size != self.posed_block.size or (self.posed_block < 0).any():
            raise InvalidInputError("solver: two posed waypoints share a free block")
        self.weights = np.asarray(nlp.stage_weights, dtype=float)
        D, R = layout.lifted_quadratic(nlp.quadratic_terms, nlp.quadratic_weights, nlp.n_arm, self.n,
                                       self.n * self.nq)
        nx = self.n * self.nq
        # Q = D + R^T diag(g) R, as IPOPT solves the quadratic terms (R: the lifted rows, dense)
        self.D, self.R, self.g = sparse.csr_matrix(D[:nx, :nx]), sparse.csr_matrix(R), D.diagonal()[nx:]
        self.Dy = sparse.csr_matrix(self.T.T @ self.D @ self.T)
        self.Ry = sparse.csr_matrix(self.R @ self.T)
        self.Qy = self.Dy + (self.Ry.T @ sparse.diags(self.g) @ self.Ry if self.g.size else 0)
        self._kinematic_matrix()
        self.window_block = self.block_of[self._widx[:, :: self.nq] // self.nq]  # n x 3, -1: fixed
        self.Dw, self.Wy = self._windowed(self.D)
        wc = self.Wy.tocoo()
        self.wide_dofs = np.unique(np.concatenate([wc.row, wc.col]) % self.nq)  # the dofs W couples (J5's)
        sel = (np.arange(self.blocks)[:, None] * self.nq + self.wide_dofs[None, :]).ravel()
        self.W_dofs = self.Wy[sel][:, sel].toarray()  # W on those dofs of every block (blocks d x blocks d)
        Q = self.D + (self.R.T @ sparse.diags(self.g) @ self.R if self.g.size else 0)
        self.Ty_Q = sparse.csr_matrix(self.T.T @ Q)  # T^T Q: the quadratic terms' gradient in y
        w = self._widx.size  # window entry -> its y variable (fixed ones dropped)
        target = self.ymap[self._widx.ravel()]
        keep = np.flatnonzero(target >= 0)
        to_y = sparse.csr_matrix((np.ones(keep.size), (target[keep], keep)), shape=(self.ny, w))
        self._gradient_map = sparse.hstack([to_y, self.Ty_Q], format="csr")  # [window gradients; x] -> y
        self._last_x: tuple | None = None

    def _windowed(self, D: sparse.csr_matrix) -> tuple[FloatArray, sparse.csr_matrix]:
        """``D`` split into what couples waypoints at most two apart (the smoothness and velocity
        terms, the near-diagonal part of J5) and the rest. The first goes into the stage windows
        (n x 3nq x 3nq: entry ``(a, b)`` of waypoints ``i, j`` to the window of ``k = max(i, j)``,
        slots ``i - k + 2`` and ``j - k + 2``, so that the windows' scatter, as the stage Hessians',
        is that part of ``D``); the rest (J5's dense blocks on the base's dofs) is returned in the
        free variables, ``T^T D_wide T``."""
        nq, w = self.nq, 3 * self.nq
        dc = sparse.coo_matrix(D)
        i, j = dc.row // nq, dc.col // nq
        near = np.abs(i - j) <= 2
        k = np.maximum(i, j)[near]
        out = np.zeros((self.n, w, w))
        np.add.at(out, (k, (i[near] - k + 2) * nq + dc.row[near] % nq, (j[near] - k + 2) * nq + dc.col[near] % nq),
                  dc.data[near])
        wide = sparse.csr_matrix((dc.data[~near], (dc.row[~near], dc.col[~near])), shape=D.shape)
        return out, sparse.csr_matrix(self.T.T @ wide @ self.T)

    # -- structure ------------------------------------------------------------------------
    def _free_stages(self) -> None:
        """``T``, ``ymap`` (x index -> y index or -1) and the free blocks."""
        n, nq, opt = self.n, self.nq, self.nlp
        owner = np.arange(n)  # the x waypoint whose configuration each waypoint copies
        if opt.rests_at_end:
            owner[n - 3:] = n - 1
        free = [k for k in range(n) if owner[k] == k and not (k == 0 and opt.fix_initial)]
        self.block_of = np.full(n, -1)
        self.block_of[free] = np.arange(len(free))
        self.block_of = self.block_of[owner]  # tied waypoints share their owner's block
        self.blocks = len(free)
        self.ny = self.blocks * nq
        self.ymap = np.full(n * nq, -1)
        for k in range(n):
            if self.block_of[k] >= 0:
                self.ymap[k * nq:(k + 1) * nq] = self.block_of[k] * nq + np.arange(nq)
        self.owner = np.asarray(free, dtype=int)  # the waypoint each block is (tied ones copy it)
        self.owner_x = np.concatenate([k * nq + np.arange(nq) for k in free]).astype(int)  # x index of each y
        rows = np.flatnonzero(self.ymap >= 0)
        self._gather = np.where(self.ymap >= 0, self.ymap, self.ny)  # x_of: y extended by a 0
        self._free_x_idx = rows
        self.T = sparse.csr_matrix((np.ones(rows.size), (rows, self.ymap[rows])), shape=(n * nq, self.ny))

    def _kinematic_matrix(self) -> None:
        """Velocity rows ``q_k - q_{k-1}`` and acceleration rows ``dq_k - dq_{k-1}`` in x (the
        optimizer's, :func:`forte.planning.nlp.ipopt_nlp.kinematic_rows`) as
        constant difference matrices; the time steps scale them per solve."""
        opt, n, nq = self.nlp, self.n, self.nq
        self.vel_rows, self.acc_rows = opt.vel_rows, opt.acc_rows
        steps = n - 1 if n >= 2 else 0
        E = sparse.eye(n * nq, format="csr")
        self._step = [E[(k + 1) * nq:(k + 2) * nq] - E[k * nq:(k + 1) * nq] for k in range(steps)]

    # -- one solve's data -----------------------------------------------------------------
    def task_data(self, t: FloatArray, targets: FloatArray, f: FloatArray, r: FloatArray, q_init: FloatArray,
                  nominal: FloatArray, term_values: dict[str, FloatArray] | None = None,
                  start: StartMotion | None = None) -> TaskData:
        """Kernel inputs and the rows of a solve (as :meth:`TrajectoryOptimizer.parameters` and
        :meth:`~TrajectoryOptimizer.bounds` pack them for IPOPT; ``start``: the first waypoint's
        motion, :mod:`forte.planning.nlp.history`)."""
        opt, n, nq = self.nlp, self.n, self.nq
        t = np.asarray(t, dtype=float)
        dt, offsets = history_parameters(opt.fix_initial, n, nq, t, start)
        dt_prev = np.concatenate([dt[:1], dt[:-1]])
        f, r = np.asarray(f, float).reshape(n, 3), np.asarray(r, float).reshape(n)
        given = term_values or {}  # e.g. the task's moment for wrench_capability
        terms = [np.asarray(given[name] if name in given else t.parameter_values(name, f, r), float).reshape(n, size)
                 for t in opt.stage_terms for name, size in t.parameters]  # e.g. rfp-cone's rays
        args = [dt_prev[:, None], dt[:, None], f, r[:, None], np.asarray(nominal, float).reshape(n, nq), *terms,
                self.weights]
        targets = np.asarray(targets, dtype=float)
        R_d = targets[:, :3, :3].transpose(0, 2, 1).reshape(n, 9)  # column-major per waypoint
        lbx, ubx, lbg, ubg = opt.bounds(t, q_init)
        x_fix = np.where(self.ymap < 0, np.clip(np.zeros(n * nq), lbx[:n * nq], ubx[:n * nq]), 0.0)
        if opt.fix_initial:
            x_fix[:nq] = q_init
            owner_fixed = self.block_of < 0
            for k in np.flatnonzero(owner_fixed):
                x_fix[k * nq:(k + 1) * nq] = q_init
        key = dt[1:].tobytes() + lbx[self.owner_x].tobytes() + ubx[self.owner_x].tobytes()  # not q_init's, dt_1
        if key != getattr(self, "_rows_key", None):  # the rows change with the time grid only
            self.A, self._G, self._bounds = self._rows(dt, lbx[:n * nq], ubx[:n * nq])
            self.At = sparse.csr_matrix(self.A.T)
            self._finite = (np.isfinite(self._bounds[0]), np.isfinite(self._bounds[1]))
            self._rows_key = key
        lower, upper = self._bounds
        b = np.concatenate([np.zeros(self.bound_vars.size), self._G @ x_fix])
        shift = acceleration_shift(start, self.acc_rows)
        if shift is not None and shift.size:  # the first acceleration rows: dq_2 - v_1
            rows, dofs = self._first_acceleration
            b[rows] -= shift[dofs]
        return TaskData(args, targets[:, :3, 3].copy(), R_d, x_fix, b, lower, upper, *self._finite,
                        None if start is None else offsets)

    def _rows(self, dt: FloatArray, lbx: FloatArray, ubx: FloatArray
              ) -> tuple[sparse.csr_matrix, sparse.csr_matrix, tuple[FloatArray, FloatArray]]:
        """``l <= A y + b <= u``: bounds of the free variables, then the kinematic rows (``A``, the
        kinematic rows in x, whose product with ``x_fix`` is their part of ``b``, and ``(l, u)``)."""
        opt, nq = self.nlp, self.nq
        vel, acc = opt.vel, opt.acc
        lo, hi = lbx[self.owner_x], ubx[self.owner_x]
        bounded = np.flatnonzero(np.isfinite(lo) | np.isfinite(hi))
        parts = [sparse.csr_matrix((np.ones(bounded.size), (np.arange(bounded.size), bounded)),
                                   shape=(bounded.size, self.ny))]
        lows, ups = [lo[bounded]], [hi[bounded]]
        dq_prev = None
        ident = []  # (x waypoint, kind 0 velocity / 1 acceleration, dof) of each kinematic row
        for k, step in enumerate(self._step):
            h = dt[k + 1]
            dq = step / h
            if self.vel_rows.size:
                parts.append(step[self.vel_rows])
                ident += [(k + 1, 0, d) for d in self.vel_rows]
                lim = vel[self.vel_rows] * h
                lows.append(-lim)
                ups.append(lim)
            if self.acc_rows.size:
                rows = dq if dq_prev is None else dq - dq_prev
                parts.append(rows[self.acc_rows])
                ident += [(k + 1, 1, d) for d in self.acc_rows]
                lim = acc[self.acc_rows] * h
                lows.append(-lim)
                ups.append(lim)
            dq_prev = dq
        G = sparse.vstack(parts[1:], format="csr") if len(parts) > 1 else sparse.csr_matrix((0, self.n * nq))
        Gy = sparse.csr_matrix(G @ self.T)
        Gy.eliminate_zeros()
        keep = np.flatnonzero(np.diff(Gy.indptr) > 0)  # rows the elimination made constant hold anyway
        low = np.concatenate(lows[1:]) if len(lows) > 1 else np.zeros(0)
        up = np.concatenate(ups[1:]) if len(ups) > 1 else np.zeros(0)
        A = sparse.vstack([parts[0], Gy[keep]], format="csr")
        self.bound_vars = bounded
        self.kin_rows = np.asarray(ident, dtype=int).reshape(-1, 3)[keep]
        first = np.flatnonzero((self.kin_rows[:, 0] == 1) & (self.kin_rows[:, 1] == 1))
        # the first step's acceleration rows (in b) and their dofs' places in acc_rows
        self._first_acceleration = (bounded.size + first, np.searchsorted(self.acc_rows, self.kin_rows[first, 2]))
        self._window_rows(dt)
        return A, sparse.csr_matrix(G[keep]), (np.concatenate([lows[0], low[keep]]),
                                                np.concatenate([ups[0], up[keep]]))

    def _window_rows(self, dt: FloatArray) -> None:
        """The kinematic rows in window form: coefficients on slots 0, 1, 2 of their waypoint's
        window (same dof), and the flat indices of ``c c^T`` in the n x 3nq x 3nq windows."""
        k, kind, d = self.kin_rows.T if self.kin_rows.size else (np.zeros(0, int),) * 3
        prev = np.where(k >= 2, 1.0 / dt[np.maximum(k - 1, 0)], 0.0)
        cur = 1.0 / dt[k]
        acc = np.stack([prev, -cur - prev, cur], 1)
        vel = np.tile([0.0, -1.0, 1.0], (k.size, 1))
        self.kin_coef = np.where((kind == 1)[:, None], acc, vel)
        w = 3 * self.nq
        pos = np.arange(3)[None, :] * self.nq + d[:, None]  # m x 3
        self.kin_flat = k[:, None, None] * w * w + pos[:, :, None] * w + pos[:, None, :]

    # -- evaluations ----------------------------------------------------------------------
    def x_of(self, y: FloatArray, data: TaskData) -> FloatArray:
        """``T y + x_fix`` (``T`` a selection: a gather); the last one is kept (the solver asks for
        the same point's several times: cost, gradient, pose rows). Treat the result as read-only."""
        last = self._last_x
        if last is not None and last[0] is y and last[1] is data:
            return last[2]
        x = np.append(y, 0.0)[self._gather] + data.x_fix
        self._last_x = (y, data, x)  # holding y keeps its identity from being reused
        return x

    def objective(self, y: FloatArray, data: TaskData) -> float:
        x = self.x_of(y, data)
        stage = self.kernels.cost(self.n, self._win(x, data), *data.stage_args)[0]
        return float(stage.sum() + 0.5 * x @ (self.D @ x) + 0.5 * self.g @ (self.R @ x) ** 2)

    def gradient(self, y: FloatArray, data: TaskData) -> FloatArray:
        """``T^T (sum_k scatter(grad c_k) + Q x)``: one sparse product of ``[window gradients; x]``."""
        x = self.x_of(y, data)
        g = self.kernels.grad(self.n, self._win(x, data), *data.stage_args)[0]
        return self._gradient_map @ np.concatenate([g.ravel(), x])

    def quadratic_gradient(self, x: FloatArray) -> FloatArray:
        """``Q x = D x + R^T (g * R x)``."""
        return self.D @ x + (self.R.T @ (self.g * (self.R @ x)) if self.g.size else 0.0)

    def quadratic_product(self, v: FloatArray, windowed: bool = False) -> FloatArray:
        """``Q_y v`` in the free variables (the dense rows applied, not formed); ``windowed``: with
        only the part of ``D`` the window Hessians do not carry (:attr:`Dw`)."""
        dense = self.Ry.T @ (self.g * (self.Ry @ v)) if self.g.size else 0.0
        return (self.Wy if windowed else self.Dy) @ v + dense

    def stage_hessians(self, y: FloatArray, data: TaskData) -> FloatArray:
        """Hessians of the weighted stage costs in their windows (n x 3nq x 3nq)."""
        x = self.x_of(y, data)
        w = 3 * self.nq
        return self.kernels.hess(self.n, self._win(x, data), *data.stage_args)[0].reshape(self.n, w, w)

    def pose(self, y: FloatArray, data: TaskData) -> FloatArray:
        """Pose residuals of the posed waypoints (P x 6)."""
        q = self.x_of(y, data).reshape(self.n, self.nq)[self.posed]
        return self.kernels.pose(self.posed.size, q, data.p_d[self.posed], data.R_d[self.posed])[0]

    def pose_jacobian(self, y: FloatArray, data: TaskData) -> FloatArray:
        """P x 6 x nq."""
        q = self.x_of(y, data).reshape(self.n, self.nq)[self.posed]
        out = self.kernels.pose_jac(self.posed.size, q, data.p_d[self.posed], data.R_d[self.posed])[0]
        return out.reshape(-1, self.nq, 6).transpose(0, 2, 1)

    def pose_hessians(self, y: FloatArray, data: TaskData, lam: FloatArray) -> FloatArray:
        """``sum_i lam_i Hess(pose_i)`` per posed waypoint (P x nq x nq)."""
        q = self.x_of(y, data).reshape(self.n, self.nq)[self.posed]
        h = self.kernels.pose_hess(self.posed.size, q, data.p_d[self.posed], data.R_d[self.posed], lam)[0]
        return h.reshape(-1, self.nq, self.nq)

    def _win(self, x: FloatArray, data: TaskData) -> FloatArray:
        """The stage windows of ``x`` (n x 3nq), with the history before the first waypoint."""
        windows = x[self._widx]
        return windows if data.offsets is None else add_history(windows, data.offsets)

    def y_of(self, q: FloatArray) -> FloatArray:
        """The free variables of configurations ``q`` (n x nq; a tied waypoint reads its owner's)."""
        return np.asarray(q, dtype=float).ravel()[self.owner_x]
