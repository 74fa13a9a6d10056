"""The primal-dual points, evaluations and results of the stagewise interior-point method
(:mod:`forte.planning.nlp.solvers.interior_point`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

from forte.validation import FloatArray


@dataclass
class Iterate:
    """A primal-dual point."""

    y: FloatArray
    lam: FloatArray  # P x 6
    s: FloatArray
    zl: FloatArray
    zu: FloatArray
    mu: float
    scale: float = 1.0  # objective scaling (IPOPT's gradient-based: max |grad f| at the start <= 100)

    def copy(self) -> Iterate:
        def cp(a: FloatArray | None) -> FloatArray | None:
            return None if a is None else a.copy()
        return Iterate(self.y.copy(), self.lam.copy(), self.s.copy(), cp(self.zl), cp(self.zu), self.mu, self.scale)


class StepInfo(NamedTuple):
    """What one iteration measured at its starting point and did."""

    error: float  # scaled KKT error at mu = 0 before the step
    violation: float  # constraint violation before the step
    alpha: float
    delta: float  # inertia correction


@dataclass
class Evaluation:
    """Derivatives at one iterate."""

    f: float
    grad: FloatArray
    c: FloatArray
    J: FloatArray
    rA: FloatArray
    extras: dict = field(default_factory=dict)


class IPResult(NamedTuple):
    """The end of a solve."""

    iterate: Iterate
    converged: bool
    iterations: int
    status: str  # IPOPT's names: Solve_Succeeded, Maximum_Iterations_Exceeded, ...
    objective: float
    violation: float
    history: list[StepInfo]
