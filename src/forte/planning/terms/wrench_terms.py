"""J1 on the residual wrench polytope, and how a method uses it when the task needs a moment.

:class:`WrenchCapability` is the ``capability`` term of :mod:`forte.planning.terms.capability_terms` with
the 6-D metric of :mod:`forte.capability.wrench`: its per-waypoint expression is the smooth
surrogate ``c_k`` of the uncertainty set ``U_k`` (force ball ``r_k`` around ``f_k``, moment ball
``r_m,k`` around ``m_k``) against the alpha-scaled residual wrench polytope, with moments scaled by
``L``. It has the capability weight ``w_1`` and the same :class:`~forte.settings.CapabilityParameters`.

The term owns its parameters: the moment ``m_k`` (3), ``r_m,k`` (1) and ``L`` (1) are per-waypoint
NLP parameters it declares (:attr:`WrenchCapability.parameters`), filled from the task's
requirement by :func:`term_values` (a :class:`~forte.force.taskforce.TaskForce` with its moment);
nothing is added to :class:`~forte.settings.CostWeights`, and the compiled kernels serve every
payload (no payload value is baked in).

:func:`for_requirement` gives the method a plan is solved with: the method itself for a force
alone, else the same method (same name, weights, style) with ``capability`` replaced by
``wrench_capability``. A task with a zero offset and no inertia needs no moment, so its plans
are solved with today's kernels, unchanged.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any, ClassVar

import casadi as ca
import numpy as np

from forte.capability.wrench import smooth_wrench_penalty_expr
from forte.exceptions import InvalidInputError
from forte.planning.terms.capability_terms import capability_params
from forte.planning.terms.costs import CostTerm, Stage, register_term
from forte.settings import CapabilityParameters
from forte.validation import FloatArray

#: The 3-D capability term and its wrench variant.
FORCE_TERM, WRENCH_TERM = "capability", "wrench_capability"


@register_term
@dataclass(frozen=True)
class WrenchCapability(CostTerm):
    """J1 on the residual wrench polytope: the smooth surrogate
    :func:`~forte.capability.wrench.smooth_wrench_penalty_expr` of the task's wrench."""

    name: ClassVar[str] = WRENCH_TERM
    weight_field: ClassVar[str | None] = "capability"
    parameters: ClassVar[tuple[tuple[str, int], ...]] = (("moment", 3), ("moment_radius", 1), ("moment_scale", 1))
    settings_of: ClassVar[str | None] = FORCE_TERM
    params: CapabilityParameters = field(default_factory=CapabilityParameters)

    @classmethod
    def from_settings(cls, settings: Any = None) -> CostTerm:
        return cls(capability_params(settings))

    def stage(self, s: Stage) -> ca.SX:
        p = s.parameters
        return smooth_wrench_penalty_expr(s.J6, s.tau, ca.DM(s.robot.torque_limits), s.f, p["moment"], s.r,
                                          p["moment_radius"], p["moment_scale"], self.params)

    def parameter_values(self, name: str, f: FloatArray, r: FloatArray) -> FloatArray:
        raise InvalidInputError(f"cost term '{self.name}': its parameter '{name}' comes from the task's moment; "
                                "solve with term_values(force) (forte.planning.terms.wrench_terms)")


def term_values(force: Any) -> dict[str, FloatArray]:
    """The values of :class:`WrenchCapability`'s parameters for a task force with its moment
    (``m`` row by row, ``r_m``, ``L`` per waypoint); empty for a force alone."""
    if force is None or not force.has_moment:
        return {}
    n = len(force.t)
    return {"moment": np.asarray(force.m, dtype=float).ravel(), "moment_radius": force.r_m,
            "moment_scale": np.full(n, float(force.moment_scale))}


def for_requirement(method: Any, force: Any) -> Any:
    """The method a plan for ``force`` is solved with: ``method`` itself unless the force carries a
    moment and the method uses the 3-D ``capability`` term, which then becomes ``wrench_capability``
    (the method's own weight for it follows)."""
    if force is None or not force.has_moment or FORCE_TERM not in method.terms:
        return method
    terms = tuple(WRENCH_TERM if t == FORCE_TERM else t for t in method.terms)
    weights = {WRENCH_TERM if k == FORCE_TERM else k: v for k, v in method.weights.items()}
    return replace(method, terms=terms, weights=weights)


def uses_capability(method: Any) -> bool:
    """Whether the method's objective uses the uncertainty ball (J1 in 3-D or 6-D)."""
    return FORCE_TERM in method.terms or WRENCH_TERM in method.terms
