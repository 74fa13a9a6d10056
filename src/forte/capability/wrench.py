"""Residual wrench polytope and the wrench-capability metric (issue 25, item 2; beyond the paper).

**Polytope.** With ``J6 = [J_v; J_w]`` the world-frame 6 x n Jacobian of the end effector (linear
rows first, Pinocchio's ``LOCAL_WORLD_ALIGNED``; the base held fixed), the joint torques that apply
the wrench ``w = (f, m)`` are ``J6^T w``, and the alpha-scaled dynamic residual wrench polytope is

    W_k = { w in R^6 : alpha tau- <= J6(q_k)^T w <= alpha tau+ }  =  { w : A_k w <= b_k },
    A_k = [J6^T ; -J6^T] (2n x 6),   b_k = alpha [tau+ ; -tau-],

with ``tau+-`` the residual margins of :mod:`forte.capability.polytope`. Its slice ``m = 0`` is
the RFP. Row ``i`` is ``a_i = (a_f,i, a_m,i) = +-(j_v,i, j_w,i)``.

**Scaling.** Moments are scaled against forces by a length ``L``: ``w_s = (f, m / L)``; a row
becomes ``a_s,i = (a_f,i, L a_m,i)``. Default ``L = |c|``, the payload's centre-of-mass offset
(``payload.moment_scale`` overrides it). Why: (1) at ``c = 0`` it is the paper's metric exactly:
any fixed ``L > 0`` would give the wrist's angular rows a weight even for a payload in the hand
and change today's numbers; (2) the payload's own moment then weighs what its force weighs,
``|m / L| = |c_hat x f| <= |f|``, and the uncertainty set of :mod:`forte.force.wrench` becomes two
balls of the same radius ``r`` (one newton of scaled moment is the moment a newton makes at the
centre of mass); (3) the sign of every facet distance below, hence ``d_k >= 0``, the verdict and
the J1 penalty's zero set, do not depend on ``L`` at all: ``L`` only sets how far inside or
outside a wrench counts, not whether it fits.

**Metric.** The uncertainty set is ``U_k = {(f_k + df, m_k + dm) : |df| <= r_k, |dm| <= r_m,k}``
(``r_m = |c| r``, :mod:`forte.force.wrench`), with support function ``h(a) = r |a_f| + r_m |a_m|``.
The signed Euclidean distance (scaled space, N) from ``U_k`` to facet ``i``, and the margin, are

    d_i = (b_i - a_i^T w_k - r_k |a_f,i| - r_m,k |a_m,i|) / sqrt(|a_f,i|^2 + L^2 |a_m,i|^2)
    d_k = min_i d_i,        c_k = 0 if d_k >= 0 else exp(kappa (-d_k) / rho_k) - 1,   J1 = sum_k c_k

with ``rho_k = max(|f_k| + r_k, eps)`` as in :mod:`forte.capability.metrics`. A row whose scaled
normal vanishes (``a_f = 0`` and ``L a_m = 0``) gives ``+inf`` when its numerator is ``>= 0``
(the row never binds) and ``-inf`` otherwise, the 3-D rule. With ``c = 0`` (no inertia: ``m_k = 0``,
``r_m = 0``, ``L = 0``) ``d_i = (b_i - a_f,i^T f_k) / |a_f,i| - r_k``: the 3-D metric, row by row.

**Capacity along the wrench.** ``t*_k = min_{a_i^T w_k > 0} b_i / (a_i^T w_k)`` is the largest
multiple of the desired wrench inside the polytope; ``|f_k| t*_k`` (N) is the 3-D directional
capacity when ``m_k = 0``.

**Smooth surrogate** (the optimizer's J1): as :func:`forte.capability.metrics.smooth_penalty_expr`
with ``|a_f|`` and ``|a_m|`` regularized to ``n_f = sqrt(|a_f|^2 + eps_n^2)``,
``n_m = sqrt(|a_m|^2 + eps_n^2)`` and the distances
``d_i = (b_i - a_i^T w - r n_f - r_m n_m) / sqrt(n_f^2 + L^2 |a_m|^2)``; it is the 3-D surrogate
when ``m = 0``, ``r_m = 0`` and ``L = 0``. Derivatives are CasADi's (automatic, exact).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np
import pinocchio as pin

from forte.capability.metrics import capability_penalty, normalization
from forte.capability.polytope import ZERO_NORMAL, nominal_torques, residual_margins
from forte.exceptions import InvalidInputError
from forte.model.robot import N_BASE, MobileManipulator
from forte.model.trajectory import StartMotion
from forte.settings import CapabilityParameters
from forte.validation import FloatArray


# -- the polytope ------------------------------------------------------------------------------
def wrench_jacobian(robot: MobileManipulator, q: Any) -> FloatArray:
    """World-frame 6 x n Jacobian ``[J_v; J_w]`` of the end effector at whole-body ``q`` (base fixed)."""
    q = robot.check_configuration(q)
    local = pin.computeFrameJacobian(robot.model, robot.data, np.ascontiguousarray(q[N_BASE:]),
                                     robot.ee_frame_id, pin.LOCAL_WORLD_ALIGNED)
    R = robot.base_transform(q[:N_BASE])[:3, :3]
    return np.vstack([R @ local[:3], R @ local[3:]])


def wrench_halfspaces(J6: Any, tau_plus: Any, tau_minus: Any, alpha: float = 1.0) -> tuple[FloatArray, FloatArray]:
    """``(A, b)`` of the residual wrench polytope from ``J6`` (... x 6 x n) and the margins."""
    if not 0.0 < alpha <= 1.0:
        raise InvalidInputError(f"alpha: expected 0 < alpha <= 1, got {alpha}")
    Jt = np.swapaxes(np.asarray(J6, dtype=float), -1, -2)
    A = np.concatenate([Jt, -Jt], axis=-2)
    b = alpha * np.concatenate([np.asarray(tau_plus, dtype=float), -np.asarray(tau_minus, dtype=float)], axis=-1)
    return A, b


@dataclass(frozen=True)
class TrajectoryWrenchPolytope:
    """Residual wrench polytopes along a trajectory: ``J6`` (N x 6 x n), ``tau_nom`` (N x n),
    ``A`` (N x 2n x 6), ``b`` (N x 2n, with ``alpha``)."""

    J6: FloatArray
    tau_nom: FloatArray
    A: FloatArray
    b: FloatArray
    alpha: float


def trajectory_wrench_polytope(robot: MobileManipulator, q: Any, t: Any, alpha: float = 1.0,
                               start: StartMotion | None = None) -> TrajectoryWrenchPolytope:
    """Dynamic residual wrench polytopes of a whole-body trajectory ``q`` (N x nq) at times ``t``
    (``start``: the first waypoint's motion, default at rest)."""
    tau = nominal_torques(robot, q, t, start)
    J6 = np.array([wrench_jacobian(robot, qk) for qk in np.asarray(q, dtype=float)])
    A, b = wrench_halfspaces(J6, *residual_margins(tau, robot.torque_limits), alpha=alpha)
    return TrajectoryWrenchPolytope(J6, tau, A, b, alpha)


# -- the exact metric (numpy, vectorized over waypoints) -----------------------------------------
def wrench_signed_distances(A: Any, b: Any, w: Any, r: Any, r_m: Any, scale: float) -> FloatArray:
    """Per-facet signed distances ``d_i`` (... x 2n) of the module docstring.

    Args:
        A: the polytope's normals (... x 2n x 6).
        b: its offsets (... x 2n, with ``alpha``).
        w: desired wrenches (... x 6).
        r: radii of the force balls (...).
        r_m: radii of the moment balls (...).
        scale: ``L`` (m).
    """
    A, b, w = (np.asarray(x, dtype=float) for x in (A, b, w))
    r, r_m = np.asarray(r, dtype=float)[..., None], np.asarray(r_m, dtype=float)[..., None]
    nf, nm = np.linalg.norm(A[..., :3], axis=-1), np.linalg.norm(A[..., 3:], axis=-1)
    slack = b - np.einsum("...ij,...j->...i", A, w) - r * nf - r_m * nm
    norms = np.sqrt(nf**2 + (scale * nm) ** 2)
    live = norms > ZERO_NORMAL
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(live, slack / np.where(live, norms, 1.0), np.where(slack >= 0, np.inf, -np.inf))


def wrench_margin(A: Any, b: Any, w: Any, r: Any, r_m: Any, scale: float) -> FloatArray:
    """``d_k``: the signed distance (scaled units, N) between the uncertainty set and the polytope.

    Examples:
        A box of +-10 N and +-1 N m (L = 0.1 m), a force ball of 2 N around 5 N along x with a
        moment ball of 0.2 N m around 0.3 N m about z: the moment leaves 0.5 N m (5 N scaled),
        the force 3 N, the margin is the smaller:

        >>> import numpy as np
        >>> A = np.vstack([np.eye(6), -np.eye(6)])
        >>> b = np.r_[np.full(3, 10.0), np.full(3, 1.0), np.full(3, 10.0), np.full(3, 1.0)]
        >>> float(wrench_margin(A, b, [5.0, 0, 0, 0, 0, 0.3], 2.0, 0.2, 0.1))
        3.0
    """
    return wrench_signed_distances(A, b, w, r, r_m, scale).min(axis=-1)


def wrench_capacity(A: Any, b: Any, w: Any) -> FloatArray:
    """``|f_k| t*_k`` (N): the polytope's boundary along the desired wrench, in newtons of its
    force (module docstring); the 3-D directional capacity when the moment is zero."""
    A, b, w = (np.asarray(x, dtype=float) for x in (A, b, w))
    norm = np.linalg.norm(w[..., :3], axis=-1, keepdims=True)
    up = np.zeros(w.shape)
    up[..., 2] = 1.0
    u = np.where(norm > 1e-12, w / np.maximum(norm, 1e-12), up)
    proj = np.einsum("...ij,...j->...i", A, u)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(proj > ZERO_NORMAL, b / np.where(proj > ZERO_NORMAL, proj, 1.0), np.inf)
    return ratio.min(axis=-1)


def wrench_cost(A: Any, b: Any, w: Any, r: Any, r_m: Any, scale: float,
                params: CapabilityParameters = CapabilityParameters()) -> float:
    """``J1 = sum_k c_k`` on the wrench margin (exact); ``A, b`` must already carry ``alpha``."""
    d = wrench_margin(A, b, w, r, r_m, scale)
    rho = normalization(np.asarray(w, dtype=float)[..., :3], r, params.eps)
    return float(np.sum(capability_penalty(d, rho, params.kappa, params.max_exponent)))


def trajectory_wrench_margin(robot: MobileManipulator, q: Any, t: Any, force: Any, alpha: float) -> FloatArray:
    """``d_k`` per waypoint of configurations ``q`` for a :class:`~forte.force.taskforce.TaskForce`
    with its moment (``m = 0``, ``r_m = 0``, ``L = 0`` without one: the 3-D metric)."""
    poly = trajectory_wrench_polytope(robot, q, t, alpha)
    return wrench_margin(poly.A, poly.b, force.wrench, force.r, force.r_m, force.moment_scale)


# -- the smooth surrogate ----------------------------------------------------------------------
def smooth_wrench_penalty(A: Any, b: Any, w: Any, r: Any, r_m: Any, scale: float,
                          params: CapabilityParameters = CapabilityParameters()) -> FloatArray:
    """Numeric smooth surrogate of ``c_k`` (the formula of :func:`smooth_wrench_penalty_expr`)."""
    A, b, w = (np.asarray(x, dtype=float) for x in (A, b, w))
    r, r_m = np.asarray(r, dtype=float), np.asarray(r_m, dtype=float)
    nf2, nm2 = np.sum(A[..., :3] ** 2, axis=-1), np.sum(A[..., 3:] ** 2, axis=-1)
    nf, nm = np.sqrt(nf2 + params.eps_normal**2), np.sqrt(nm2 + params.eps_normal**2)
    slack = b - np.einsum("...ij,...j->...i", A, w) - r[..., None] * nf - r_m[..., None] * nm
    d = slack / np.sqrt(nf**2 + scale**2 * nm2)
    x = -d / normalization(w[..., :3], r, params.eps)[..., None] + params.knee / params.beta
    z = params.beta * np.concatenate([np.zeros(x.shape[:-1] + (1,)), x], axis=-1)
    top = z.max(axis=-1, keepdims=True)
    soft = (top[..., 0] + np.log(np.sum(np.exp(z - top), axis=-1))) / params.beta
    return np.expm1(np.minimum(params.kappa * soft, params.max_exponent))


def smooth_wrench_penalty_expr(J6: Any, tau_nom: Any, tau_max: Any, f: Any, m: Any, r: Any, r_m: Any,
                               scale: Any, params: CapabilityParameters = CapabilityParameters()) -> Any:
    """CasADi expression of the smooth wrench penalty at one waypoint.

    Args:
        J6: 6 x n Jacobian ``[J_v; J_w]`` (expression).
        tau_nom: n nominal torques (expression).
        tau_max: n torque limits; the lower limits are ``-tau_max``.
        f: desired force (3).
        m: desired moment (3).
        r: radius of the force ball.
        r_m: radius of the moment ball.
        scale: ``L`` (m).
    """
    a = params.alpha
    Jv, Jw = J6[:3, :], J6[3:, :]
    proj = Jv.T @ f + Jw.T @ m
    nm2 = ca.sum1(Jw**2).T
    nf = ca.sqrt(ca.sum1(Jv**2).T + params.eps_normal**2)
    nm = ca.sqrt(nm2 + params.eps_normal**2)
    norms = ca.sqrt(nf**2 + scale**2 * nm2)
    spread = r * nf + r_m * nm
    d_plus = (a * (tau_max - tau_nom) - proj - spread) / norms
    d_minus = (a * (tau_max + tau_nom) + proj - spread) / norms
    rho = ca.fmax(ca.norm_2(f) + r, params.eps)
    x = -ca.vertcat(d_plus, d_minus) / rho + params.knee / params.beta
    soft = ca.logsumexp(ca.vertcat(0, params.beta * x)) / params.beta
    return ca.exp(ca.fmin(params.kappa * soft, params.max_exponent)) - 1


# -- what the reports and the verdict read ----------------------------------------------------
def requirement_measures(J6: Any, tau_nom: Any, tau_max: Any, force: Any, alpha: float) -> dict[str, FloatArray]:
    """Per sample, for a requirement ``force`` with its moment (``f``, ``m``, ``r``, ``r_m``,
    ``moment_scale``: a :class:`~forte.force.taskforce.TaskForce` or the verdict's sampled force):
    ``d`` (the margin with ``alpha``), ``capacity`` (:func:`wrench_capacity` of the polytope with
    ``alpha = 1``), ``shortfall = |f| + r - capacity`` and ``torque_ratio``
    ``max_i |tau_nom + J6^T w|_i / tau_max,i`` (the torque that moves the arm and applies the wrench)."""
    J6, tau_nom = np.asarray(J6, dtype=float), np.asarray(tau_nom, dtype=float)
    tau_max = np.asarray(tau_max, dtype=float)
    A, b = wrench_halfspaces(J6, *residual_margins(tau_nom, tau_max))
    w = np.hstack([force.f, force.m])
    capacity = wrench_capacity(A, b, w)
    return {"d": wrench_margin(A, alpha * b, w, force.r, force.r_m, force.moment_scale), "capacity": capacity,
            "shortfall": np.linalg.norm(force.f, axis=1) + force.r - capacity,
            "torque_ratio": np.max(np.abs(tau_nom + np.einsum("kij,ki->kj", J6, w)) / tau_max, axis=1)}


def wrench_metrics(robot: MobileManipulator, q: Any, t: Any, force: Any, alpha: float,
                   start: StartMotion | None = None) -> dict[str, FloatArray]:
    """The metrics.csv columns that follow the wrench when the task needs a moment: ``d``,
    ``directional_capacity``, ``capacity_margin`` and ``max_torque_ratio_with_force`` from
    :func:`requirement_measures`, and ``mx, my, mz`` (N m, world frame, at the end effector)."""
    poly = trajectory_wrench_polytope(robot, q, t, alpha=1.0, start=start)
    out = requirement_measures(poly.J6, poly.tau_nom, robot.torque_limits, force, alpha)
    return {"d": out["d"], "directional_capacity": out["capacity"], "capacity_margin": -out["shortfall"],
            "max_torque_ratio_with_force": out["torque_ratio"],
            "mx": force.m[:, 0], "my": force.m[:, 1], "mz": force.m[:, 2]}
