"""Planning methods (paper, Section 5): one :class:`Method` entry per method, in a registry.

A method says which modes it applies to, how its plan is produced and, for optimized methods,
which cost terms (:mod:`forte.planning.costs`) make up its objective. Everything that lists
methods (the CLI's choices, ``forte compare``, the experiments, plot colours, kernel cache keys)
is derived from :data:`METHODS`; adding a method is one :func:`register_method` call.

Built-in methods:

- ``forte``: the paper's objective ``w1 J1 + w2 J2 + w3 J3 + w4 J4 + w5 J5``;
- ``manipulability``: the same without ``J1``;
- ``rfp-radius`` / ``rfp-cone``: ``J1`` replaced by ``1 / max(|value|, eps)`` of the centred
  inscribed radius or the cone measure of the RFP (Ferrolho et al. 2021);
- ``quintic`` (trajectory mode): the interpolated path followed by damped least-squares IK, not
  optimized (also the optimizer's initial guess);
- ``teaching`` (hold mode): the task's teaching configuration, not optimized.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import Any

from forte.exceptions import InvalidInputError, TaskFileError
from forte.planning.costs import COST_TERMS, CostTerm, make_terms
from forte.planning.ik import initial_guess
from forte.planning.tasks import MODES
from forte.settings import CostWeights
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
            make_terms(self.terms, CostWeights())  # every term must be registered
        elif self.produce is None:
            raise InvalidInputError(f"method {self.name}: a method that is not optimized needs produce")
        object.__setattr__(self, "weights", MappingProxyType(dict(self.weights)))
        if not self.style.label:
            object.__setattr__(self, "style", MethodStyle(self.style.color, self.name, self.style.marker,
                                                          self.style.linestyle))

    @property
    def optimized(self) -> bool:
        return self.production == "optimized"

    def applies_to(self, task: Any) -> bool:
        """Whether the method can plan ``task`` (its mode; a given method needs what it gives)."""
        if task.mode not in self.modes:
            return False
        return self.production != "given" or getattr(task, "teaching", None) is not None

    def __hash__(self) -> int:
        return hash(self.name)

    def cost_terms(self, weights: CostWeights) -> tuple[CostTerm, ...]:
        """The method's terms with their parameters from ``weights``."""
        return make_terms(self.terms, weights)

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
        raise InvalidInputError(f"method: expected one of {', '.join(METHODS)}, got '{name}'")
    return METHODS[name]


def method_names(mode: str | None = None, optimized: bool | None = None) -> tuple[str, ...]:
    """Names of the registered methods, optionally only those for ``mode`` / (not) optimized."""
    return tuple(m.name for m in METHODS.values()
                 if (mode is None or mode in m.modes) and (optimized is None or m.optimized == optimized))


def _teaching(task: Any) -> FloatArray:
    if task.teaching is None:
        raise TaskFileError(f"{task.source}: teaching_configuration: required for method 'teaching'")
    return task.teaching[None]


PAPER_TERMS = ("capability", "manipulability", "joint_limits", "smoothness", "base_spectral")
for _method in (
    Method("forte", "the paper's task-sufficient capability objective (J1..J5)", terms=PAPER_TERMS,
           style=MethodStyle("tab:red", "forte (ours)"), source="paper, Section 4.3"),
    Method("manipulability", "manipulability only: the forte objective without J1", terms=PAPER_TERMS[1:],
           style=MethodStyle("tab:green", "manipulability", "s"), source="paper, Section 5"),
    Method("rfp-radius", "J1 replaced by 1/max(|R|, eps), R the RFP's centred inscribed radius",
           terms=("rfp_radius", *PAPER_TERMS[1:]), style=MethodStyle("tab:blue", "RFP inscribed radius", "^"),
           source="Ferrolho et al. 2021"),
    Method("rfp-cone", "J1 replaced by 1/max(|V|, eps), V the RFP's volume in a cone around f",
           terms=("rfp_cone", *PAPER_TERMS[1:]), style=MethodStyle("tab:purple", "RFP cone", "v"),
           source="Ferrolho et al. 2021"),
    Method("quintic", "the quintic path followed by damped least-squares IK (not optimized)",
           production="interpolated", modes=("trajectory",), produce=initial_guess,
           status="not optimized (quintic path + IK)", style=MethodStyle("tab:gray", "quintic", "D", "--"),
           source="paper, Section 5.3"),
    Method("teaching", "the task's teaching configuration (not optimized)", production="given", modes=("hold",),
           produce=_teaching, status="not optimized (teaching point)",
           style=MethodStyle("tab:brown", "teaching point", "P"), source="paper, Section 5.4"),
):
    register_method(replace(_method, in_paper=True))

__all__ = ["COST_TERMS", "METHODS", "Method", "MethodStyle", "get_method", "method_names", "register_method",
           "unregister_method"]
