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
- ``rfp_radius``, ``rfp_cone`` (w1 of the RFP baselines): ``1 / max(|value|, eps)`` of the
  centred inscribed radius or the cone measure of the RFP (Ferrolho et al. 2021);
- ``manipulability`` (w2): ``1 / max(mu_k, eps_m)``;
- ``joint_limits`` (w3): ``sum_i e_i^2 + v_i^4``;
- ``smoothness`` (w4): ``sum_k 1/2 ||W_s (q_k - q_{k-1})||^2``;
- ``base_spectral`` (w5): ``1/2 sum_xi eta_xi sum_{l in H} gamma_l bhat_{xi,l}^2``.

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
    """RFP-radius baseline: ``1 / max(|R_k|, eps)``, ``R_k = min_i b_i / ||a_i||`` (smoothed minimum).

    ``R_k`` is the radius of the largest ball centred at the origin inside the RFP (Ferrolho et
    al. 2021), from the residual margins ``tau_max -+ tau_nom``; the task force is unused, the
    soft minimum's temperature is ``max(|f| + r, eps)``.
    """

    name: ClassVar[str] = "rfp_radius"
    weight_field: ClassVar[str | None] = "capability"
    params: CapabilityParameters = field(default_factory=CapabilityParameters)

    @classmethod
    def from_weights(cls, weights: CostWeights) -> InscribedRadius:
        return cls(weights.capability_params)

    def stage(self, s: Stage) -> ca.SX:
        p = self.params
        norms = ca.sqrt(ca.sum1(s.J**2).T + p.eps_normal**2)
        tm = ca.DM(s.robot.torque_limits)
        dist = ca.vertcat((tm - s.tau) / norms, (tm + s.tau) / norms)
        scale = ca.fmax(ca.norm_2(s.f) + s.r, p.eps)
        return inverse_capacity_expr(_smooth_min(dist, scale, p.beta))


@register_term
@dataclass(frozen=True)
class ConeVolume(CostTerm):
    """RFP-cone baseline: ``1 / max(|V_k|, eps)``, ``V_k = Omega/(3M) sum_j rho_j^3``.

    ``rho_j``, the capacity along ray ``d_j`` of the cone of half-angle ``half_angle`` around the
    desired force (``rings x azimuths`` rays plus the axis, an NLP parameter per waypoint), is the
    smoothed minimum of ``b_i / (a_i . d_j)`` over rows with ``a_i . d_j > 0``; the row selection
    uses a softplus of ``a_i . d_j`` so rows pointing away give huge ratios that the soft minimum
    ignores; ``Omega = 2 pi (1 - cos half_angle)``.
    """

    name: ClassVar[str] = "rfp_cone"
    weight_field: ClassVar[str | None] = "capability"
    params: CapabilityParameters = field(default_factory=CapabilityParameters)
    half_angle: float = 0.35
    rings: int = 3
    azimuths: int = 8

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
    """J2: ``1 / max(mu_k, eps_m)``, ``mu_k = sqrt(det(J_t J_t^T + lambda I_3))`` (arm Jacobian)."""

    name: ClassVar[str] = "manipulability"
    lam: float = 1e-6
    eps: float = 1e-4

    @classmethod
    def from_weights(cls, weights: CostWeights) -> Manipulability:
        return cls(weights.manipulability_lambda, weights.manipulability_eps)

    def stage(self, s: Stage) -> ca.SX:
        return 1 / ca.fmax(manipulability_expr(s.J, self.lam), self.eps)


@register_term
@dataclass(frozen=True)
class JointLimits(CostTerm):
    """J3: ``sum_i e_i^2 + v_i^4``, ``e_i = (q_i - mid_i)/h_i``, ``v_i = max(0, (|q_i - mid_i| - h_i)/delta)``."""

    name: ClassVar[str] = "joint_limits"
    margin: float = 0.1
    eps: float = 1e-3

    @classmethod
    def from_weights(cls, weights: CostWeights) -> JointLimits:
        return cls(weights.joint_margin, weights.joint_eps)

    def stage(self, s: Stage) -> ca.SX:
        mid, half = joint_limit_geometry(s.robot.lower, s.robot.upper, self.margin, self.eps)
        dev = s.q0[N_BASE:] - ca.DM(mid)
        e = dev / ca.DM(half)
        v = ca.fmax(0, (ca.fabs(dev) - ca.DM(half)) / self.margin)
        return ca.sumsqr(e) + ca.sum1(v**4)


def joint_limit_geometry(lower: FloatArray, upper: FloatArray, margin: float,
                         eps: float) -> tuple[FloatArray, FloatArray]:
    """Joint centres and safe half-widths ``h_i = max(eps_h, (max - min)/2 - delta)``."""
    mid = (np.asarray(upper) + np.asarray(lower)) / 2
    half = np.maximum(eps, (np.asarray(upper) - np.asarray(lower)) / 2 - margin)
    return mid, half


# -- quadratic terms -------------------------------------------------------------------------
@register_term
@dataclass(frozen=True)
class Smoothness(CostTerm):
    """J4 = ``sum_k 1/2 ||W_s (q_k - q_{k-1})||^2`` with ``W_s = diag(base, arm...)``."""

    name: ClassVar[str] = "smoothness"
    kind: ClassVar[str] = "quadratic"
    base: tuple[float, float, float] = (1.0, 1.0, 0.5)
    arm: float = 1.0

    @classmethod
    def from_weights(cls, weights: CostWeights) -> Smoothness:
        return cls(tuple(weights.smoothness_base), weights.smoothness_arm)

    def matrix(self, n_arm: int, n: int) -> sparse.csr_matrix:
        size = (n_arm + N_BASE) * n
        if n == 1:
            return sparse.csr_matrix((size, size))
        D = sparse.diags([-np.ones(n - 1), np.ones(n - 1)], [0, 1], shape=(n - 1, n))  # q_{k+1} - q_k
        Ws = sparse.diags(np.concatenate([self.base, np.full(n_arm, self.arm)]) ** 2)
        return sparse.kron(D.T @ D, Ws).tocsr()


@register_term
@dataclass(frozen=True)
class BaseSpectral(CostTerm):
    """J5 = ``1/2 sum_xi eta_xi sum_{l in H} gamma_l bhat_{xi,l}^2`` (orthonormal DCT-II per base axis)."""

    name: ClassVar[str] = "base_spectral"
    kind: ClassVar[str] = "quadratic"
    cutoff: float = 0.35
    axis: tuple[float, float, float] = (1.0, 1.0, 0.5)
    power: float = 0.0

    @classmethod
    def from_weights(cls, weights: CostWeights) -> BaseSpectral:
        return cls(weights.dct_cutoff, tuple(weights.dct_axis), weights.dct_power)

    def matrix(self, n_arm: int, n: int) -> sparse.csr_matrix:
        nq = n_arm + N_BASE
        if n == 1:
            return sparse.csr_matrix((nq, nq))
        E = np.zeros((nq, nq))
        E[:N_BASE, :N_BASE] = np.diag(self.axis)
        P = dct_penalty(n, self.cutoff, self.power)
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


def dct_penalty(n: int, cutoff: float, power: float) -> FloatArray:
    """``P`` with ``b^T P b = sum_{l in H} gamma_l bhat_l^2``, ``gamma_l = (l / (N - 1))^power``."""
    C = dct_matrix(n)
    H = high_frequencies(n, cutoff)
    if H.size == 0:
        return np.zeros((n, n))
    gamma = (H / max(n - 1, 1)) ** power
    CH = C[H]
    return CH.T @ (gamma[:, None] * CH)


def dct_penalty_matrix(n: int, weights: CostWeights) -> FloatArray:
    """:func:`dct_penalty` with the cutoff and power of ``weights`` (one base coordinate)."""
    return dct_penalty(n, weights.dct_cutoff, weights.dct_power)
