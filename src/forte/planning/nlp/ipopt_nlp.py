"""The IPOPT side of the trajectory NLP: its constraint Jacobian, Lagrangian Hessian, kinematic
rows and options, as CasADi expressions of a :class:`~forte.planning.nlp.optimizer.TrajectoryOptimizer`
(``opt``) under construction (:meth:`~forte.planning.nlp.optimizer.TrajectoryOptimizer._build`)."""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np

from forte.planning.nlp.assembly import block_diagonal_pattern
from forte.planning.nlp.budget import ipopt_budget


def constraint_jacobian(opt: Any, x: ca.MX, X: ca.MX, pd: ca.MX, Rd: ca.MX, g_kin: ca.MX) -> ca.MX:
    """6 x nq pose blocks (one per posed waypoint), then the linear rows."""
    nq, n, nx = opt.robot.nq, opt.n, x.numel()
    steps = opt._pose_steps
    blocks = opt.kernels.pose_jac.map(n)(X, pd, Rd)  # 6 x nq n
    runs = np.split(steps, np.flatnonzero(np.diff(steps) != 1) + 1) if steps.size else []
    parts = []
    for run in runs:  # contiguous runs of posed waypoints: block-diagonal pieces
        sp, nz = block_diagonal_pattern(6, nq, run.size, col_offset=int(run[0]) * nq, ncol=nx)
        cols = blocks[:, int(run[0]) * nq:(int(run[-1]) + 1) * nq]
        parts.append(ca.MX(sp, ca.mtimes(ca.DM(nz), ca.vec(cols))))
    jac = ca.vertcat(*parts) if parts else ca.MX(0, nx)
    return ca.vertcat(jac, ca.jacobian(g_kin, x)) if g_kin.numel() else jac

def lagrangian_hessian(opt: Any, pattern: tuple[ca.Sparsity, Any], X: ca.MX, pd: ca.MX, Rd: ca.MX,
                       stage_args: list[Any], lam_f: ca.MX, lam_g: ca.MX) -> ca.MX:
    """Upper triangle of ``lam_f * Hess(cost) + sum lam_g Hess(g)`` over the pose rows (linear
    rows add nothing) in ``pattern`` (:func:`~forte.planning.nlp.assembly.hessian_pattern`)."""
    n = opt.n
    steps = opt._pose_steps
    lam_pose = ca.reshape(lam_g[: 6 * steps.size], 6, steps.size)
    cols = [ca.MX.zeros(6, 1)] * n
    for i, k in enumerate(steps.tolist()):
        cols[k] = lam_pose[:, i]
    lam = ca.horzcat(*cols)
    h_stage = opt.kernels.hess.map(n)(*stage_args)  # 3nq x 3nq n
    h_pose = opt.kernels.pose_hess.map(n)(X, pd, Rd, lam)  # nq x nq n
    sp, maps = pattern
    nz = (lam_f * ca.mtimes(ca.DM(maps[0]), ca.vec(h_stage))
          + ca.mtimes(ca.DM(maps[1]), ca.vec(h_pose))
          + lam_f * ca.DM(maps[2]))
    return ca.MX(sp, nz)

def kinematic_rows(opt: Any, X: ca.MX, dt: ca.MX) -> ca.MX:
    """Velocity rows ``q_k - q_{k-1}`` and acceleration rows ``dq_k - dq_{k-1}`` (k >= 2), with
    ``dq_1 = 0``; :meth:`~forte.planning.nlp.optimizer.TrajectoryOptimizer.bounds` scales the limits by ``dt_k``.
    Of the coordinates with a limit (``opt._limited``, the stagewise solver's rows), a given path's
    NLP with the executed spline's rows leaves out those the spline's rows imply
    (:meth:`~forte.planning.nlp.spline_rows.SplineCoordinates.covered`) while ``opt._drop_implied``."""
    opt._vel_rows = np.flatnonzero(np.isfinite(opt._vel)) if opt.limits.enabled else np.array([], int)
    opt._acc_rows = np.flatnonzero(np.isfinite(opt._acc)) if opt.limits.enabled else np.array([], int)
    if opt.n < 2 or not opt.fix_initial:
        opt._vel_rows = opt._acc_rows = np.array([], int)
    opt._limited = (opt._vel_rows, opt._acc_rows)
    if opt.n < 2 or not opt.fix_initial:
        return ca.MX(0, 1)
    if opt._spline_rows and opt.goal is None and opt._drop_implied:
        velocity, acceleration = opt._spline.covered()
        opt._vel_rows = np.setdiff1d(opt._vel_rows, velocity)
        opt._acc_rows = np.setdiff1d(opt._acc_rows, acceleration)
    if not opt.limits.enabled and not opt.rests_at_end:
        return ca.MX(0, 1)
    step = X[:, 1:] - X[:, :-1]
    dq = step / ca.repmat(dt[:, 1:], X.shape[0], 1)
    dq_prev = ca.horzcat(ca.MX.zeros(X.shape[0], 1), dq[:, :-1])
    rows = [ca.vec(step[opt._vel_rows.tolist(), :]), ca.vec((dq - dq_prev)[opt._acc_rows.tolist(), :])]
    if opt.rests_at_end:  # v_N = 0 and a_N = (v_N - v_{N-1}) / dt_N = 0
        rows += [step[:, -1], step[:, -2]]
    return ca.vertcat(*rows)

def warm_options(options: Any) -> dict[str, Any]:
    """IPOPT's options of a solve from a given primal-dual point (added to :func:`ipopt_options`).

    The barrier parameter starts at ``tol / 10``: from a near-optimal primal-dual point a larger
    one only costs the iterations that bring it down again (on the lift's seeded mass changes,
    375 warm iterations in all with 1e-7, 406 with 1e-5, 417 with 1e-6). No "acceptable level"
    exit: a warm solve converges to ``tol`` or fails.
    """
    return {
        "ipopt.warm_start_init_point": "yes", "ipopt.warm_start_bound_push": 1e-9,
        "ipopt.warm_start_bound_frac": 1e-9, "ipopt.warm_start_slack_bound_push": 1e-9,
        "ipopt.warm_start_slack_bound_frac": 1e-9, "ipopt.warm_start_mult_bound_push": 1e-9,
        "ipopt.mu_strategy": "monotone", "ipopt.mu_init": 0.1 * options.tol,
        "ipopt.acceptable_iter": 0, "calc_lam_x": True,
    }


#: MUMPS' fill-reducing orderings (``mumps_pivot_order``): QAMD, ~25 % faster factorizations than
#: MUMPS' default on the waypoint problem; METIS, half the linear-solver time once a given path's
#: problem carries the executed spline's knot variables and rows (the lift: IPOPT 0.28 -> 0.14 s at
#: 41 waypoints, 0.33 -> 0.23 s at 100, the same 9 / 8 iterations), while a goal task's solves
#: (route, clearance and spline rows) gain nothing from it (MotionBenchMaker, 6 problems per
#: scenario: NLP median 0.45 vs 0.46 s, the same 23 iterations), so they keep QAMD.
QAMD, METIS = 6, 5


def pivot_order(opt: Any) -> int:
    """The ordering of ``opt``'s solves: :data:`METIS` for a given path with the spline's rows,
    else :data:`QAMD`."""
    return METIS if getattr(opt, "on_spline", False) and opt.goal is None else QAMD


def ipopt_options(opt: Any) -> dict[str, Any]:
    """IPOPT's options of ``opt``'s solves (``SolverOptions.extra`` last)."""
    o = opt.options
    opts = {
        "ipopt.max_iter": o.max_iter, "ipopt.tol": o.tol, "ipopt.print_level": o.print_level,
        "ipopt.sb": "yes", "print_time": False, "ipopt.constr_viol_tol": o.constraint_tol,
        "ipopt.mu_strategy": "adaptive", "calc_lam_p": False, "calc_lam_x": opt.keep_multipliers,
        "ipopt.mumps_pivot_order": pivot_order(opt),
    }
    opts |= ipopt_budget()  # the plan's solves share a time budget (nlp/budget.py)
    if opt.goal is not None:  # a free path: stop where the feasible iterate's objective stalls
        opts.update(stall_stop(o))
    opts.update({k if "." in k else f"ipopt.{k}": v for k, v in o.extra.items()})
    return opts


#: A goal task's solve stops once, for this many iterations in a row, the iterate keeps every row
#: within ``constraint_tol`` and the objective moves by less than :data:`STALL_CHANGE` of itself
#: (IPOPT's "acceptable" exit, :func:`stall_stop`).
STALL_ITERATIONS = 10
#: Relative objective change per iteration below which a goal task's solve counts as stalled.
STALL_CHANGE = 1e-5


def stall_stop(options: Any) -> dict[str, Any]:
    """IPOPT's acceptable exit set to stop a goal task's cold solve on a feasible stall.

    A free path among many clearance rows reaches its objective to ~5 digits in a few dozen
    iterations, then IPOPT spends the rest bringing the dual infeasibility down on near-redundant
    rows (MotionBenchMaker's table_pick 0003: objective within 1e-5 of the optimum from iteration
    ~35, exit at 179). The exit asks for the iterate's constraint violation within
    ``constraint_tol`` (unscaled, the rows the verdict checks), complementarity within IPOPT's
    default 1e-2, and :data:`STALL_ITERATIONS` consecutive iterations whose objective changed by
    less than :data:`STALL_CHANGE` relative; the overall error and the dual infeasibility are not
    limited (``1e20``: the stall is the test). Warm solves keep ``acceptable_iter = 0``
    (:func:`warm_options`)."""
    return {
        "ipopt.acceptable_iter": STALL_ITERATIONS, "ipopt.acceptable_obj_change_tol": STALL_CHANGE,
        "ipopt.acceptable_constr_viol_tol": options.constraint_tol, "ipopt.acceptable_tol": 1e20,
        "ipopt.acceptable_dual_inf_tol": 1e20, "ipopt.acceptable_compl_inf_tol": 1e-2,
    }
