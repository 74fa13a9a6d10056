"""Cost terms of the whole-body NLP (paper, Section 4.3) as CasADi functions, one per concept.

Per-waypoint terms are ``casadi.Function`` objects of the *stage* ``(q_{k-2}, q_{k-1}, q_k)`` so
the optimizer can ``map`` them over the horizon; the backward differences of the paper need the
two previous configurations. The first samples start at rest: the optimizer pads the trajectory
with two copies of ``q_1``, which makes ``dq_1 = ddq_1 = 0`` and ``dq_1 = 0`` inside ``ddq_2``.

- :func:`capability_stage`: ``c_k`` of J1 (smooth surrogate, :mod:`forte.capability.metrics`);
- :func:`inscribed_radius_stage`, :func:`cone_stage`: capability terms of the RFP baselines,
  ``1 / max(|value|, eps)``;
- :func:`manipulability_stage`: ``1 / max(mu_k, eps_m)`` of J2;
- :func:`joint_limit_stage`: ``sum_i e_i^2 + v_i^4`` of J3;
- :func:`smoothness_weights` and :func:`dct_penalty_matrix`: the quadratic J4 and J5.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from forte.capability.metrics import (
    CapabilityParameters,
    inverse_capacity_expr,
    manipulability_expr,
    smooth_penalty_expr,
)
from forte.exceptions import InvalidInputError
from forte.model.robot import N_BASE
from forte.model.twin import CasadiTwin
from forte.validation import FloatArray

N_CONE_RAYS = 25


@dataclass(frozen=True)
class CostWeights:
    """Weights ``w_1..w_5`` and the parameters of each term (defaults: the authors').

    Attributes:
        capability, manipulability, joint_limits, smoothness, base_spectral: ``w_1..w_5``.
        manipulability_lambda: ``lambda`` of the regularized manipulability.
        manipulability_eps: ``eps_m`` in ``1 / max(mu, eps_m)``.
        joint_margin: ``delta_i`` (rad), the safety margin of J3 (one value for every joint).
        joint_eps: ``eps_h``.
        smoothness_base, smoothness_arm: diagonal of ``W_s`` for (x, y, yaw) and the arm joints.
        dct_cutoff: frequencies ``l >= ceil(cutoff N)`` form the high-frequency set ``H``.
        dct_axis: ``eta_xi`` for x, y, yaw.
        dct_power: ``gamma_l = (l / (N - 1)) ** power`` (0: every high frequency weighs 1).
    """

    capability: float = 5.0
    manipulability: float = 2.0
    joint_limits: float = 3.0
    smoothness: float = 10.0
    base_spectral: float = 1.0
    manipulability_lambda: float = 1e-6
    manipulability_eps: float = 1e-4
    joint_margin: float = 0.1
    joint_eps: float = 1e-3
    smoothness_base: tuple[float, float, float] = (1.0, 1.0, 0.5)
    smoothness_arm: float = 1.0
    dct_cutoff: float = 0.35
    dct_axis: tuple[float, float, float] = (1.0, 1.0, 0.5)
    dct_power: float = 0.0
    capability_params: CapabilityParameters = field(default_factory=CapabilityParameters)

    def __post_init__(self) -> None:
        for name in ("capability", "manipulability", "joint_limits", "smoothness", "base_spectral", "dct_power"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value >= 0):
                raise InvalidInputError(f"{name}: expected a finite number >= 0, got {value}")
        for name in ("manipulability_lambda", "manipulability_eps", "joint_margin", "joint_eps", "smoothness_arm"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise InvalidInputError(f"{name}: expected a finite number > 0, got {value}")
        if not 0.0 < self.dct_cutoff < 1.0:
            raise InvalidInputError(f"dct_cutoff: expected 0 < cutoff < 1, got {self.dct_cutoff}")
        for name in ("smoothness_base", "dct_axis"):
            values = np.asarray(getattr(self, name), dtype=float)
            if values.shape != (3,) or not np.all(np.isfinite(values) & (values >= 0)):
                raise InvalidInputError(f"{name}: expected 3 finite numbers >= 0, got {getattr(self, name)}")


def _stage_symbols(nq: int) -> tuple[ca.SX, ca.SX, ca.SX, ca.SX, ca.SX]:
    return (ca.SX.sym("q_prev2", nq), ca.SX.sym("q_prev", nq), ca.SX.sym("q", nq),
            ca.SX.sym("dt_prev"), ca.SX.sym("dt"))


def stage_dynamics(twin: CasadiTwin, q2: ca.SX, q1: ca.SX, q0: ca.SX, dt1: ca.SX, dt0: ca.SX) -> ca.SX:
    """Nominal arm torque at ``q0`` with the paper's backward differences."""
    dq0 = (q0[N_BASE:] - q1[N_BASE:]) / dt0
    dq1 = (q1[N_BASE:] - q2[N_BASE:]) / dt1
    return twin.rnea(q0[N_BASE:], dq0, (dq0 - dq1) / dt0)


def capability_stage(twin: CasadiTwin, tau_max: FloatArray, params: CapabilityParameters) -> ca.Function:
    """``c_k(q_{k-2}, q_{k-1}, q_k, dt_{k-1}, dt_k, f_k, r_k)``: smooth capability penalty."""
    q2, q1, q0, dt1, dt0 = _stage_symbols(twin.robot.nq)
    f, r = ca.SX.sym("f", 3), ca.SX.sym("r")
    tau = stage_dynamics(twin, q2, q1, q0, dt1, dt0)
    c = smooth_penalty_expr(twin.arm_jacobian(q0), tau, ca.DM(tau_max), f, r, params)
    return ca.Function("capability", [q2, q1, q0, dt1, dt0, f, r], [c])


def _softplus(x: ca.SX) -> ca.SX:
    """``log(1 + exp(x))`` without overflow."""
    return ca.fmax(x, 0) + ca.log1p(ca.exp(-ca.fabs(x)))


def _smooth_min(values: ca.SX, scale: ca.SX, beta: float) -> ca.SX:
    """``-(s/beta) log sum exp(-beta v_i / s)``: a lower bound of ``min v`` within s log(n)/beta."""
    return -scale / beta * ca.logsumexp(-beta * values / scale)


def inscribed_radius_stage(twin: CasadiTwin, tau_max: FloatArray, params: CapabilityParameters) -> ca.Function:
    """RFP-radius baseline: ``1 / max(|R_k|, eps)`` with ``R_k = min_i b_i / ||a_i||`` (smoothed)."""
    q2, q1, q0, dt1, dt0 = _stage_symbols(twin.robot.nq)
    f, r = ca.SX.sym("f", 3), ca.SX.sym("r")
    tau = stage_dynamics(twin, q2, q1, q0, dt1, dt0)
    J = twin.arm_jacobian(q0)
    norms = ca.sqrt(ca.sum1(J**2).T + params.eps_normal**2)
    tm = ca.DM(tau_max)
    dist = ca.vertcat((tm - tau) / norms, (tm + tau) / norms)
    scale = ca.fmax(ca.norm_2(f) + r, params.eps)
    radius = _smooth_min(dist, scale, params.beta)
    return ca.Function("rfp_radius", [q2, q1, q0, dt1, dt0, f, r], [inverse_capacity_expr(radius)])


def cone_stage(twin: CasadiTwin, tau_max: FloatArray, params: CapabilityParameters,
               half_angle: float = 0.35) -> ca.Function:
    """RFP-cone baseline: ``1 / max(|V_k|, eps)``, ``V_k = Omega/(3M) sum_j rho_j^3``.

    ``rho_j``, the capacity along ray ``d_j``, is the smoothed minimum of ``b_i / (a_i . d_j)``
    over rows with ``a_i . d_j > 0``; the row selection uses a softplus of ``a_i . d_j`` so rows
    pointing away give huge ratios that the soft minimum ignores. The rays (M x 3) are inputs.
    """
    q2, q1, q0, dt1, dt0 = _stage_symbols(twin.robot.nq)
    f, r = ca.SX.sym("f", 3), ca.SX.sym("r")
    rays = ca.SX.sym("rays", N_CONE_RAYS, 3)
    tau = stage_dynamics(twin, q2, q1, q0, dt1, dt0)
    J = twin.arm_jacobian(q0)
    tm = ca.DM(tau_max)
    A = ca.vertcat(J.T, -J.T)
    b = ca.vertcat(tm - tau, tm + tau)
    scale = ca.fmax(ca.norm_2(f) + r, params.eps)
    total = 0
    sharp = 1e-3  # softplus width of a_i . d (m)
    for j in range(N_CONE_RAYS):
        proj = A @ rays[j, :].T
        pos = sharp * _softplus(proj / sharp)
        rho = _smooth_min(b / (pos + 1e-9), scale, params.beta)
        total += ca.fmax(rho, 0) ** 3
    omega = 2 * np.pi * (1 - np.cos(half_angle))
    volume = omega / (3 * N_CONE_RAYS) * total
    return ca.Function("rfp_cone", [q2, q1, q0, dt1, dt0, f, r, rays], [inverse_capacity_expr(volume)])


def manipulability_stage(twin: CasadiTwin, weights: CostWeights) -> ca.Function:
    """``1 / max(mu(q_k), eps_m)`` with the regularized translational manipulability."""
    q = ca.SX.sym("q", twin.robot.nq)
    mu = manipulability_expr(twin.arm_jacobian(q), weights.manipulability_lambda)
    return ca.Function("manipulability", [q], [1 / ca.fmax(mu, weights.manipulability_eps)])


def joint_limit_stage(lower: FloatArray, upper: FloatArray, weights: CostWeights) -> ca.Function:
    """``sum_i e_i^2 + v_i^4`` with ``e_i = (q_i - mid_i)/h_i``, ``v_i = max(0, (|q_i - mid_i| - h_i)/delta)``."""
    q = ca.SX.sym("q", len(lower) + N_BASE)
    mid, half = joint_limit_geometry(lower, upper, weights)
    dev = q[N_BASE:] - ca.DM(mid)
    e = dev / ca.DM(half)
    v = ca.fmax(0, (ca.fabs(dev) - ca.DM(half)) / weights.joint_margin)
    return ca.Function("joint_limits", [q], [ca.sumsqr(e) + ca.sum1(v**4)])


def joint_limit_geometry(lower: FloatArray, upper: FloatArray, weights: CostWeights) -> tuple[FloatArray, FloatArray]:
    """Joint centres and safe half-widths ``h_i = max(eps_h, (max - min)/2 - delta)``."""
    mid = (np.asarray(upper) + np.asarray(lower)) / 2
    half = np.maximum(weights.joint_eps, (np.asarray(upper) - np.asarray(lower)) / 2 - weights.joint_margin)
    return mid, half


def smoothness_weights(n_arm: int, weights: CostWeights) -> FloatArray:
    """Diagonal of ``W_s`` (base x, y, yaw, then the arm joints)."""
    return np.concatenate([weights.smoothness_base, np.full(n_arm, weights.smoothness_arm)])


def dct_matrix(n: int) -> FloatArray:
    """Orthonormal DCT-II matrix ``C`` (``C @ x`` equals ``scipy.fft.dct(x, norm='ortho')``)."""
    k = np.arange(n)[:, None]
    i = np.arange(n)[None, :]
    C = np.cos(np.pi * (2 * i + 1) * k / (2 * n)) * np.sqrt(2.0 / n)
    C[0] /= np.sqrt(2.0)
    return C


def high_frequencies(n: int, cutoff: float) -> FloatArray:
    """Indices ``l`` of the high-frequency set ``H = {l : l >= ceil(cutoff n)}`` (never l = 0)."""
    return np.arange(max(1, int(np.ceil(cutoff * n))), n)


def dct_penalty_matrix(n: int, weights: CostWeights) -> FloatArray:
    """``P`` with ``b^T P b = sum_{l in H} gamma_l bhat_l^2`` for one base coordinate."""
    C = dct_matrix(n)
    H = high_frequencies(n, weights.dct_cutoff)
    if H.size == 0:
        return np.zeros((n, n))
    gamma = (H / max(n - 1, 1)) ** weights.dct_power
    CH = C[H]
    return CH.T @ (gamma[:, None] * CH)


def base_spectral_cost(base: FloatArray, weights: CostWeights) -> float:
    """Numeric J5 = 1/2 sum_xi eta_xi sum_{l in H} gamma_l bhat_{xi,l}^2 for base (N x 3)."""
    base = np.asarray(base, dtype=float)
    P = dct_penalty_matrix(base.shape[0], weights)
    return 0.5 * float(sum(eta * base[:, i] @ P @ base[:, i] for i, eta in enumerate(weights.dct_axis)))


def smoothness_cost(q: FloatArray, weights: CostWeights) -> float:
    """Numeric J4 = sum_k 1/2 ||W_s (q_k - q_{k-1})||^2."""
    q = np.asarray(q, dtype=float)
    W = smoothness_weights(q.shape[1] - N_BASE, weights)
    return 0.5 * float(np.sum((np.diff(q, axis=0) * W) ** 2))
