"""Force-capability metric (paper, Section 4.2) and manipulability (Section 4.3).

Exact metric, per waypoint ``k`` and arm joint ``i`` with normal ``n_i = j_i`` (column i of
``J_t``)::

    d+_i = (alpha tau+_i - n_i^T f) / ||n_i|| - r,      d-_i = (-alpha tau-_i + n_i^T f) / ||n_i|| - r
    d_k  = min_i min(d+_i, d-_i)
    rho_k = max(||f|| + r, eps)
    c_k  = 0 if d_k >= 0 else exp(kappa (-d_k) / rho_k) - 1,        J1 = sum_k c_k

In half-space form both signed distances are ``(b_i - a_i^T f) / ||a_i|| - r``.

Two guards change nothing where the formula is defined: a zero normal gives ``+inf`` (the row
never binds) or ``-inf`` (the polytope is empty), and the exponent is capped at
``max_exponent`` (40) so the penalty stays finite.

**Smooth surrogate** (for IPOPT, which stalls on the hard ``min`` and on the kink at ``d = 0``
whenever the capability term is active at the optimum). With ``x_i = -d_i / rho`` the
normalized violations, the exact exponent ``kappa max(0, max_i x_i)`` is replaced by the log-sum-exp

    s_beta = (1/beta) log(1 + sum_i exp(beta x_i + knee))

which bounds ``max(0, max_i x_i)`` from above by at most ``(log(1 + 2n) + knee) / beta`` and
converges to it as ``beta -> inf`` (``knee`` fixed); zero normals use ``sqrt(||n||^2 + eps_n^2)``.
Reports always use the exact metric.

The ``knee`` (3 by default) moves the smoothing band to ``d > 0``. With a single binding facet the
exponent's slope at ``d = 0`` is ``sigmoid(knee)`` (95 %) of the exact ``kappa / rho``. Where the
exact J1 stops on the ball's edge because another term pulls outward with less than the kink's
slope, the surrogate stops inside the polytope, within ``(knee + 1) rho / beta``; a centred
surrogate (``knee = 0``, half the slope at ``d = 0``) stops outside whenever that pull exceeds
half the kink's slope. Both are tested against the exact penalty.
"""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np

from forte.capability.polytope import ZERO_NORMAL, trajectory_rfp
from forte.settings import CapabilityParameters
from forte.validation import FloatArray


# -- exact metric (numpy, vectorized over waypoints) --------------------------------------
def signed_distances(A: Any, b: Any, f: Any, r: Any) -> FloatArray:
    """Per-half-space signed distances ``(b_i - a_i^T f)/||a_i|| - r`` (... x 2n)."""
    A = np.asarray(A, dtype=float)
    b = np.asarray(b, dtype=float)
    f = np.asarray(f, dtype=float)
    r = np.asarray(r, dtype=float)
    norms = np.linalg.norm(A, axis=-1)
    slack = b - np.einsum("...ij,...j->...i", A, f)
    live = norms > ZERO_NORMAL
    with np.errstate(divide="ignore", invalid="ignore"):
        dist = np.where(live, slack / np.where(live, norms, 1.0),
                        np.where(b >= 0, np.inf, -np.inf))
    return dist - r[..., None]


def capability_margin(A: Any, b: Any, f: Any, r: Any) -> FloatArray:
    """``d_k``: the minimum signed distance between the force ball and the RFP ``{f : A f <= b}``.

    Examples:
        A box of +-10 N, a ball of radius 2 N around 5 N along x: 3 N of margin left:

        >>> import numpy as np, forte
        >>> A = np.vstack([np.eye(3), -np.eye(3)])
        >>> float(forte.capability_margin(A, np.full(6, 10.0), [5.0, 0.0, 0.0], 2.0))
        3.0
    """
    return signed_distances(A, b, f, r).min(axis=-1)


def normalization(f: Any, r: Any, eps: float = 1e-6) -> FloatArray:
    """``rho_k = max(||f_k|| + r_k, eps)``."""
    return np.maximum(np.linalg.norm(np.asarray(f, dtype=float), axis=-1) + np.asarray(r), eps)


def capability_penalty(d: Any, rho: Any, kappa: float = 3.0, max_exponent: float = 40.0) -> FloatArray:
    """``c_k = 0`` for ``d_k >= 0``, else ``exp(min(kappa (-d_k)/rho_k, max_exponent)) - 1``."""
    d = np.asarray(d, dtype=float)
    exponent = np.minimum(kappa * np.maximum(-d, 0.0) / np.asarray(rho, dtype=float), max_exponent)
    return np.where(d >= 0, 0.0, np.expm1(exponent))


def capability_cost(
    A: Any, b: Any, f: Any, r: Any, params: CapabilityParameters = CapabilityParameters()
) -> float:
    """``J1 = sum_k c_k`` (exact). ``A, b`` must already carry ``alpha``."""
    d = capability_margin(A, b, f, r)
    rho = normalization(f, r, params.eps)
    return float(np.sum(capability_penalty(d, rho, params.kappa, params.max_exponent)))


def smooth_capability_penalty(
    A: Any, b: Any, f: Any, r: Any, params: CapabilityParameters = CapabilityParameters()
) -> FloatArray:
    """Numeric smooth surrogate of ``c_k`` (the same formula as :func:`smooth_penalty_expr`)."""
    A = np.asarray(A, dtype=float)
    b = np.asarray(b, dtype=float)
    f = np.asarray(f, dtype=float)
    r = np.asarray(r, dtype=float)
    norms = np.sqrt(np.sum(A**2, axis=-1) + params.eps_normal**2)
    d = (b - np.einsum("...ij,...j->...i", A, f)) / norms - r[..., None]
    x = -d / normalization(f, r, params.eps)[..., None] + params.knee / params.beta
    z = params.beta * np.concatenate([np.zeros(x.shape[:-1] + (1,)), x], axis=-1)
    top = z.max(axis=-1, keepdims=True)
    soft = (top[..., 0] + np.log(np.sum(np.exp(z - top), axis=-1))) / params.beta
    return np.expm1(np.minimum(params.kappa * soft, params.max_exponent))


# -- smooth surrogate (CasADi, one waypoint) -------------------------------------------------
def smooth_penalty_expr(
    J: Any, tau_nom: Any, tau_max: Any, f: Any, r: Any,
    params: CapabilityParameters = CapabilityParameters(),
) -> Any:
    """CasADi expression of the smooth penalty at one waypoint.

    Args:
        J: 3 x n translational Jacobian (expression).
        tau_nom: n nominal torques (expression).
        tau_max: n torque limits (numbers or expression); the lower limits are ``-tau_max``.
        f: 3 desired force; r: radius (numbers or expressions).
    """
    a = params.alpha
    proj = J.T @ f  # n_i^T f
    norms = ca.sqrt(ca.sum1(J**2).T + params.eps_normal**2)
    d_plus = (a * (tau_max - tau_nom) - proj) / norms - r
    d_minus = (a * (tau_max + tau_nom) + proj) / norms - r  # -alpha tau- = alpha (tau_max + tau_nom)
    rho = ca.fmax(ca.norm_2(f) + r, params.eps)
    x = -ca.vertcat(d_plus, d_minus) / rho + params.knee / params.beta
    soft = ca.logsumexp(ca.vertcat(0, params.beta * x)) / params.beta
    return ca.exp(ca.fmin(params.kappa * soft, params.max_exponent)) - 1


def inverse_capacity_expr(value: Any, eps: float = 1e-6) -> Any:
    """Baseline cost term ``1 / max(|value|, eps)`` (RFP radius and cone baselines).

    The absolute value is the authors' implementation (their public code). It makes the
    term *decrease* again when the value turns negative (origin outside the RFP), so a baseline
    started where the value is negative can be pushed further out; kept as written for fidelity.
    """
    return 1 / ca.fmax(ca.fabs(value), eps)


# -- manipulability ----------------------------------------------------------------------
def manipulability(J: Any, lam: float = 1e-6) -> FloatArray:
    """Regularized translational manipulability ``mu = sqrt(det(J J^T + lam I_3))``."""
    J = np.asarray(J, dtype=float)
    return np.sqrt(np.linalg.det(J @ np.swapaxes(J, -1, -2) + lam * np.eye(J.shape[-2])))


def yoshikawa(J: Any) -> FloatArray:
    """Yoshikawa's measure ``sqrt(det(J J^T))``."""
    J = np.asarray(J, dtype=float)
    return np.sqrt(np.maximum(np.linalg.det(J @ np.swapaxes(J, -1, -2)), 0.0))


def min_margin(robot: Any, q: Any, t: Any, f: Any, r: Any, alpha: float) -> float:
    """``min_k d_k``: the exact capability margin of the configurations ``q`` (N x nq) at the times
    ``t``, the force ball (``f``, ``r``) against the alpha-scaled dynamic RFP of every waypoint."""
    rfp = trajectory_rfp(robot, q, t, alpha=alpha)
    return float(np.min(capability_margin(rfp.A, rfp.b, np.asarray(f, dtype=float), np.asarray(r, dtype=float))))


def ellipsoid_axes(J: Any) -> tuple[FloatArray, FloatArray]:
    """Velocity-manipulability ellipsoid ``{J qd : ||qd|| <= 1}`` of one Jacobian.

    Returns:
        ``(lengths, directions)``: semi-axis lengths (singular values, descending) and the unit
        axis directions as the columns of a 3 x 3 matrix.
    """
    U, s, _ = np.linalg.svd(np.asarray(J, dtype=float))
    return s, U


def manipulability_expr(J: Any, lam: float = 1e-6) -> Any:
    """CasADi expression of the regularized manipulability."""
    return ca.sqrt(ca.det(J @ J.T + lam * ca.DM.eye(3)))
