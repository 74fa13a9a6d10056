"""Cost terms of the whole-body NLP (paper, Section 4.3): one small class per term, in a registry.

The objective is ``J = sum_i w_i J_i``. A term is one of two kinds:

- a **stage term** ``J_i = sum_k c_i(q_{k-2}, q_{k-1}, q_k, dt_{k-1}, dt_k, f_k, r_k, ...)``: its
  per-waypoint expression is compiled into the optimizer's kernels (so everything it bakes in
  is part of the kernel cache key, see :meth:`CostTerm.baked`) and mapped over the horizon. The
  backward differences of the paper need the two previous configurations; the first samples
  start at rest (the optimizer pads the trajectory with two copies of ``q_1``);
- a **quadratic term** ``J_i = x^T Q_i x / 2`` over ``x = vec(q_1..q_N)`` (J4, J5): a constant
  sparse matrix, assembled once per horizon.

Built-in terms (``name``: weight field of :class:`~forte.settings.CostWeights`):

- ``capability`` (w1): ``c_k`` of J1, the smooth surrogate of :mod:`forte.capability.metrics`;
- ``rfp_radius``, ``rfp_cone``, ``static_radius`` (w1 of the baselines): ``1 / max(|value|, eps)``
  of the centred inscribed radius, the cone measure, or the radius with a gravity-only residual;
- ``manipulability`` (w2): ``1 / max(mu_k, eps_m)``;
- ``joint_limits`` (w3): ``sum_i w_i (e_i^2 + v_i^4)`` (arm), ``w_i (q_i - q_nom,i)^2`` (base);
- ``smoothness`` / ``base_smoothness`` (w4): ``sum_k 1/2 ||W_s (q_k - q_{k-1})||^2`` over the arm /
  the base coordinates;
- ``base_spectral`` (w5): ``1/2 sum_xi eta_xi sum_{l in H} gamma_l bhat_{xi,l}^2``;
- ``velocity`` / ``base_velocity``: ``1/2 ||q_k - q_{k-1}||^2 / dt_k^2`` over the arm / the base;
- ``nominal``: ``1/2 ||q_a,k - q_a,nom,k||^2`` (the task's nominal trajectory);
- ``collision``: spheres on the arm against the base box and the floor.

The terms beyond the paper's J1..J5 (velocity, nominal, collision, the per-DoF joint weights,
the ramped spectral weights) are the authors' (``AUTHORS_SETUP.md``, "Metric and costs").

A new term is a subclass registered with :func:`register_term`; a method
(:mod:`forte.planning.methods`) lists the terms it uses by name.
"""

from __future__ import annotations

import dataclasses
import hashlib
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any, ClassVar

import casadi as ca
import numpy as np
from scipy import sparse

from forte.capability.metrics import inverse_capacity_expr, manipulability_expr, smooth_penalty_expr
from forte.capability.polytope import cone_directions
from forte.exceptions import InvalidInputError
from forte.model.robot import N_BASE, MobileManipulator
from forte.model.twin import CasadiTwin
from forte.settings import CapabilityParameters, CostWeights
from forte.validation import FloatArray


@dataclass
class Stage:
    """The symbols of one waypoint's stage and the quantities several terms share.

    Attributes:
        twin: CasADi kinematics and dynamics of the robot.
        q2, q1, q0: ``q_{k-2}``, ``q_{k-1}``, ``q_k`` (whole body).
        dt1, dt0: ``dt_{k-1}``, ``dt_k``.
        f, r: desired force (3) and uncertainty radius at waypoint k.
        parameters: further per-waypoint parameters declared by terms (name -> symbol).
        nominal: the task's nominal whole-body configuration at waypoint k (nq).
    """

    twin: CasadiTwin
    q2: ca.SX
    q1: ca.SX
    q0: ca.SX
    dt1: ca.SX
    dt0: ca.SX
    f: ca.SX
    r: ca.SX
    parameters: dict[str, ca.SX] = field(default_factory=dict)
    nominal: ca.SX | None = None

    @property
    def robot(self) -> MobileManipulator:
        return self.twin.robot

    @cached_property
    def tau(self) -> ca.SX:
        """Nominal arm torque at ``q_k`` with the paper's backward differences."""
        return stage_dynamics(self.twin, self.q2, self.q1, self.q0, self.dt1, self.dt0)

    @cached_property
    def J(self) -> ca.SX:
        """World-frame translational arm Jacobian at ``q_k``."""
        return self.twin.arm_jacobian(self.q0)

    @cached_property
    def tau_static(self) -> ca.SX:
        """Gravity torque ``g(q_k)`` (the static residual: no velocity, no acceleration)."""
        zero = ca.SX.zeros(self.robot.n_arm)
        return self.twin.rnea(self.q0[N_BASE:], zero, zero)


class CostTerm:
    """Base class of a cost term; subclasses set the class attributes and one method.

    Attributes:
        name: unique key in the registry (and in reports).
        kind: ``"stage"`` (implements :meth:`stage`) or ``"quadratic"`` (implements :meth:`matrix`).
        weight_field: the :class:`~forte.settings.CostWeights` field that holds the weight
            (default: ``name``); a term without one uses ``default_weight``.
        default_weight: the weight when neither the method nor ``CostWeights`` gives one.
        parameters: per-waypoint NLP parameters the term needs, ``(name, size)`` pairs, filled
            by :meth:`parameter_values`.
    """

    name: ClassVar[str] = ""
    kind: ClassVar[str] = "stage"
    weight_field: ClassVar[str | None] = None
    default_weight: ClassVar[float] = 1.0
    parameters: ClassVar[tuple[tuple[str, int], ...]] = ()

    @classmethod
    def from_weights(cls, weights: CostWeights) -> CostTerm:
        """The term with its parameters taken from ``weights`` (default: no parameters)."""
        return cls()

    def weight(self, weights: CostWeights) -> float:
        """``w_i`` from ``weights`` (methods may override it, see ``Method.weights``)."""
        field_name = self.weight_field or self.name
        if field_name in WEIGHT_FIELDS:
            return float(getattr(weights, field_name))
        return float(self.default_weight)

    def baked(self) -> tuple[Any, ...]:
        """Everything compiled into the kernels (the dataclass fields): part of the cache key."""
        return tuple((f.name, _stable(getattr(self, f.name))) for f in dataclasses.fields(self))

    def stage(self, s: Stage) -> ca.SX:  # pragma: no cover - abstract
        raise NotImplementedError(f"{type(self).__name__} is not a stage term")

    def matrix(self, n_arm: int, n: int) -> sparse.csr_matrix:  # pragma: no cover - abstract
        raise NotImplementedError(f"{type(self).__name__} is not a quadratic term")

    def parameter_values(self, name: str, f: FloatArray, r: FloatArray) -> FloatArray:  # pragma: no cover
        raise NotImplementedError(f"{type(self).__name__} declares no parameter '{name}'")


#: The weight fields of :class:`~forte.settings.CostWeights` a term may draw its weight from.
WEIGHT_FIELDS = ("capability", "manipulability", "joint_limits", "smoothness", "base_spectral")
#: The registry: term name -> term class.
COST_TERMS: dict[str, type[CostTerm]] = {}


def _stable(value: Any) -> Any:
    """A repr-stable form of a baked value: arrays by their exact bytes, containers recursively."""
    if isinstance(value, np.ndarray):
        digest = hashlib.sha256(np.ascontiguousarray(value).tobytes()).hexdigest()
        return ("array", value.shape, str(value.dtype), digest)
    if isinstance(value, tuple | list):
        return tuple(_stable(v) for v in value)
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return (type(value).__qualname__, tuple((f.name, _stable(getattr(value, f.name)))
                                               for f in dataclasses.fields(value)))
    if isinstance(value, float | np.floating):
        return float(value).hex()  # exact
    return value


def register_term(cls: type[CostTerm], *, replace: bool = False) -> type[CostTerm]:
    """Add a term class to :data:`COST_TERMS` (usable as a class decorator).

    A term must be a frozen dataclass: its fields are what it bakes into the compiled kernels
    and so part of their cache key.
    """
    if not cls.name or cls.kind not in ("stage", "quadratic"):
        raise InvalidInputError(f"cost term {cls.__name__}: needs a name and kind 'stage' or 'quadratic'")
    params = getattr(cls, "__dataclass_params__", None)
    if params is None or not params.frozen:
        raise InvalidInputError(f"cost term {cls.__name__}: expected a frozen dataclass (@dataclass(frozen=True))")
    if cls.name in COST_TERMS and COST_TERMS[cls.name] is not cls and not replace:
        raise InvalidInputError(f"cost term '{cls.name}' is already registered")
    COST_TERMS[cls.name] = cls
    return cls


def unregister_term(name: str) -> None:
    """Remove a term (e.g. one a test registered)."""
    COST_TERMS.pop(name, None)


def make_terms(names: tuple[str, ...], weights: CostWeights) -> tuple[CostTerm, ...]:
    """Instances of the named terms with their parameters from ``weights``."""
    unknown = [n for n in names if n not in COST_TERMS]
    if unknown:
        raise InvalidInputError(f"cost term '{unknown[0]}': not registered; known: {', '.join(COST_TERMS)}")
    return tuple(COST_TERMS[n].from_weights(weights) for n in names)


# -- stage terms ---------------------------------------------------------------------------
def stage_dynamics(twin: CasadiTwin, q2: ca.SX, q1: ca.SX, q0: ca.SX, dt1: ca.SX, dt0: ca.SX) -> ca.SX:
    """Nominal arm torque at ``q0`` with the paper's backward differences."""
    dq0 = (q0[N_BASE:] - q1[N_BASE:]) / dt0
    dq1 = (q1[N_BASE:] - q2[N_BASE:]) / dt1
    return twin.rnea(q0[N_BASE:], dq0, (dq0 - dq1) / dt0)


def _softplus(x: ca.SX) -> ca.SX:
    """``log(1 + exp(x))`` without overflow."""
    return ca.fmax(x, 0) + ca.log1p(ca.exp(-ca.fabs(x)))


def _smooth_min(values: ca.SX, scale: ca.SX, beta: float) -> ca.SX:
    """``-(s/beta) log sum exp(-beta v_i / s)``: a lower bound of ``min v`` within s log(n)/beta."""
    return -scale / beta * ca.logsumexp(-beta * values / scale)


@register_term
@dataclass(frozen=True)
class Capability(CostTerm):
    """J1 (paper, Section 4.2): ``c_k`` of the force ball against the dynamic RFP (smooth surrogate)."""

    name: ClassVar[str] = "capability"
    params: CapabilityParameters = field(default_factory=CapabilityParameters)

    @classmethod
    def from_weights(cls, weights: CostWeights) -> Capability:
        return cls(weights.capability_params)

    def stage(self, s: Stage) -> ca.SX:
        return smooth_penalty_expr(s.J, s.tau, ca.DM(s.robot.torque_limits), s.f, s.r, self.params)


@register_term
@dataclass(frozen=True)
class InscribedRadius(CostTerm):
    """RFP-radius baseline (Ferrolho et al. 2021, as the authors run it): ``1 / max(|R_k|, 1e-6)``.

    ``R_k = max(0, min_i min(alpha (tau_max,i - tau_nom,i), alpha (tau_max,i + tau_nom,i)) / ||n_i||)``,
    ``n_i`` the columns of the 3 x n world translational Jacobian: the radius of the largest
    ball centred at the origin inside the alpha-scaled dynamic RFP, clamped at 0; the task force
    is unused (``AUTHORS_SETUP.md``, "Baselines", ``residual_force_polytope``). The minimum is
    smoothed (a lower bound within ``s log(2n) / beta``, ``s = max(|f| + r, eps)``);
    :func:`forte.planning.reference.inscribed_radius_exact` is the exact value.
    """

    name: ClassVar[str] = "rfp_radius"
    weight_field: ClassVar[str | None] = "capability"
    params: CapabilityParameters = field(default_factory=CapabilityParameters)

    @classmethod
    def from_weights(cls, weights: CostWeights) -> InscribedRadius:
        return cls(weights.capability_params)

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
    ``tau = g(q_k)`` (no velocity or acceleration terms; the authors' fourth baseline,
    ``AUTHORS_SETUP.md``, "Baselines": "inscribed radius with a gravity-only residual")."""

    name: ClassVar[str] = "static_radius"

    def residual(self, s: Stage) -> ca.SX:
        return s.tau_static


@register_term
@dataclass(frozen=True)
class ConeVolume(CostTerm):
    """RFP-cone baseline (Ferrolho et al. 2021, as the authors run it): ``1 / max(|V_k|, 1e-6)``,
    ``V_k = Omega/(3M) sum_j rho_j^3`` (``cone_intersection_volume``, ``AUTHORS_SETUP.md``).

    The authors' rays: the axis along ``f`` (+z where ``f = 0``) plus 4 rings x 12 azimuths at
    ``theta_j = 0.1 j / 4`` (M = 49), each ray's capacity clamped at 0, no alpha.

    ``rho_j``, the capacity along ray ``d_j`` of the cone of half-angle ``half_angle`` around the
    desired force (``rings x azimuths`` rays plus the axis, an NLP parameter per waypoint), is the
    smoothed minimum of ``b_i / (a_i . d_j)`` over rows with ``a_i . d_j > 0``; the row selection
    uses a softplus of ``a_i . d_j`` so rows pointing away give huge ratios that the soft minimum
    ignores; ``Omega = 2 pi (1 - cos half_angle)``.
    """

    name: ClassVar[str] = "rfp_cone"
    weight_field: ClassVar[str | None] = "capability"
    params: CapabilityParameters = field(default_factory=CapabilityParameters)
    half_angle: float = 0.1
    rings: int = 4
    azimuths: int = 12

    @classmethod
    def from_weights(cls, weights: CostWeights) -> ConeVolume:
        return cls(weights.capability_params)

    @property
    def rays(self) -> int:
        return 1 + self.rings * self.azimuths

    @property
    def parameters(self) -> tuple[tuple[str, int], ...]:  # type: ignore[override]
        return (("rays", 3 * self.rays),)

    def stage(self, s: Stage) -> ca.SX:
        rays = ca.reshape(s.parameters["rays"], self.rays, 3)
        A = ca.vertcat(s.J.T, -s.J.T)
        tm = ca.DM(s.robot.torque_limits)
        b = ca.vertcat(tm - s.tau, tm + s.tau)
        scale = ca.fmax(ca.norm_2(s.f) + s.r, self.params.eps)
        total = 0
        sharp = 1e-3  # softplus width of a_i . d (m)
        for j in range(self.rays):
            pos = sharp * _softplus(A @ rays[j, :].T / sharp)
            rho = _smooth_min(b / (pos + 1e-9), scale, self.params.beta)
            total += ca.fmax(rho, 0) ** 3
        omega = 2 * np.pi * (1 - np.cos(self.half_angle))
        return inverse_capacity_expr(omega / (3 * self.rays) * total)

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
    lam: float = 1e-6
    eps: float = 1e-8
    with_yaw: bool = False

    @classmethod
    def from_weights(cls, weights: CostWeights) -> Manipulability:
        return cls(weights.manipulability_lambda, weights.manipulability_eps, weights.manipulability_yaw)

    def stage(self, s: Stage) -> ca.SX:
        J = s.J
        if self.with_yaw:
            _, p = s.twin.ee_pose(s.q0)
            J = ca.horzcat(ca.vertcat(-(p[1] - s.q0[1]), p[0] - s.q0[0], 0), J)
        return 1 / ca.fmax(manipulability_expr(J, self.lam), self.eps)


@register_term
@dataclass(frozen=True)
class JointLimits(CostTerm):
    """J3: ``sum_i w_i (e_i^2 + v_i^4)`` over the arm, ``+ sum_b w_b (q_b - q_nom,b)^2`` over the base.

    ``e_i = (q_i - mid_i)/h_i``, ``v_i = max(0, (|q_i - mid_i| - h_i)/delta_i)``,
    ``h_i = max(eps_h, range_i/2 - delta_i)``; ``delta_i = margin_fraction * range_i`` (the
    authors: 5 %) or ``margin`` for every joint; ``w`` the per-DoF weights over
    (x, y, yaw, q1..q7) (the authors': [0,2,1,10,0,1,2,1,0,0]/10), default 1 per arm joint and
    0 for the base. The base has no limits: its entries pull it toward the nominal trajectory.
    """

    name: ClassVar[str] = "joint_limits"
    margin: float = 0.1
    eps: float = 1e-3
    margin_fraction: float | None = None
    dof_weights: tuple[float, ...] | None = None

    @classmethod
    def from_weights(cls, weights: CostWeights) -> JointLimits:
        dof = None if weights.joint_dof_weights is None else tuple(float(w) for w in weights.joint_dof_weights)
        return cls(weights.joint_margin, weights.joint_eps, weights.joint_margin_fraction, dof)

    def weights_for(self, n_arm: int) -> FloatArray:
        """Per-DoF weights (base 3, then arm)."""
        if self.dof_weights is None:
            return np.r_[np.zeros(N_BASE), np.ones(n_arm)]
        w = np.asarray(self.dof_weights, dtype=float)
        if w.shape != (N_BASE + n_arm,):
            raise InvalidInputError(f"joint_dof_weights: expected {N_BASE + n_arm} values, got {w.size}")
        return w

    def stage(self, s: Stage) -> ca.SX:
        robot = s.robot
        delta = self.margins(robot.lower, robot.upper)
        mid, half = joint_limit_geometry(robot.lower, robot.upper, delta, self.eps)
        w = self.weights_for(robot.n_arm)
        dev = s.q0[N_BASE:] - ca.DM(mid)
        e = dev / ca.DM(half)
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


# -- quadratic terms -------------------------------------------------------------------------
@register_term
@dataclass(frozen=True)
class Smoothness(CostTerm):
    """Arm part of J4: ``sum_k 1/2 ||W_s (q_k - q_{k-1})||^2`` with ``W_s = diag(0, 0, 0, arm...)``.

    With :class:`BaseSmoothness` (``W_s = diag(base, 0...)``) at the same weight this is the
    paper's whole-body J4 with ``W_s = diag(base, arm...)``.
    """

    name: ClassVar[str] = "smoothness"
    kind: ClassVar[str] = "quadratic"
    base: tuple[float, float, float] = (0.0, 0.0, 0.0)
    arm: float = 1.0

    @classmethod
    def from_weights(cls, weights: CostWeights) -> Smoothness:
        return cls((0.0, 0.0, 0.0), weights.smoothness_arm)

    def matrix(self, n_arm: int, n: int) -> sparse.csr_matrix:
        size = (n_arm + N_BASE) * n
        if n == 1:
            return sparse.csr_matrix((size, size))
        D = sparse.diags([-np.ones(n - 1), np.ones(n - 1)], [0, 1], shape=(n - 1, n))  # q_{k+1} - q_k
        Ws = sparse.diags(np.concatenate([self.base, np.full(n_arm, self.arm)]) ** 2)
        return sparse.kron(D.T @ D, Ws).tocsr()


@register_term
@dataclass(frozen=True)
class BaseSmoothness(Smoothness):
    """Base part of J4: ``W_s = diag(base, 0...)`` (``smoothness_base``, default (1, 1, 0.5))."""

    name: ClassVar[str] = "base_smoothness"
    base: tuple[float, float, float] = (1.0, 1.0, 0.5)
    arm: float = 0.0

    @classmethod
    def from_weights(cls, weights: CostWeights) -> BaseSmoothness:
        return cls(tuple(weights.smoothness_base), 0.0)


@register_term
@dataclass(frozen=True)
class Velocity(CostTerm):
    """Arm velocity term ``1/2 ||q_a,k - q_a,k-1||^2 / dt_k^2`` (the authors' velocity cost;
    zero at the first waypoint, which starts at rest)."""

    name: ClassVar[str] = "velocity"

    def coordinates(self, s: Stage) -> slice:
        return slice(N_BASE, s.robot.nq)

    def stage(self, s: Stage) -> ca.SX:
        i = self.coordinates(s)
        return 0.5 * ca.sumsqr(s.q0[i] - s.q1[i]) / s.dt0**2


@register_term
@dataclass(frozen=True)
class BaseVelocity(Velocity):
    """Base velocity term ``1/2 ||q_b,k - q_b,k-1||^2 / dt_k^2`` over (x, y, yaw)."""

    name: ClassVar[str] = "base_velocity"

    def coordinates(self, s: Stage) -> slice:
        return slice(0, N_BASE)


@register_term
@dataclass(frozen=True)
class Nominal(CostTerm):
    """Arm nominal term ``1/2 ||q_a,k - q_a,nom,k||^2`` (the nominal trajectory of the task: the
    joint-space interpolation of taught configurations, else the initial guess)."""

    name: ClassVar[str] = "nominal"

    def stage(self, s: Stage) -> ca.SX:
        if s.nominal is None:
            return ca.SX(0)
        return 0.5 * ca.sumsqr(s.q0[N_BASE:] - s.nominal[N_BASE:])


#: Collision model of the built-in robot: the base as a box in the base frame (m) and the arm
#: points that carry spheres (joint origins 3, 4, 5, 7 and the end effector: 6 shares 5's; 1-2 sit on the
#: mount). An estimate: the MOCA base is not in the authors' optimizer URDF.
BASE_BOX: tuple[tuple[float, float, float], tuple[float, float, float]] = ((-0.35, -0.28, 0.0), (0.30, 0.28, 0.50))
COLLISION_JOINTS: tuple[int, ...] = (2, 3, 4, 6)


@register_term
@dataclass(frozen=True)
class Collision(CostTerm):
    """Collision term: ``sum_s max(0, 1 - d_box,s / rho)^2 + max(0, 1 - z_s / rho)^2``.

    Spheres of radius ``rho`` (0.08 m, the authors') at the origins of arm joints 3, 4, 5, 7 and at
    the end effector; ``d_box`` is the distance from a centre to the base box :data:`BASE_BOX`
    (0 inside), ``z`` the height above the floor. Zero when every sphere clears both; each
    penetrating sphere adds up to 2. ``sqrt`` is guarded by ``1e-10`` m^2 (a 1e-5 m offset).
    """

    name: ClassVar[str] = "collision"
    radius: float = 0.08
    box: tuple[tuple[float, float, float], tuple[float, float, float]] = BASE_BOX
    joints: tuple[int, ...] = COLLISION_JOINTS

    @classmethod
    def from_weights(cls, weights: CostWeights) -> Collision:
        return cls(weights.collision_radius)

    def centres(self, s: Stage) -> list[ca.SX]:
        """Sphere centres in the base frame."""
        poses = s.twin._arm_poses(s.q0[N_BASE:])
        _, p_ee = s.twin.arm_ee_pose(s.q0[N_BASE:])
        return [poses[j][1] for j in self.joints if j < len(poses)] + [p_ee]

    def stage(self, s: Stage) -> ca.SX:
        lo, hi = ca.DM(self.box[0]), ca.DM(self.box[1])
        centre, half = (lo + hi) / 2, (hi - lo) / 2
        cost = ca.SX(0)
        for c in self.centres(s):
            out = ca.fmax(ca.fabs(c - centre) - half, 0)
            d_box = ca.sqrt(ca.sumsqr(out) + 1e-10)
            cost += ca.fmax(0, 1 - d_box / self.radius) ** 2 + ca.fmax(0, 1 - c[2] / self.radius) ** 2
        return cost


@register_term
@dataclass(frozen=True)
class BaseSpectral(CostTerm):
    """J5 = ``1/2 sum_xi eta_xi sum_{l in H} gamma_l bhat_{xi,l}^2`` (orthonormal DCT-II per base axis)."""

    name: ClassVar[str] = "base_spectral"
    kind: ClassVar[str] = "quadratic"
    cutoff: float = 0.35
    axis: tuple[float, float, float] = (1.0, 1.0, 0.5)
    power: float = 0.0
    ramp: bool = False

    @classmethod
    def from_weights(cls, weights: CostWeights) -> BaseSpectral:
        return cls(weights.dct_cutoff, tuple(weights.dct_axis), weights.dct_power, weights.dct_ramp)

    def matrix(self, n_arm: int, n: int) -> sparse.csr_matrix:
        nq = n_arm + N_BASE
        if n == 1:
            return sparse.csr_matrix((nq, nq))
        E = np.zeros((nq, nq))
        E[:N_BASE, :N_BASE] = np.diag(self.axis)
        P = dct_penalty(n, self.cutoff, self.power, self.ramp)
        return sparse.kron(sparse.csr_matrix(P), sparse.csr_matrix(E)).tocsr()


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


def ramped_frequencies(n: int, cutoff: float) -> FloatArray:
    """The authors' high set ``H = {l : l / (N - 1) > cutoff}``."""
    ell = np.arange(n)
    return ell[ell / max(n - 1, 1) > cutoff]


def dct_penalty(n: int, cutoff: float, power: float, ramp: bool = False) -> FloatArray:
    """``P`` with ``b^T P b = sum_{l in H} gamma_l bhat_l^2``.

    ``gamma_l = (l / (N - 1))^power`` on ``l >= ceil(cutoff N)`` (the paper's text), or with
    ``ramp`` the authors' ``gamma_l = ((l/(N-1) - c) / (1 - c))^power`` on ``l/(N-1) > c``.
    """
    C = dct_matrix(n)
    H = ramped_frequencies(n, cutoff) if ramp else high_frequencies(n, cutoff)
    if H.size == 0:
        return np.zeros((n, n))
    x = H / max(n - 1, 1)
    gamma = ((x - cutoff) / (1 - cutoff)) ** power if ramp else x**power
    CH = C[H]
    return CH.T @ (gamma[:, None] * CH)


def dct_penalty_matrix(n: int, weights: CostWeights) -> FloatArray:
    """:func:`dct_penalty` with the cutoff and power of ``weights`` (one base coordinate)."""
    return dct_penalty(n, weights.dct_cutoff, weights.dct_power, weights.dct_ramp)
