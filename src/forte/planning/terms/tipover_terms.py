"""The tip-over term: keep the whole robot's zero-moment point inside the base's support polygon.

Term ``tipover`` (beyond the paper; issue 25, item 3). At waypoint ``k`` the floor's wrench
``(F, N_O)`` of :mod:`forte.model.stability` is computed in CasADi
(:meth:`forte.model.twin.CasadiTwin.ground_wrench`: the base, the arm's universe body and links with
the paper's backward differences of the whole body, base included, and the task wrench ``(f_k,
m_k)`` at the end effector), the ZMP ``z_k = (-N_y / F_z, N_x / F_z)`` (base frame) and its slack to
each edge ``i`` of the support polygon, ``s_ik = h_i - n_i . z_k`` (m). The term's value is

    x_ik = (mu - s_ik) / l,     sigma_k = (1/beta) log(1 + sum_i exp(beta x_ik)),
    c_k  = exp(min(kappa sigma_k, 40)) - 1,           J_tip = sum_k c_k

with ``mu`` the margin the ZMP keeps from the edge (setting ``margin``, default
:data:`DEFAULT_MARGIN` = 0.02 m), ``l`` = 0.01 m (the penalty's length unit), ``beta`` = 10 and
``kappa`` = 3: zero well inside (``s >= mu + 3 l / beta``), about ``kappa / beta`` per edge at the
margin, and growing like ``exp(kappa x)`` past it: a 1 cm violation of the margin costs 19, 3 cm
8100 (times the term's weight, default 10), so the optimizer treats it as the constraint
``s_ik >= mu`` (``sigma_k`` is a smooth upper bound of ``max(0, max_i x_ik)`` within
``log(K + 1) / beta``). The verdict judges the exact margin on the executed motion
(:mod:`forte.planning.verdict.base_requirements`).

A task adds it to every optimized method with ``terms: {tipover: {weight: 10, margin: 0.02}}``
(:mod:`forte.planning.tasks.terms_section`); the margin is an NLP parameter (``tipover_margin``, m) and
so is the task's moment ``m_k`` (``tipover_moment``, N m, zero for a force alone), so one compiled
kernel serves every margin and payload. The robot must state its base support
(``robot.base_support``); its polygon, mass and centre of mass are baked into the kernels through
the robot's fingerprint.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import casadi as ca
import numpy as np

from forte.exceptions import InvalidInputError
from forte.planning.terms.costs import CostTerm, Stage, TermSetting, nonnegative, register_term
from forte.validation import FloatArray

#: Default distance (m) the ZMP keeps inside the support polygon's edge.
DEFAULT_MARGIN = 0.02


@register_term
@dataclass(frozen=True)
class Tipover(CostTerm):
    """``c_k`` of the module docstring (the ZMP kept ``margin`` inside the support polygon)."""

    name: ClassVar[str] = "tipover"
    default_weight: ClassVar[float] = 10.0
    parameters: ClassVar[tuple[tuple[str, int], ...]] = (("tipover_margin", 1), ("tipover_moment", 3))
    settings: ClassVar[tuple[TermSetting, ...]] = (
        TermSetting("margin", "tipover_margin", DEFAULT_MARGIN, "m",
                    "distance the zero-moment point keeps inside the support polygon's edge", valid=nonnegative),)
    length: float = 0.01
    beta: float = 10.0
    kappa: float = 3.0
    max_exponent: float = 40.0

    def stage(self, s: Stage) -> ca.SX:
        support = s.robot.base_support
        if support is None:
            raise InvalidInputError("terms.tipover: the robot states no base support (robot.base_footprint)")
        W = s.twin.ground_wrench(s.q2, s.q1, s.q0, s.dt1, s.dt0, s.f, s.parameters["tipover_moment"])
        zmp = ca.vertcat(-W[4], W[3]) / W[2]
        normal, offset = support.halfplanes()
        slack = ca.DM(offset) - ca.DM(normal) @ zmp
        x = (s.parameters["tipover_margin"] - slack) / self.length
        soft = ca.logsumexp(ca.vertcat(0, self.beta * x)) / self.beta
        return ca.exp(ca.fmin(self.kappa * soft, self.max_exponent)) - 1

    def parameter_values(self, name: str, f: FloatArray, r: FloatArray) -> FloatArray:
        n = len(np.asarray(r))
        return np.full(n, DEFAULT_MARGIN) if name == "tipover_margin" else np.zeros(3 * n)

    @classmethod
    def task_values(cls, force: Any, settings: dict[str, float]) -> dict[str, FloatArray]:
        """The margin (given or default) and the task's moment (zero for a force alone)."""
        moment = np.zeros((len(force.t), 3)) if force.m is None else np.asarray(force.m, dtype=float)
        return super().task_values(force, settings) | {"tipover_moment": moment.ravel()}
