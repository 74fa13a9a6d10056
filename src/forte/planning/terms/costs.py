"""Cost terms of the whole-body NLP (paper, Section 4.3): one small class per term, in a registry.

The objective is ``J = sum_i w_i J_i``. A term is one of two kinds:

- a **stage term** ``J_i = sum_k c_i(q_{k-2}, q_{k-1}, q_k, dt_{k-1}, dt_k, f_k, r_k, ...)``: its
  per-waypoint expression is compiled into the optimizer's kernels (so everything it bakes in
  is part of the kernel cache key, see :meth:`CostTerm.baked`) and mapped over the horizon. The
  backward differences of the paper need the two previous configurations; the first samples
  start at rest (the optimizer pads the trajectory with two copies of ``q_1``);
- a **quadratic term** ``J_i = x^T Q_i x / 2`` over ``x = vec(q_1..q_N)`` (J4, J5): a constant
  sparse matrix, assembled once per horizon (:meth:`CostTerm.matrix`, the exact value). The
  optimizer solves with :meth:`CostTerm.lifted`, ``x^T D x / 2 + sum_j g_j (A x)_j^2 / 2`` with
  ``D`` sparse and ``A`` a few dense rows lifted as variables, so the KKT matrix stays sparse.

Built-in terms (``name``: weight field of :class:`~forte.settings.CostWeights`; each declares its
parameters, :attr:`CostTerm.settings`, read from :class:`~forte.settings.TermSettings`):

- ``capability`` (w1): ``c_k`` of J1, the smooth surrogate of :mod:`forte.capability.metrics`;
- ``wrench_capability`` (w1): ``c_k`` of J1 on the residual wrench polytope
  (:mod:`forte.capability.wrench`), used instead of ``capability`` when the task's payload needs a
  moment (:func:`forte.planning.terms.wrench_terms.for_requirement`);
- ``rfp_radius``, ``rfp_cone``, ``static_radius`` (w1 of the baselines): ``1 / max(|value|, eps)``
  of the centred inscribed radius, the cone measure, or the radius with a gravity-only residual;
- ``manipulability`` (w2): ``1 / max(mu_k, eps_m)``;
- ``joint_limits`` (w3): ``sum_i w_i (e_i^2 + v_i^4)`` (arm), ``w_i (q_i - q_nom,i)^2`` (base);
- ``smoothness`` / ``base_smoothness`` (w4): ``sum_k 1/2 ||W_s (q_k - q_{k-1})||^2`` over the arm /
  the base coordinates (base: or ``1/2 sum_i m_i dq_i^2``, the metric used linearly, the
  authors' code);
- ``base_spectral`` (w5): ``1/2 sum_xi eta_xi sum_{l in H} gamma_l bhat_{xi,l}^2``;
- ``velocity``: ``1/2 ||q_a,k - q_a,k-1||^2 / dt_k^2`` over the arm;
- ``base_velocity``: ``1/2 sum_i m_i (q_b,k - q_b,k-1)_i^2 / dt_k^2``, ``m = (1, 1, 0.5)``, yaw wrapped;
- ``nominal``: ``1/2 ||q_a,k - q_a,nom,k||^2`` (the task's nominal trajectory);
- ``collision``: ``sum max(0, s - clearance)^2`` over pairs of spheres on the end effector and on
  the base (the authors'; ``collision_model: box``: arm spheres against a base box and the floor).

The terms beyond the paper's J1..J5 (velocity, nominal, collision, the per-DoF joint weights,
the ramped spectral weights) are the authors' (the authors' public code).

A new term is a subclass registered with :func:`register_term`; a method
(:mod:`forte.planning.methods.catalog`) lists the terms it uses by name.
"""

from __future__ import annotations

import dataclasses
import hashlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any, ClassVar, NamedTuple

import casadi as ca
import numpy as np
from scipy import sparse

from forte.exceptions import InvalidInputError
from forte.model.robot import N_BASE, MobileManipulator
from forte.model.twin import CasadiTwin, rot_z
from forte.settings import CostWeights
from forte.validation import FloatArray, did_you_mean


class LiftedQuadratic(NamedTuple):
    """``x^T Q x / 2`` as ``x^T D x / 2 + z^T diag(g) z / 2`` with ``z = A x`` (the optimizer lifts
    ``z`` as variables with the rows ``A x - z = 0``, so a dense ``Q`` becomes ``D`` plus ``len(g)``
    dense rows)."""

    D: sparse.csr_matrix
    A: sparse.csr_matrix
    g: FloatArray


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
    def J6(self) -> ca.SX:
        """World-frame 6 x n arm Jacobian ``[J; J_w]`` at ``q_k`` (linear rows first)."""
        return ca.vertcat(self.J, rot_z(self.q0[2]) @ self.twin.arm_angular_jacobian_base(self.q0[N_BASE:]))

    @cached_property
    def tau_static(self) -> ca.SX:
        """Gravity torque ``g(q_k)`` (the static residual: no velocity, no acceleration)."""
        zero = ca.SX.zeros(self.robot.n_arm)
        return self.twin.rnea(self.q0[N_BASE:], zero, zero)


class TermSetting(NamedTuple):
    """A parameter a term declares (issue 25, item 6: terms own their parameters).

    A task sets it in ``terms: {TERM: {NAME: value}}`` (or, for the settings that had one before,
    under its older name next to the weights: ``weights: {LEGACY: value}``); a named weight set
    in its :class:`~forte.settings.TermSettings`. It reaches the term in one of two ways:

    - ``parameter`` given: as that per-waypoint NLP parameter (no kernel is rebuilt for another
      value, e.g. the tip-over margin);
    - ``parameter`` ``None``: as the term's dataclass field ``field`` (default: ``name``), baked
      into the compiled kernels, so part of their cache key (:meth:`CostTerm.baked`).

    Attributes:
        kind: how a task file gives it: ``float``, ``int``, ``bool``, ``str``, ``vector`` (any
            length; or the length of ``default``), each optionally ``| None``.
        expected, valid: the check (``valid(value)``) and the words of its error message.
        legacy: the older ``weights:`` key (e.g. ``joint_margin``), read into this setting.
    """

    name: str
    parameter: str | None
    default: Any
    unit: str
    doc: str
    field: str | None = None
    kind: str = "float"
    expected: str = "a finite number >= 0"
    valid: Callable[[Any], bool] | None = None
    legacy: str | None = None

    def check(self, value: Any) -> Any:
        """``value`` (a vector as a tuple of floats) if it passes the check, else
        :class:`~forte.exceptions.InvalidInputError` ``NAME: expected ..., got ...``."""
        if isinstance(value, list | np.ndarray):
            value = tuple(float(v) for v in value)
        ok = (value is None and self.kind.endswith("| None")) or (
            _of_kind(value, self.kind) and (self.valid is None or bool(self.valid(value))))
        if not ok:
            raise InvalidInputError(f"{self.name}: expected {self.expected}, got {value!r}")
        return value


def _of_kind(value: Any, kind: str) -> bool:
    base = kind.removesuffix(" | None")
    if base == "bool":
        return isinstance(value, bool)
    if base == "str":
        return isinstance(value, str)
    if base == "int":
        return isinstance(value, int) and not isinstance(value, bool)
    if base == "vector":
        return isinstance(value, tuple) and all(isinstance(v, float) and np.isfinite(v) for v in value)
    return isinstance(value, int | float) and not isinstance(value, bool) and bool(np.isfinite(value))


def nonnegative(value: Any) -> bool:
    return value >= 0


def positive(value: Any) -> bool:
    return value > 0


def nonnegative_vector(size: int | None) -> Callable[[Any], bool]:
    """The check of a vector of ``size`` (``None``: any) numbers >= 0."""
    return lambda v: (size is None or len(v) == size) and all(x >= 0 for x in v)


class CostTerm:
    """Base class of a cost term; subclasses set the class attributes and one method.

    Attributes:
        name: unique key in the registry (and in reports).
        kind: ``"stage"`` (implements :meth:`stage`) or ``"quadratic"`` (implements :meth:`matrix`).
        weight_field: the :class:`~forte.settings.CostWeights` field that holds the weight
            (default: ``name``); a term without one uses ``default_weight``.
        default_weight: the weight when neither the method nor ``CostWeights`` gives one.
        parameters: per-waypoint NLP parameters the term needs, ``(name, size)`` pairs, filled
            by :meth:`parameter_values` or by the caller (:meth:`task_values`).
        settings: the parameters a task may set (:class:`TermSetting`, baked or NLP parameters).
        settings_of: the term whose settings this one uses (e.g. the baselines' capability
            terms use ``capability``'s); ``None``: its own.
    """

    name: ClassVar[str] = ""
    kind: ClassVar[str] = "stage"
    weight_field: ClassVar[str | None] = None
    default_weight: ClassVar[float] = 1.0
    parameters: ClassVar[tuple[tuple[str, int], ...]] = ()
    settings: ClassVar[tuple[TermSetting, ...]] = ()
    settings_of: ClassVar[str | None] = None

    @classmethod
    def task_values(cls, force: Any, settings: Mapping[str, Any]) -> dict[str, FloatArray]:
        """The values of the term's NLP parameters for a task force and the task's ``settings``
        (default: each declared NLP setting, given or its default, at every waypoint)."""
        n = len(force.t)
        return {s.parameter: np.full(n, float(settings.get(s.name, s.default)))
                for s in cls.settings if s.parameter is not None}

    @classmethod
    def setting_values(cls, settings: Mapping[str, Mapping[str, Any]] | None = None) -> dict[str, Any]:
        """Every declared setting's value in ``settings`` (term -> {name: value}), default where not
        given, each checked."""
        given = (settings or {}).get(cls.settings_of or cls.name, {})
        unknown = sorted(set(given) - {s.name for s in cls.settings})
        if unknown and cls.settings_of is None:
            raise InvalidInputError(f"{cls.name}: no setting '{unknown[0]}'; expected one of "
                                    f"{', '.join(s.name for s in cls.settings) or 'none'}"
                                    + did_you_mean(unknown[0], (s.name for s in cls.settings)))
        return {s.name: s.check(given[s.name]) if s.name in given else s.default for s in cls.settings}

    @classmethod
    def from_settings(cls, settings: Mapping[str, Mapping[str, Any]] | None = None) -> CostTerm:
        """The term with its baked settings (its dataclass fields) from ``settings`` (default:
        each declared default)."""
        values = cls.setting_values(settings)
        return cls(**{s.field or s.name: values[s.name] for s in cls.settings if s.parameter is None})

    def weight(self, weights: CostWeights) -> float:
        """``w_i`` from ``weights`` (methods may override it, see ``Method.weights``)."""
        field_name = self.weight_field or self.name
        if field_name in {f.name for f in dataclasses.fields(weights)} - {"preset"}:
            return float(getattr(weights, field_name))
        return float(self.default_weight)

    def baked(self) -> tuple[Any, ...]:
        """Everything compiled into the kernels (the dataclass fields): part of the cache key."""
        return tuple((f.name, _stable(getattr(self, f.name))) for f in dataclasses.fields(self))

    def stage(self, s: Stage) -> ca.SX:  # pragma: no cover - abstract
        raise NotImplementedError(f"{type(self).__name__} is not a stage term")

    def matrix(self, n_arm: int, n: int) -> sparse.csr_matrix:  # pragma: no cover - abstract
        raise NotImplementedError(f"{type(self).__name__} is not a quadratic term")

    def lifted(self, n_arm: int, n: int) -> LiftedQuadratic:
        """What the optimizer minimizes for a quadratic term (default: :meth:`matrix`, no rows)."""
        Q = self.matrix(n_arm, n)
        return LiftedQuadratic(Q, sparse.csr_matrix((0, Q.shape[1])), np.zeros(0))

    def solved_as(self, n: int) -> str:
        """How :meth:`lifted` represents the term at horizon ``n`` (reported with a plan)."""
        return "exact"

    def parameter_values(self, name: str, f: FloatArray, r: FloatArray) -> FloatArray:  # pragma: no cover
        raise NotImplementedError(f"{type(self).__name__} declares no parameter '{name}'")


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
    if "settings" not in vars(cls) and cls.settings_of is None:  # declared by its fields
        cls.settings = _field_settings(cls) + tuple(s for s in cls.settings if s.parameter is not None)
    COST_TERMS[cls.name] = cls
    return cls


def unregister_term(name: str) -> None:
    """Remove a term (e.g. one a test registered)."""
    COST_TERMS.pop(name, None)


def make_terms(names: tuple[str, ...], settings: Mapping[str, Mapping[str, Any]] | None = None
               ) -> tuple[CostTerm, ...]:
    """Instances of the named terms with their parameters from ``settings`` (term -> {setting:
    value}, :class:`~forte.settings.TermSettings`; default: the terms' declared defaults)."""
    unknown = [n for n in names if n not in COST_TERMS]
    if unknown:
        raise InvalidInputError(f"cost term '{unknown[0]}': not registered; known: {', '.join(COST_TERMS)}")
    return tuple(COST_TERMS[n].from_settings(settings) for n in names)


def setting(default: Any, unit: str, doc: str, kind: str = "float", expected: str = "a finite number >= 0",
            valid: Callable[[Any], bool] | None = nonnegative, legacy: str | None = None, name: str | None = None
            ) -> Any:
    """A term's dataclass field that is a baked setting (its :class:`TermSetting` is built from
    it by :func:`register_term`; ``name``: the task file's key when not the field's)."""
    meta = {"setting": (name, unit, doc, kind, expected, valid, legacy)}
    if isinstance(default, list | dict):  # pragma: no cover - settings are immutable values
        raise TypeError("a setting's default must be immutable")
    return field(default=default, metadata=meta)


def _field_settings(cls: type) -> tuple[TermSetting, ...]:
    """The :class:`TermSetting` of each field of ``cls`` made with :func:`setting`."""
    out = []
    for f in dataclasses.fields(cls):
        if "setting" in f.metadata:
            name, unit, doc, kind, expected, valid, legacy = f.metadata["setting"]
            out.append(TermSetting(name or f.name, None, f.default, unit, doc, f.name, kind, expected, valid, legacy))
    return tuple(out)


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

