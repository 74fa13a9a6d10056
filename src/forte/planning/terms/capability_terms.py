"""Built-in stage terms: the capability term J1 and the baselines' capability terms, J2, J3.

Each is a frozen dataclass registered in :data:`forte.planning.terms.costs.COST_TERMS`; see that module
for the interface.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, ClassVar

import casadi as ca
import numpy as np

from forte.capability.metrics import inverse_capacity_expr, manipulability_expr, smooth_penalty_expr
from forte.capability.polytope import cone_directions
from forte.model.robot import N_BASE
from forte.planning.terms.costs import (
    CostTerm,
    Stage,
    TermSetting,
    _smooth_min,
    _softplus,
    nonnegative,
    nonnegative_vector,
    positive,
    register_term,
    setting,
)
from forte.settings import CapabilityParameters
from forte.validation import FloatArray

_GT0 = "a finite number > 0"
#: Where J3's quadratic pulls each arm joint (:class:`JointLimits`).
CENTRES = ("range", "nominal")
#: The capability metric's parameters (:class:`~forte.settings.CapabilityParameters`) as the
#: ``capability`` term's settings; every capability-type term (J1, its wrench variant, the
#: baselines') uses them (``settings_of = "capability"``); the legacy key is
#: ``weights: {capability_params: {NAME: value}}``.
CAPABILITY_SETTINGS: tuple[TermSetting, ...] = (
    TermSetting("alpha", None, 0.9, "1", "scale of the residual torque interval", None, "float",
                "0 < alpha <= 1", lambda v: 0 < v <= 1),
    TermSetting("kappa", None, 3.0, "1", "growth rate of the penalty", None, "float", _GT0, positive),
    TermSetting("eps", None, 1e-6, "N", "lower bound of the normalization rho", None, "float", _GT0, positive),
    TermSetting("max_exponent", None, 40.0, "1", "cap on kappa (-d) / rho", None, "float", _GT0, positive),
    TermSetting("beta", None, 50.0, "1", "sharpness of the smooth surrogate (per unit of d / rho)", None, "float",
                _GT0, positive),
    TermSetting("eps_normal", None, 1e-6, "m", "regularization of zero normals in the surrogate", None, "float",
                _GT0, positive),
    TermSetting("knee", None, 3.0, "1", "the surrogate's knee, in units of 1 / beta inside the polytope", None,
                "float", "a finite number >= 0", nonnegative),
)


def capability_params(settings: Any) -> CapabilityParameters:
    """The metric's parameters from ``settings`` (term -> {setting: value}): ``capability``'s."""
    return CapabilityParameters(**Capability.setting_values(settings))


@register_term
@dataclass(frozen=True)
class Capability(CostTerm):
    """J1 (paper, Section 4.2): ``c_k`` of the force ball against the dynamic RFP (smooth surrogate)."""

    name: ClassVar[str] = "capability"
    settings: ClassVar[tuple[TermSetting, ...]] = CAPABILITY_SETTINGS
    params: CapabilityParameters = field(default_factory=CapabilityParameters)

    @classmethod
    def from_settings(cls, settings: Any = None) -> CostTerm:
        return cls(capability_params(settings))

    def stage(self, s: Stage) -> ca.SX:
        return smooth_penalty_expr(s.J, s.tau, ca.DM(s.robot.torque_limits), s.f, s.r, self.params)


@register_term
@dataclass(frozen=True)
class InscribedRadius(CostTerm):
    """RFP-radius baseline (Ferrolho et al. 2021, as the authors run it): ``1 / max(|R_k|, 1e-6)``.

    ``R_k = max(0, min_i min(alpha (tau_max,i - tau_nom,i), alpha (tau_max,i + tau_nom,i)) / ||n_i||)``,
    ``n_i`` the columns of the 3 x n world translational Jacobian: the radius of the largest
    ball centred at the origin inside the alpha-scaled dynamic RFP, clamped at 0; the task force
    is unused (the authors' public code, ``residual_force_polytope``). The minimum is
    smoothed (a lower bound within ``s log(2n) / beta``, ``s = max(|f| + r, eps)``);
    the exact value is :func:`forte.capability.polytope.inscribed_radius` of the alpha-scaled RFP, clamped at 0.
    """

    name: ClassVar[str] = "rfp_radius"
    weight_field: ClassVar[str | None] = "capability"
    settings_of: ClassVar[str | None] = "capability"
    params: CapabilityParameters = field(default_factory=CapabilityParameters)

    @classmethod
    def from_settings(cls, settings: Any = None) -> CostTerm:
        return cls(capability_params(settings))

    def residual(self, s: Stage) -> ca.SX:
        """The nominal torque the margins are taken from (dynamic: the paper's ``tau_nom``)."""
        return s.tau

    def radius(self, s: Stage) -> ca.SX:
        p = self.params
        norms = ca.sqrt(ca.sum1(s.J**2).T + p.eps_normal**2)
        tm, tau = ca.DM(s.robot.torque_limits), self.residual(s)
        dist = p.alpha * ca.vertcat((tm - tau) / norms, (tm + tau) / norms)
        scale = ca.fmax(ca.norm_2(s.f) + s.r, p.eps)
        return ca.fmax(_smooth_min(dist, scale, p.beta), 0)

    def stage(self, s: Stage) -> ca.SX:
        return inverse_capacity_expr(self.radius(s))


@register_term
@dataclass(frozen=True)
class StaticRadius(InscribedRadius):
    """Static force polytope baseline: :class:`InscribedRadius` with the gravity-only residual
    ``tau = g(q_k)`` (no velocity or acceleration terms; the authors' fourth baseline, an
    inscribed radius with a gravity-only residual in their public code)."""

    name: ClassVar[str] = "static_radius"

    def residual(self, s: Stage) -> ca.SX:
        return s.tau_static


@register_term
@dataclass(frozen=True)
class ConeVolume(CostTerm):
    """RFP-cone baseline (Ferrolho et al. 2021, as the authors run it): ``1 / max(|V_k|, 1e-6)``,
    ``V_k = Omega/(3M) sum_j rho_j^3`` (``cone_intersection_volume`` in the authors' public code).

    The authors' rays: the axis along ``f`` (+z where ``f = 0``) plus 4 rings x 12 azimuths at
    ``theta_j = 0.1 j / 4`` (M = 49), each ray's capacity clamped at 0, the margins scaled by
    ``alpha`` as in the radius baseline (the authors pass their ``capability_alpha`` to every ray,
    so their ``V`` is ``alpha^3`` times the unscaled one).

    ``rho_j``, the capacity along ray ``d_j`` of the cone of half-angle ``half_angle`` around the
    desired force (``rings x azimuths`` rays plus the axis, an NLP parameter per waypoint), is the
    smoothed minimum of ``b_i / (a_i . d_j)`` over rows with ``a_i . d_j > 0``; the row selection
    uses a softplus of ``a_i . d_j`` so rows pointing away give huge ratios that the soft minimum
    ignores; ``Omega = 2 pi (1 - cos half_angle)``.

    The sum over rays is one CasADi function mapped over the rays (:meth:`ray_sum`), kept as a
    call in the stage expression: the compiled kernels hold the per-ray code (and its
    derivatives) once, in a loop, instead of 49 unrolled copies (24 MB of C, over a minute of
    compilation, before). :meth:`ray_sum_unrolled` is the same sum written out, for tests.
    """

    name: ClassVar[str] = "rfp_cone"
    weight_field: ClassVar[str | None] = "capability"
    settings_of: ClassVar[str | None] = "capability"
    params: CapabilityParameters = field(default_factory=CapabilityParameters)
    half_angle: float = 0.1
    rings: int = 4
    azimuths: int = 12

    @classmethod
    def from_settings(cls, settings: Any = None) -> CostTerm:
        return cls(capability_params(settings))

    @property
    def rays(self) -> int:
        return 1 + self.rings * self.azimuths

    @property
    def parameters(self) -> tuple[tuple[str, int], ...]:  # type: ignore[override]
        return (("rays", 3 * self.rays),)

    def stage(self, s: Stage) -> ca.SX:
        tm = ca.DM(s.robot.torque_limits)
        b = self.params.alpha * ca.vertcat(tm - s.tau, tm + s.tau)
        scale = ca.fmax(ca.norm_2(s.f) + s.r, self.params.eps)
        rays = ca.reshape(s.parameters["rays"], self.rays, 3).T  # 3 x M, one ray per column
        total = self.ray_sum(s.robot.n_arm)(s.J, b, rays, scale)
        omega = 2 * np.pi * (1 - np.cos(self.half_angle))
        return inverse_capacity_expr(omega / (3 * self.rays) * total)

    def ray_cube(self, J: Any, b: Any, d: Any, scale: Any) -> Any:
        """``max(rho, 0)^3`` of one ray ``d``: ``rho`` the smoothed minimum of ``b_i / (a_i . d)``
        over the rows ``a_i`` of ``A = [J^T; -J^T]``."""
        sharp = 1e-3  # softplus width of a_i . d (m)
        a = J.T @ d
        pos = sharp * _softplus(ca.vertcat(a, -a) / sharp)
        rho = _smooth_min(b / (pos + 1e-9), scale, self.params.beta)
        return ca.fmax(rho, 0) ** 3

    def ray_sum(self, n_arm: int) -> ca.Function:
        """``(J, b, D, scale) -> sum_j max(rho_j, 0)^3`` over the columns ``d_j`` of ``D`` (3 x M):
        :meth:`ray_cube` as one function mapped over the rays, never inlined into the caller."""
        J, b, d, scale = ca.SX.sym("J", 3, n_arm), ca.SX.sym("b", 2 * n_arm), ca.SX.sym("d", 3), ca.SX.sym("s")
        ray = ca.Function("cone_ray", [J, b, d, scale], [self.ray_cube(J, b, d, scale)])
        args = [ca.MX.sym("J", 3, n_arm), ca.MX.sym("b", 2 * n_arm), ca.MX.sym("D", 3, self.rays), ca.MX.sym("s")]
        total = ca.sum2(ray.map(self.rays, "serial")(*args))
        return ca.Function("cone_ray_sum", args, [total], {"never_inline": True})

    def ray_sum_unrolled(self, J: Any, b: Any, D: Any, scale: Any) -> Any:
        """The sum of :meth:`ray_sum` written out ray by ray (reference for tests)."""
        return sum(self.ray_cube(J, b, D[:, j], scale) for j in range(self.rays))

    def parameter_values(self, name: str, f: FloatArray, r: FloatArray) -> FloatArray:
        """The rays around each desired force (straight up where it vanishes), column-major M x 3."""
        out = []
        for fk in np.asarray(f, dtype=float):
            u = fk if np.linalg.norm(fk) > 1e-9 else np.array([0.0, 0.0, 1.0])
            out.append(cone_directions(u, self.half_angle, self.rings, self.azimuths).ravel(order="F"))
        return np.concatenate(out)


@register_term
@dataclass(frozen=True)
class Manipulability(CostTerm):
    """J2: ``1 / max(mu_k, eps_m)``, ``mu_k = sqrt(det(J J^T + lambda I_3))``.

    ``J`` is the 3 x n world translational arm Jacobian (the paper's text, default) or, with
    ``with_yaw``, the 3 x (1 + n) Jacobian with the base-yaw column
    ``d p / d yaw = (-(p_y - y), p_x - x, 0)`` first (the authors' code).
    """

    name: ClassVar[str] = "manipulability"
    lam: float = setting(1e-6, "m^2", "lambda of the regularized manipulability", expected=_GT0, valid=positive,
                         legacy="manipulability_lambda", name="lambda")
    eps: float = setting(1e-8, "m^3", "eps_m in 1 / max(mu, eps_m)", expected=_GT0, valid=positive,
                         legacy="manipulability_eps")
    with_yaw: bool = setting(False, "", "mu from the 3 x (1 + n) Jacobian with the base-yaw column (the authors' "
                             "code) instead of the 3 x n arm Jacobian (the paper's text)", kind="bool",
                             expected="true or false", valid=None, legacy="manipulability_yaw")

    def stage(self, s: Stage) -> ca.SX:
        J = s.J
        if self.with_yaw:
            _, p = s.twin.ee_pose(s.q0)
            J = ca.horzcat(ca.vertcat(-(p[1] - s.q0[1]), p[0] - s.q0[0], 0), J)
        return 1 / ca.fmax(manipulability_expr(J, self.lam), self.eps)


#: The authors' trajectory DoF weights of J3 over (x, y, yaw, q1..q7).
AUTHORS_DOF = (0.0, 0.2, 0.1, 1.0, 0.0, 0.1, 0.2, 0.1, 0.0, 0.0)


@register_term
@dataclass(frozen=True)
class JointLimits(CostTerm):
    """J3: ``sum_i w_i (e_i^2 + v_i^4)`` over the arm, ``+ sum_b w_b (q_b - q_nom,b)^2`` over the base.

    ``e_i = (q_i - c_i)/h_i``, ``v_i = max(0, (|q_i - mid_i| - h_i)/delta_i)``,
    ``h_i = max(eps_h, range_i/2 - delta_i)``; ``delta_i = margin_fraction * range_i`` (the
    authors: 5 %) or ``margin`` for every joint; ``w`` the per-DoF weights over
    (x, y, yaw, q1..q7) (the authors': [0,2,1,10,0,1,2,1,0,0]/10), default 1 per arm joint and
    0 for the base. The base has no limits: its entries pull it toward the nominal trajectory.

    The quadratic's centre ``c_i`` (``centre``): ``range``, the paper's ``mid_i``; ``nominal``,
    the task's nominal trajectory ``q_nom,k`` (its own start posture carried along the path, or
    its taught configurations); ``null`` (default): ``range`` where the per-DoF list is made for
    the arm (the authors' Panda list on the Panda, or no list), ``nominal`` where it is not.
    Why: the list and the centres are the authors' tuning for their Panda; on another arm a
    range's middle need not be a posture at all (the Kinova's joints 2-3 at mid: the arm
    straight up, elbow straight, singular), and pulling there from the user's start posture
    makes the plan race across the range. The barrier ``v_i`` always keeps the range's limits.
    """

    name: ClassVar[str] = "joint_limits"
    margin: float = setting(0.1, "rad", "delta_i for every joint, used when margin_fraction is null",
                            expected=_GT0, valid=positive, legacy="joint_margin")
    eps: float = setting(1e-3, "rad", "eps_h, the least half-width h_i", expected=_GT0, valid=positive,
                         legacy="joint_eps")
    margin_fraction: float | None = setting(
        0.05, "1", "delta_i = fraction * (q_max,i - q_min,i) (the authors: 0.05); null: margin",
        kind="float | None", expected="0 < fraction < 0.5", valid=lambda v: 0 < v < 0.5,
        legacy="joint_margin_fraction")
    dof_weights: tuple[float, ...] | None = setting(
        AUTHORS_DOF, "1", "per-DoF weights over (x, y, yaw, arm joints); null: 1 per arm joint, 0 base",
        kind="vector | None", expected="finite numbers >= 0", valid=nonnegative_vector(None),
        legacy="joint_dof_weights")
    centre: str | None = setting(
        None, "", "the quadratic's centre: range (the paper's mid), nominal (the task's own posture); "
        "null: range where dof_weights fits the arm, else nominal", kind="str | None",
        expected=f"one of {', '.join(CENTRES)} or null", valid=lambda v: v in CENTRES)

    def weights_for(self, n_arm: int) -> FloatArray:
        """Per-DoF weights (base 3, then arm). A list made for an arm of another size (the weight
        sets' and the methods' lists are the Panda's: 3 + 7) keeps its base entries and gives
        every arm joint 1, the default; a task's own list of the wrong size is refused when the
        task is read (:func:`forte.planning.tasks.tasks.task_from_dict`)."""
        if self.dof_weights is None:
            return np.r_[np.zeros(N_BASE), np.ones(n_arm)]
        w = np.asarray(self.dof_weights, dtype=float)
        if w.shape != (N_BASE + n_arm,):
            return np.r_[w[:N_BASE], np.ones(n_arm)]
        return w

    def centre_for(self, n_arm: int) -> str:
        """The quadratic's centre on an arm of ``n_arm`` joints (``centre``, resolved when null)."""
        if self.centre is not None:
            return self.centre
        fits = self.dof_weights is None or len(self.dof_weights) == N_BASE + n_arm
        return "range" if fits else "nominal"

    def stage(self, s: Stage) -> ca.SX:
        robot = s.robot
        delta = self.margins(robot.lower, robot.upper)
        mid, half = joint_limit_geometry(robot.lower, robot.upper, delta, self.eps)
        w = self.weights_for(robot.n_arm)
        dev = s.q0[N_BASE:] - ca.DM(mid)
        centre = self.centre_for(robot.n_arm)
        e = (dev if centre == "range" or s.nominal is None else s.q0[N_BASE:] - s.nominal[N_BASE:]) / ca.DM(half)
        v = ca.fmax(0, (ca.fabs(dev) - ca.DM(half)) / ca.DM(delta))
        cost = ca.dot(ca.DM(w[N_BASE:]), e**2 + v**4)
        if np.any(w[:N_BASE]) and s.nominal is not None:
            cost += ca.dot(ca.DM(w[:N_BASE]), (s.q0[:N_BASE] - s.nominal[:N_BASE]) ** 2)
        return cost

    def margins(self, lower: FloatArray, upper: FloatArray) -> FloatArray:
        """``delta_i`` per arm joint."""
        span = np.asarray(upper, dtype=float) - np.asarray(lower, dtype=float)
        return span * self.margin_fraction if self.margin_fraction is not None else np.full(span.shape, self.margin)


def joint_limit_geometry(lower: FloatArray, upper: FloatArray, margin: Any,
                         eps: float) -> tuple[FloatArray, FloatArray]:
    """Joint centres and safe half-widths ``h_i = max(eps_h, (max - min)/2 - delta)``."""
    mid = (np.asarray(upper) + np.asarray(lower)) / 2
    half = np.maximum(eps, (np.asarray(upper) - np.asarray(lower)) / 2 - margin)
    return mid, half


