"""Planning methods (paper, Section 5): one :class:`Method` entry per method, in a registry.

A method says which modes it applies to, how its plan is produced and, for optimized methods,
which cost terms (:mod:`forte.planning.terms.costs`) make up its objective. Everything that lists
methods (the CLI's choices, ``forte compare``, the experiments, plot colours, kernel cache keys)
is derived from :data:`METHODS`; adding a method is one :func:`register_method` call.

Built-in methods (definitions and weights as the authors run them in their public code: each
keeps the weight set's weights except as listed in its ``tuning``):

- ``forte``: the paper's J1..J5 plus the authors' velocity, nominal, base-velocity and collision
  terms (:data:`FORTE_TERMS`), with the weight set's weights (trajectories: ``forte-trajectory``,
  the authors' set with capability weight 5 and the paper's text for J2 and the base smoothness;
  ``authors-trajectory`` is their exact set: J2 on the 3 x 8 Jacobian with the base-yaw column,
  the base smoothness metric used linearly, which every baseline then inherits);
- ``manipulability``: J2 and J3 only (no J1, no regularization terms); in the trajectory set the
  joint-limit DoF weights [0,2,1,10,5,1,2,1,0,0]/10 (arm joint 2 penalized);
- ``rfp-radius``: J1 replaced by ``1/max(|R|, 1e-6)``, R the alpha-scaled origin-centred
  inscribed radius of the dynamic RFP clamped at 0; no manipulability; trajectory set:
  capability weight 60, base velocity 0.54, J5 kept;
- ``rfp-cone``: J1 replaced by ``1/max(|V|, 1e-6)``, V the ray-sampled RFP volume in a 0.1 rad
  cone around f (49 rays); no manipulability, no J5; trajectory set: capability weight 60,
  joint limit 2, velocity 7, collision 0.1;
- ``static-polytope`` (not in the paper): as ``rfp-radius`` with the gravity-only residual;
  trajectory set: capability weight 2;
- ``quintic`` (trajectory mode): the task's nominal trajectory, not optimized: the joint-space
  quintic interpolation of its taught configurations (paper, Section 5.3; the authors'), or,
  for a task given by end-effector poses, the IK path (below);
- ``ik-path`` (trajectory mode, not in the paper): the interpolated end-effector path followed
  by damped least-squares IK;
- ``teaching`` (hold mode): the task's teaching configuration, not optimized.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import Any

from forte.exceptions import InvalidInputError, TaskFileError
from forte.planning.methods.plugins import load_plugins
from forte.planning.tasks.ik import initial_guess
from forte.planning.tasks.tasks import MODES
from forte.planning.terms.costs import COST_TERMS, CostTerm, make_terms
from forte.settings import AUTHORS_TRAJECTORY_SETS, CostWeights, TermSettings
from forte.validation import FloatArray

PRODUCTIONS: tuple[str, ...] = ("optimized", "interpolated", "given")


@dataclass(frozen=True)
class MethodStyle:
    """How figures draw a method (the same in every figure)."""

    color: str
    label: str
    marker: str = "o"
    linestyle: str = "-"


@dataclass(frozen=True)
class Method:
    """A planning method.

    Attributes:
        name: key in :data:`METHODS` and on the command line.
        description: one line for help texts and reports.
        production: ``"optimized"`` (the NLP with :attr:`terms`), ``"interpolated"`` or
            ``"given"`` (:attr:`produce` makes the configurations from the task).
        modes: the task modes it applies to (``"trajectory"``, ``"hold"``).
        terms: names of its cost terms, in the order they are summed.
        weights: weights by term name that take precedence over
            :class:`~forte.settings.CostWeights` (part of the method's definition).
        style: colour, label and marker in figures.
        produce: ``task -> q`` (N x nq) for methods that are not optimized.
        status: solver status reported for methods that are not optimized.
        source: where the definition comes from.
        in_paper: compared in the paper's experiments (``forte experiment`` runs these).
        tuning: per weight set (:data:`forte.settings.WEIGHT_SETS` name), what this method
            changes in that set: weights by :class:`~forte.settings.CostWeights` field (e.g. the
            authors' baseline weights) and term settings as ``"TERM.SETTING"``.
    """

    name: str
    description: str
    production: str = "optimized"
    modes: tuple[str, ...] = MODES
    terms: tuple[str, ...] = ()
    weights: Mapping[str, float] = field(default_factory=dict)
    style: MethodStyle = MethodStyle("tab:gray", "")
    produce: Callable[[Any], FloatArray] | None = None
    status: str = ""
    source: str = ""
    in_paper: bool = False
    tuning: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not re.fullmatch(r"[A-Za-z0-9][A-Za-z0-9_.-]*", self.name or ""):
            raise InvalidInputError(f"method name {self.name!r}: expected letters, digits, '-', '_' or '.'")
        unknown = sorted(set(self.weights) - set(self.terms))
        if unknown:
            raise InvalidInputError(f"method {self.name}: weights: '{unknown[0]}' is not one of its terms "
                                    f"({', '.join(self.terms) or 'none'})")
        if self.production not in PRODUCTIONS:
            raise InvalidInputError(f"method {self.name}: production: expected one of {PRODUCTIONS}")
        if not set(self.modes) <= set(MODES) or not self.modes:
            raise InvalidInputError(f"method {self.name}: modes: expected a subset of {MODES}")
        if self.production == "optimized":
            make_terms(self.terms)  # every term must be registered
        elif self.produce is None:
            raise InvalidInputError(f"method {self.name}: a method that is not optimized needs produce")
        object.__setattr__(self, "weights", MappingProxyType(dict(self.weights)))
        object.__setattr__(self, "tuning", MappingProxyType({k: MappingProxyType(dict(v))
                                                             for k, v in self.tuning.items()}))
        if not self.style.label:
            object.__setattr__(self, "style", MethodStyle(self.style.color, self.name, self.style.marker,
                                                          self.style.linestyle))

    @property
    def optimized(self) -> bool:
        return self.production == "optimized"

    def resolve(self, weights: CostWeights, settings: TermSettings | None = None
                ) -> tuple[CostWeights, TermSettings]:
        """``weights`` and ``settings`` with this method's :attr:`tuning` for their set applied."""
        settings = settings if isinstance(settings, TermSettings) else TermSettings(settings)
        changes = self.tuning.get(weights.preset, {})
        plain = {k: v for k, v in changes.items() if "." not in k}
        for key, value in changes.items():
            if "." in key:
                term, name = key.split(".", 1)
                settings = settings.with_values(term, **{name: value})
        return (replace(weights, **plain) if plain else weights), settings

    def applies_to(self, task: Any) -> bool:
        """Whether the method can plan ``task`` (its mode; a given method needs what it gives)."""
        if task.mode not in self.modes:
            return False
        return self.production != "given" or getattr(task, "teaching", None) is not None

    def __hash__(self) -> int:
        return hash(self.name)

    def cost_terms(self, settings: TermSettings | None = None) -> tuple[CostTerm, ...]:
        """The method's terms with their parameters from ``settings`` (default: the terms' own)."""
        return make_terms(self.terms, settings)

    def term_weight(self, term: CostTerm, weights: CostWeights) -> float:
        """``w_i`` of ``term``: the method's own weight if it sets one, else from ``weights``."""
        return float(self.weights[term.name]) if term.name in self.weights else term.weight(weights)


#: The registry: method name -> method, in registration order.
METHODS: dict[str, Method] = {}


def register_method(method: Method, *, replace: bool = False) -> Method:
    """Add ``method`` to :data:`METHODS`."""
    if method.name in METHODS and not replace:
        raise InvalidInputError(f"method '{method.name}' is already registered")
    METHODS[method.name] = method
    return method


def unregister_method(name: str) -> None:
    """Remove a method (e.g. one a test registered)."""
    METHODS.pop(name, None)


def get_method(name: str | Method) -> Method:
    """The registered method called ``name`` (a :class:`Method` is returned as is)."""
    if isinstance(name, Method):
        return name
    if name not in METHODS:
        load_plugins()  # an installed package's method (forte.planning.methods.plugins)
    if name not in METHODS:
        raise InvalidInputError(f"method: expected one of {', '.join(METHODS)}, got '{name}'")
    return METHODS[name]


def method_names(mode: str | None = None, optimized: bool | None = None) -> tuple[str, ...]:
    """Names of the registered methods, optionally only those for ``mode`` / (not) optimized."""
    load_plugins()  # the installed packages' methods appear with forte's own
    return tuple(m.name for m in METHODS.values()
                 if (mode is None or mode in m.modes) and (optimized is None or m.optimized == optimized))


def _teaching(task: Any) -> FloatArray:
    if task.teaching is None:
        raise TaskFileError(f"{task.source}: teaching_configuration: required for method 'teaching'")
    return task.teaching[None]


def _nominal(task: Any) -> FloatArray:
    return task.nominal()


#: The paper's J1..J5 (J4 split into its arm and base parts).
PAPER_TERMS = ("capability", "manipulability", "joint_limits", "smoothness", "base_smoothness", "base_spectral")
#: The authors' trajectory-regularization terms (everything but J1, J2, J3).
REGULARIZATION = ("smoothness", "velocity", "nominal", "base_smoothness", "base_velocity", "base_spectral",
                  "collision")
#: forte's objective as the authors run it.
FORTE_TERMS = ("capability", "manipulability", "joint_limits", *REGULARIZATION)


def _on_trajectory_sets(changes: Mapping[str, Any]) -> dict[str, Mapping[str, Any]]:
    """A baseline's changes to the authors' trajectory set, for every set built on it, and (the
    changes that are not regularization weights: a single point has none) to ``authors-hold-as-run``."""
    as_run = {k: v for k, v in changes.items() if k not in REGULARIZATION}
    return {name: changes for name in AUTHORS_TRAJECTORY_SETS} | {"authors-hold-as-run": as_run}


_MANIP_DOF = tuple(v / 10 for v in (0, 2, 1, 10, 5, 1, 2, 1, 0, 0))
for _method, _paper in (
    (Method("forte", "the paper's task-sufficient capability objective (J1..J5 + the authors' regularization)",
            terms=FORTE_TERMS, style=MethodStyle("tab:red", "forte (ours)"),
            source="paper, Section 4.3; the authors' public code (their lift weights)"), True),
    (Method("manipulability", "manipulability and joint limits only (no J1, no regularization)",
            terms=("manipulability", "joint_limits"), style=MethodStyle("tab:green", "manipulability", "s"),
            tuning=_on_trajectory_sets({"joint_limits.dof_weights": _MANIP_DOF}),
            source="paper, Section 5; the authors' code"), True),
    (Method("rfp-radius", "J1 replaced by 1/max(|R|, 1e-6), R the alpha-scaled centred inscribed radius, clamped at 0",
            terms=("rfp_radius", "joint_limits", *REGULARIZATION),
            style=MethodStyle("tab:blue", "RFP inscribed radius", "^"),
            tuning=_on_trajectory_sets({"capability": 60.0, "base_velocity": 0.54}),
            source="Ferrolho et al. 2021; the authors' code (residual_force_polytope)"), True),
    (Method("rfp-cone", "J1 replaced by 1/max(|V|, 1e-6), V the RFP's volume in a 0.1 rad cone around f",
            terms=("rfp_cone", "joint_limits", *(t for t in REGULARIZATION if t != "base_spectral")),
            style=MethodStyle("tab:purple", "RFP cone", "v"),
            tuning=_on_trajectory_sets({"capability": 60.0, "joint_limits": 2.0, "velocity": 7.0, "collision": 0.1}),
            source="Ferrolho et al. 2021; the authors' code (cone_intersection_volume)"), True),
    (Method("static-polytope", "J1 replaced by 1/max(|R|, 1e-6), R the inscribed radius with a gravity-only residual",
            terms=("static_radius", "joint_limits", *REGULARIZATION),
            style=MethodStyle("tab:olive", "static force polytope", "x"),
            tuning=_on_trajectory_sets({"capability": 2.0}),
            source="the authors' code (their fourth baseline)"), False),
    (Method("quintic", "the task's nominal trajectory: joint-space quintics through its taught configurations "
            "(IK path for a path of poses), not optimized", production="interpolated", modes=("trajectory",),
            produce=_nominal, status="not optimized (quintic interpolation)",
            style=MethodStyle("tab:gray", "quintic", "D", "--"), source="paper, Section 5.3; the authors' code"), True),
    (Method("ik-path", "the interpolated end-effector path followed by damped least-squares IK (not optimized)",
            production="interpolated", modes=("trajectory",), produce=initial_guess,
            status="not optimized (path + IK)", style=MethodStyle("tab:cyan", "IK path", "d", ":"),
            source="forte"), False),
    (Method("teaching", "the task's teaching configuration (not optimized)", production="given", modes=("hold",),
            produce=_teaching, status="not optimized (teaching point)",
            style=MethodStyle("tab:brown", "teaching point", "P"), source="paper, Section 5.4"), True),
):
    register_method(replace(_method, in_paper=_paper))

__all__ = ["COST_TERMS", "METHODS", "Method", "MethodStyle", "get_method", "method_names", "register_method",
           "unregister_method"]
