"""A primal-dual interior-point method on the stage-structured trajectory NLP, with a null-space
step per waypoint, and its real-time iteration.

The problem (:class:`~forte.planning.nlp.solvers.stage_problem.StageProblem`)::

    min f(y)   s.t.   c(y) = 0 (pose rows, 6 per posed block of y),   l <= A y + b <= u

with slacks ``s = A y + b`` and bound multipliers ``z_l, z_u >= 0``. For the barrier parameter
``mu`` the Newton step on the primal-dual equations, after eliminating ``ds, dz_l, dz_u``
(``Sigma = z_l/(s-l) + z_u/(u-s)``, ``r_A = A y + b - s``), is

    [ W + A^T Sigma A   J^T ] [dy ]     [ grad f + J^T lam + A^T (mu/(u-s) - mu/(s-l) + Sigma r_A) ]
    [ J                  0  ] [dlam] = -[ c                                                        ]

``J`` is block diagonal (each pose row reads one waypoint), so the step is computed in the null
space of each block: ``J_j^T = [Y_j Z_j] [R_j; 0]`` (QR), ``dy = Y p_Y + Z p_Z`` with
``p_Y = -R^-T c`` and the reduced system ``Z^T H Z p_Z = -Z^T (g + H Y p_Y)``, whose matrix
has ``nq - 6`` rows per posed waypoint (the lift at N = 41: 148 against IPOPT's ~1000-row KKT
matrix), dense Cholesky with IPOPT's inertia correction (``H + delta I`` until positive
definite). The multipliers follow from ``Y^T``: ``lam + dlam = -R^-1 Y^T (g + H dy) + lam``.

Globalization: fraction-to-the-boundary ``tau = max(0.99, 1 - mu)``, a backtracking line search
on the l1 merit function ``phi = f - mu sum log(slack) + nu (|c|_1 + |r_A|_1)`` with one
second-order correction of the pose rows, and the monotone barrier update of IPOPT
(``mu <- max(tol/10, min(mu/5, mu^1.5))`` when the barrier problem's error is below ``10 mu``).
Convergence: IPOPT's scaled KKT error (``s_max = 100``) below ``tol`` and the constraint
violation below ``constraint_tol`` (:class:`~forte.settings.SolverOptions`).

A **real-time iteration** (:meth:`InteriorPoint.iterate`) is one such Newton step from the last
iterate at the last barrier parameter, without line search, on the new task data: the warm
point of a converged solve is the previous problem's optimum, so after a change of payload
mass, or a shift of the horizon, the step is the tangent predictor of the new optimum
(Diehl's real-time iteration, here on the interior-point equations).
"""

from __future__ import annotations

import time
from collections import Counter

import numpy as np
from scipy import sparse

from forte.planning.nlp.solvers.iterate import Evaluation, IPResult, Iterate, StepInfo
from forte.planning.nlp.solvers.line_search import FilterLineSearch, Trial
from forte.planning.nlp.solvers.native_step import NativeStep
from forte.planning.nlp.solvers.reduced_system import DENSE_VARIABLES, ReducedSystem
from forte.planning.nlp.solvers.stage_problem import StageProblem, TaskData
from forte.validation import FloatArray

S_MAX = 100.0  # IPOPT's s_max of the scaled optimality error
MAX_GRADIENT = 100.0  # IPOPT's nlp_scaling_max_gradient: the objective is scaled so that its gradient stays below
KAPPA_EPS = 10.0
KAPPA_SIGMA = 1e10


class InteriorPoint:
    """The solver for one :class:`StageProblem` (see the module docstring)."""

    def __init__(self, problem: StageProblem, tol: float = 1e-6, constraint_tol: float = 1e-6,
                 max_iter: int = 200, use_native: bool = True) -> None:
        self.pb, self.tol, self.constraint_tol, self.max_iter = problem, tol, constraint_tol, max_iter
        self.use_native = use_native  # the compiled step (native_step) where it can be built
        self.mu_min = tol / 10
        self.line_search = FilterLineSearch(problem)
        self._trial: Trial | None = None  # the line search's accepted point (its evaluation is reused)
        self.seconds: Counter[str] = Counter()  # factorization time, summed (kernel time: problem.kernels.clock)
        self._reduced_structure()

    def _reduced_structure(self) -> None:
        """Index maps of the reduced matrix: ``r`` columns per block (``nq - 6`` when every block
        is posed; else ``nq``, a posed block's last 6 padded), window entries -> reduced entries."""
        pb, nq, n = self.pb, self.pb.nq, self.pb.n
        self.posed_mask = np.zeros(pb.blocks, bool)
        self.posed_mask[pb.posed_block] = True
        self.r = r = nq - 6 if self.posed_mask.all() else nq
        self.nr = nr = pb.blocks * r
        wb = np.where(pb.window_block < 0, pb.blocks, pb.window_block)  # fixed -> a zero block
        self.wb = wb
        col = (wb[:, :, None] * r + np.arange(r)[None, None, :]).reshape(n, 3 * r)  # reduced column
        col = np.where(col >= nr, 0, col)  # a fixed slot's (zero) entries land anywhere
        self.widx = (col[:, :, None] * nr + col[:, None, :]).ravel()
        blk = np.arange(pb.blocks)[:, None] * r + np.arange(r)[None, :]
        self.didx = (blk[:, :, None] * nr + blk[:, None, :]).ravel()
        # y index of each window entry (ny: a fixed slot)
        wy = wb[:, :, None] * nq + np.arange(nq)[None, None, :]
        self.wy = np.where(wy >= pb.ny, pb.ny, wy).reshape(n, 3 * nq)
        cols = (np.arange(pb.ny)[:, None] // nq * r + np.arange(r)[None, :]).ravel()
        self.z_indices, self.z_indptr = cols, np.arange(0, pb.ny * r + 1, r)  # Z's CSR layout (banded form)
        self.padded = np.zeros(0, int)
        if r == nq:  # unposed blocks (identity), posed blocks padded with zero columns
            self.padded = (pb.posed_block[:, None] * r + np.arange(nq - 6, nq)[None, :]).ravel()
        banded = pb.ny > DENSE_VARIABLES
        dc = sparse.coo_matrix(pb.Dy)
        reach = int(np.abs(dc.row // nq - dc.col // nq).max(initial=0))  # D's bandwidth in blocks
        self.system = ReducedSystem(nr, self.widx, self.didx, (max(2, reach) + 1) * r - 1, banded)
        if banded and pb.g.size:  # the dense rows, per block: U = Z^T R^T
            self._rt = pb.Ry.T.toarray().reshape(pb.blocks, nq, -1)
        library = pb.nlp.kernels.library  # compiled kernels: a compiler and a cache folder
        self.native = None if banded or library is None or not self.use_native else \
            NativeStep.load(library.parent, pb, r, wb, self.wy)

    # -- evaluation -----------------------------------------------------------------------
    def evaluate(self, it: Iterate, data: TaskData) -> Evaluation:
        """Objective, gradient, pose rows and Jacobian, slack residual at ``it`` (the objective and
        pose rows of the line search's accepted trial point are reused: the same ``y``)."""
        pb = self.pb
        trial = self._trial
        hit = trial is not None and trial.y is it.y and trial.data is data
        f, c = (trial.f, trial.c) if hit else (it.scale * pb.objective(it.y, data), pb.pose(it.y, data))
        return Evaluation(f, it.scale * pb.gradient(it.y, data), c, pb.pose_jacobian(it.y, data),
                          pb.A @ it.y + data.b - it.s)

    def pose_rows(self, y: FloatArray, data: TaskData) -> FloatArray:
        """The pose rows at ``y`` (those the line search evaluated at the point it accepted, reused)."""
        trial = self._trial
        return trial.c if trial is not None and trial.y is y and trial.data is data else self.pb.pose(y, data)

    def _dual_residual(self, ev: Evaluation, it: Iterate) -> FloatArray:
        pb = self.pb
        jt = np.zeros(pb.ny)
        jt_blocks = np.einsum("pij,pi->pj", ev.J, it.lam)
        idx = (pb.posed_block[:, None] * pb.nq + np.arange(pb.nq)[None, :]).ravel()
        jt[idx] = jt_blocks.ravel()
        return ev.grad + jt + pb.At @ (it.zu - it.zl)

    def error(self, ev: Evaluation, it: Iterate, data: TaskData, mu: float) -> tuple[float, float]:
        """IPOPT's scaled optimality error at barrier ``mu``, and the constraint violation."""
        lo, up = data.lo, data.up
        key = (it.y, it.lam, it.zl, it.zu, it.s)  # the terms without mu, once per iterate
        cached = ev.extras.get("error")
        if cached is None or any(a is not b for a, b in zip(cached[0], key, strict=True)):
            rd = self._dual_residual(ev, it)
            z = np.abs(it.zl[lo]).sum() + np.abs(it.zu[up]).sum()
            s_d = max(S_MAX, (np.abs(it.lam).sum() + z) / max(it.lam.size + it.s.size + it.y.size, 1)) / S_MAX
            s_c = max(S_MAX, z / max(it.s.size, 1)) / S_MAX
            dual = np.abs(rd).max(initial=0) / s_d
            products = np.concatenate([((it.s - data.lower) * it.zl)[lo], ((data.upper - it.s) * it.zu)[up]])
            cached = ev.extras["error"] = (key, dual, s_c, products, self.violation(ev.c, it.y, data, ev.rA + it.s))
        _, dual, s_c, products, viol = cached
        err = max(dual, viol, np.abs(products - mu).max(initial=0) / s_c)
        return float(err), viol

    def violation(self, c: FloatArray, y: FloatArray, data: TaskData, rows: FloatArray | None = None) -> float:
        """Largest violation of the pose rows ``c`` and of the rows' bounds at ``y`` (as IPOPT
        reports; ``rows``: ``A y + b`` when known)."""
        v = self.pb.A @ y + data.b if rows is None else rows
        rows = np.maximum(np.maximum(data.lower - v, v - data.upper), 0)
        return float(max(np.abs(c).max(initial=0), rows.max(initial=0)))

    # -- the Newton step ------------------------------------------------------------------
    def bases(self, J: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """``Z`` (blocks x nq x r), ``Y`` (P x nq x 6) and ``R`` (P x 6 x 6): ``J_j^T = Y_j R_j``."""
        pb, nq, r = self.pb, self.pb.nq, self.r
        Qf, Rf = np.linalg.qr(J.transpose(0, 2, 1), mode="complete")
        Z = np.zeros((pb.blocks, nq, r))
        Z[~self.posed_mask] = np.eye(nq, r)
        Z[pb.posed_block, :, : nq - 6] = Qf[:, :, 6:]
        return Z, Qf[:, :, :6], Rf[:, :6, :]

    def _window_hessians(self, it: Iterate, ev: Evaluation, data: TaskData, sigma: FloatArray) -> FloatArray:
        """Stage Hessians plus ``D``'s window part, the pose rows' curvature and the barrier of the
        kinematic rows."""
        pb, nq = self.pb, self.pb.nq
        Hw = ev.extras["hess"] + it.scale * pb.Dw  # and the quadratic terms' near-diagonal part
        Hw[pb.posed, 2 * nq:, 2 * nq:] += pb.pose_hessians(it.y, data, it.lam)
        kin = sigma[pb.bound_vars.size:]
        if kin.size:
            c = pb.kin_coef  # m x 3, on window slots 0, 1, 2 of the row's waypoint, its dof
            w = (c[:, :, None] * c[:, None, :]) * kin[:, None, None]
            Hw.reshape(-1)[:] += np.bincount(pb.kin_flat.ravel(), w.ravel(), minlength=Hw.size)
        return Hw

    def step(self, it: Iterate, ev: Evaluation, data: TaskData, mu: float
             ) -> tuple[FloatArray, FloatArray, float, tuple]:
        """``(dy, lam_new, delta, parts)`` of the Newton step at barrier ``mu``."""
        pb, nq, r = self.pb, self.pb.nq, self.r
        lo, up = data.lo, data.up
        sl = np.where(lo, it.s - data.lower, 1.0)
        su = np.where(up, data.upper - it.s, 1.0)
        sig_l = np.where(lo, it.zl / sl, 0.0)
        sig_u = np.where(up, it.zu / su, 0.0)
        sigma = sig_l + sig_u
        barrier = np.where(up, mu / su, 0.0) - np.where(lo, mu / sl, 0.0)
        g = ev.grad + pb.At @ (barrier + sigma * ev.rA)
        bdiag = np.zeros(pb.ny)
        bdiag[pb.bound_vars] = sigma[: pb.bound_vars.size]
        if self.native is not None:  # the same arithmetic in compiled code (native_step)
            dy, lam_new, delta, Y, R = self._native_step(it, ev, data, g, sigma, bdiag)
            return dy, lam_new, delta, (sigma, sig_l, sig_u, sl, su, lo, up, Y, R)
        Hw = self._window_hessians(it, ev, data, sigma)
        Z, Y, R = self.bases(ev.J)
        Zw = np.zeros((pb.n, 3 * nq, 3 * r))
        Zext = np.concatenate([Z, np.zeros((1, nq, r))])
        for slot in range(3):
            Zw[:, slot * nq:(slot + 1) * nq, slot * r:(slot + 1) * r] = Zext[self.wb[:, slot]]
        Hred = np.matmul(Zw.transpose(0, 2, 1), np.matmul(Hw, Zw))  # reduced window Hessians
        bounds = np.einsum("bna,bn,bnc->bac", Z, bdiag.reshape(pb.blocks, nq), Z)
        U = g_rows = None
        if self.system.banded:
            Zm = sparse.csr_matrix((Z.reshape(-1), self.z_indices, self.z_indptr), shape=(pb.ny, self.nr))
            M = self.system.assemble(Hred, bounds, it.scale * (Zm.T @ (pb.Wy @ Zm)))
            M[0, self.padded] += 1.0
            if pb.g.size:
                U, g_rows = np.einsum("bna,bnl->bal", Z, self._rt).reshape(self.nr, -1), it.scale * pb.g
        else:
            M = self.system.assemble(Hred, bounds, it.scale * self._reduced_quadratic(Z))
            M[self.padded, self.padded] += 1.0

        def hv(v: FloatArray) -> FloatArray:
            vw = np.append(v, 0.0)[self.wy]
            out = np.bincount(self.wy.ravel(), np.matmul(Hw, vw[:, :, None]).ravel(), minlength=pb.ny + 1)
            return out[: pb.ny] + it.scale * pb.quadratic_product(v, windowed=True) + bdiag * v

        pY = -np.linalg.solve(R.transpose(0, 2, 1), ev.c[..., None])[..., 0]  # P x 6
        ypy = np.zeros((pb.blocks, nq))
        ypy[pb.posed_block] = np.einsum("pij,pj->pi", Y, pY)
        ypy = ypy.ravel()
        rhs = -np.einsum("bna,bn->ba", Z, (g + hv(ypy)).reshape(pb.blocks, nq)).ravel()
        begin = time.perf_counter()
        pZ, delta = self.system.solve(M, rhs, U, g_rows)
        self.seconds["factorization"] += time.perf_counter() - begin
        dy = ypy + np.einsum("bna,ba->bn", Z, pZ.reshape(pb.blocks, r)).ravel()
        resid = (g + hv(dy) + delta * dy).reshape(pb.blocks, nq)[pb.posed_block]
        lam_new = -np.linalg.solve(R, np.einsum("pij,pi->pj", Y, resid)[..., None])[..., 0]
        return dy, lam_new, delta, (sigma, sig_l, sig_u, sl, su, lo, up, Y, R)

    def _native_step(self, it: Iterate, ev: Evaluation, data: TaskData, g: FloatArray, sigma: FloatArray,
                     bdiag: FloatArray) -> tuple[FloatArray, FloatArray, float, FloatArray, FloatArray]:
        """:meth:`step`'s ``(dy, lam_new, delta, Y, R)`` by :class:`NativeStep` and LAPACK."""
        pb, native = self.pb, self.native
        M, rhs = native.prepare(ev.extras["hess"], pb.pose_hessians(it.y, data, it.lam), ev.J, ev.c, g, bdiag,
                                sigma[pb.bound_vars.size:], pb.kin_coef, pb.kin_flat, it.scale)
        M[self.padded, self.padded] += 1.0
        begin = time.perf_counter()
        pZ, delta = self.system.solve(M, rhs)
        self.seconds["factorization"] += time.perf_counter() - begin
        dy, lam_new = native.finish(pZ, delta)
        return dy, lam_new, delta, native.Y.copy(), native.R.copy()

    def _reduced_quadratic(self, Z: FloatArray) -> FloatArray:
        """``Z^T (W + R^T diag(g) R) Z``: the constant quadratic terms the window Hessians do not
        carry (dense form): ``W`` on the few dofs it couples (J5's dense blocks), ``R Z`` per block."""
        pb, r, blocks = self.pb, self.r, self.pb.blocks
        if not hasattr(self, "_r3"):
            self._r3 = pb.Ry.toarray().reshape(-1, blocks, pb.nq).transpose(1, 0, 2)  # blocks x L x nq
        out = np.zeros((self.nr, self.nr))
        if pb.wide_dofs.size:
            Zs = Z[:, pb.wide_dofs, :]  # blocks x d x r
            w4 = pb.W_dofs.reshape(blocks, pb.wide_dofs.size, -1)
            t1 = np.matmul(Zs.transpose(0, 2, 1), w4).reshape(blocks * r, blocks, -1)  # (i a), j, m
            out += np.matmul(t1.transpose(1, 0, 2), Zs).transpose(1, 0, 2).reshape(self.nr, self.nr)
        if pb.g.size:
            rz = np.matmul(self._r3, Z).transpose(1, 0, 2).reshape(pb.g.size, self.nr)  # R Z, L x nr
            out += rz.T @ (pb.g[:, None] * rz)
        return out

    # -- moving along a step --------------------------------------------------------------
    def _fraction_to_boundary(self, it: Iterate, ds: FloatArray, dzl: FloatArray, dzu: FloatArray,
                              parts: tuple, tau: float) -> tuple[float, float]:
        _, _, _, sl, su, lo, up, _, _ = parts

        def largest(v: FloatArray, dv: FloatArray, finite: FloatArray) -> float:
            neg = np.flatnonzero(finite & (dv < 0))
            return float(min(1.0, np.min(-tau * v[neg] / dv[neg]))) if neg.size else 1.0

        a_p = min(largest(sl, ds, lo), largest(su, -ds, up))
        a_d = min(largest(it.zl, dzl, lo), largest(it.zu, dzu, up))
        return a_p, a_d

    def _directions(self, it: Iterate, ev: Evaluation, dy: FloatArray, parts: tuple, mu: float
                    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        _, sig_l, sig_u, sl, su, lo, up, _, _ = parts
        ds = self.pb.A @ dy + ev.rA
        dzl = np.where(lo, mu / sl - it.zl - sig_l * ds, 0.0)
        dzu = np.where(up, mu / su - it.zu + sig_u * ds, 0.0)
        return ds, dzl, dzu

    def _take(self, it: Iterate, dy: FloatArray, lam_new: FloatArray, ds: FloatArray, dzl: FloatArray,
              dzu: FloatArray, a_p: float, a_d: float, mu: float, data: TaskData) -> Iterate:
        trial = self._trial
        y = trial.y if trial is not None and trial.dy is dy and trial.alpha == a_p else it.y + a_p * dy
        new = Iterate(y, it.lam + a_p * (lam_new - it.lam), it.s + a_p * ds,
                      it.zl + a_d * dzl, it.zu + a_d * dzu, mu, it.scale)
        lo, up = data.lo, data.up
        # IPOPT's safeguard: z stays within a factor kappa_sigma of mu / slack
        sl, su = np.where(lo, new.s - data.lower, 1.0), np.where(up, data.upper - new.s, 1.0)
        new.zl = np.where(lo, np.clip(new.zl, mu / (KAPPA_SIGMA * sl), KAPPA_SIGMA * mu / sl), 0.0)
        new.zu = np.where(up, np.clip(new.zu, mu / (KAPPA_SIGMA * su), KAPPA_SIGMA * mu / su), 0.0)
        return new

    # -- starting points ------------------------------------------------------------------
    def start(self, y0: FloatArray, data: TaskData, mu0: float = 0.1) -> Iterate:
        """A cold start: slacks pushed inside their bounds (IPOPT's ``bound_push`` 0.01), bound
        multipliers 1, pose multipliers by least squares."""
        pb = self.pb
        v = pb.A @ y0 + data.b
        s = self._push(v, data)
        lo, up = data.lo, data.up
        it = Iterate(y0.copy(), np.zeros((pb.posed.size, 6)), s, lo * 1.0, up * 1.0, mu0)
        it.scale = min(1.0, MAX_GRADIENT / max(float(np.abs(pb.gradient(y0, data)).max(initial=0.0)), 1e-300))
        ev = self.evaluate(it, data)
        it.lam = self.least_squares_multipliers(ev, it)
        return it

    def _push(self, v: FloatArray, data: TaskData) -> FloatArray:
        lo, up = data.lower, data.upper
        width = np.where(np.isfinite(lo) & np.isfinite(up), up - lo, np.inf)
        p_l = np.minimum(1e-2 * np.maximum(1.0, np.abs(np.where(np.isfinite(lo), lo, 0))), 1e-2 * width)
        p_u = np.minimum(1e-2 * np.maximum(1.0, np.abs(np.where(np.isfinite(up), up, 0))), 1e-2 * width)
        return np.minimum(np.maximum(v, np.where(np.isfinite(lo), lo + p_l, -np.inf)),
                          np.where(np.isfinite(up), up - p_u, np.inf))

    def least_squares_multipliers(self, ev: Evaluation, it: Iterate) -> FloatArray:
        """``lam`` minimizing ``|grad f + J^T lam + A^T (z_u - z_l)|`` per posed block."""
        pb = self.pb
        g = (ev.grad + pb.At @ (it.zu - it.zl)).reshape(pb.blocks, pb.nq)[pb.posed_block]
        return -np.linalg.lstsq_batched(ev.J, g) if hasattr(np.linalg, "lstsq_batched") else \
            -np.stack([np.linalg.lstsq(J.T, gi, rcond=None)[0] for J, gi in zip(ev.J, g, strict=True)])

    def warm(self, it: Iterate, data: TaskData) -> Iterate:
        """``it`` made consistent with new rows' data: slacks moved inside, multipliers kept."""
        new = it.copy()
        v = self.pb.A @ new.y + data.b
        inside = (v > data.lower) & (v < data.upper)
        new.s = np.where(inside, v, self._push(v, data))
        return new

    # -- iterations -----------------------------------------------------------------------
    def iteration(self, it: Iterate, ev: Evaluation, data: TaskData, line_search: bool = True
                  ) -> tuple[Iterate, float, float]:
        """One Newton step from ``it`` at ``it.mu``: the new iterate, its step length and delta."""
        mu = it.mu
        ev.extras["hess"] = self.pb.stage_hessians(it.y, data)
        if it.scale != 1.0:
            ev.extras["hess"] *= it.scale
        dy, lam_new, delta, parts = self.step(it, ev, data, mu)
        ds, dzl, dzu = self._directions(it, ev, dy, parts, mu)
        a_p, a_d = self._fraction_to_boundary(it, ds, dzl, dzu, parts, max(0.99, 1 - mu))
        if not line_search:
            return self._take(it, dy, lam_new, ds, dzl, dzu, a_p, a_d, mu, data), a_p, delta
        alpha, accepted, self._trial = self.line_search.search(it, ev, data, dy, ds, parts, a_p)
        if accepted is not dy:  # a second-order correction was accepted
            dy = accepted
            ds, dzl, dzu = self._directions(it, ev, dy, parts, mu)
            a_d = min(a_d, self._fraction_to_boundary(it, ds, dzl, dzu, parts, max(0.99, 1 - mu))[1])
        return self._take(it, dy, lam_new, ds, dzl, dzu, alpha, a_d, mu, data), alpha, delta

    def solve(self, it: Iterate, data: TaskData, max_iter: int | None = None) -> IPResult:
        """Iterate from ``it`` until IPOPT's convergence test holds (or ``max_iter``)."""
        max_iter = self.max_iter if max_iter is None else max_iter
        history: list[StepInfo] = []
        self.reset()
        for k in range(max_iter + 1):
            ev = self.evaluate(it, data)
            if not np.isfinite(ev.f) or not np.isfinite(ev.grad).all():
                return IPResult(it, False, k, "Invalid_Number_Detected", ev.f, np.inf, history)
            err0, viol = self.error(ev, it, data, 0.0)
            if err0 <= self.tol and viol <= self.constraint_tol:
                return IPResult(it, True, k, "Solve_Succeeded", ev.f / it.scale, viol, history)
            if k == max_iter:
                break
            while it.mu > self.mu_min and self.error(ev, it, data, it.mu)[0] <= KAPPA_EPS * it.mu:
                it.mu = max(self.mu_min, min(0.2 * it.mu, it.mu ** 1.5))
            try:
                it, alpha, delta = self.iteration(it, ev, data)
            except np.linalg.LinAlgError:
                return IPResult(it, False, k, "Error_In_Step_Computation", ev.f / it.scale, viol, history)
            history.append(StepInfo(err0, viol, alpha, delta))
        return IPResult(it, False, max_iter, "Maximum_Iterations_Exceeded", ev.f / it.scale, viol, history)

    def reset(self) -> None:
        """Forget the filter and the last inertia correction (a new solve)."""
        self.line_search.reset()
        self.system.reset()

    def real_time_iteration(self, it: Iterate, data: TaskData) -> tuple[Iterate, Evaluation]:
        """One full Newton step from ``it`` on ``data`` (no line search), and the evaluation at the
        new point's primal variables (its constraint violation decides whether it may be used)."""
        ev = self.evaluate(it, data)
        new, _, _ = self.iteration(it, ev, data, line_search=False)
        return new, ev
