"""What a solve of the trajectory NLP returns, whichever solver ran (IPOPT or the stagewise one)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from forte.settings import SolverOptions
from forte.validation import FloatArray


def accepted_violation(options: SolverOptions) -> float:
    """The largest constraint violation a converged solve may keep: ``max(1e-5, 10 constraint_tol)``."""
    return max(1e-5, 10 * options.constraint_tol)


@dataclass
class SolverResult:
    """What one IPOPT solve returned (the planner turns it into a plan)."""

    q: FloatArray
    success: bool
    status: str
    iterations: int
    objective: float
    constraint_violation: float
    build_time: float
    solve_time: float
    codegen: str  # "compiled", "cached", "virtual-machine"
    lam_x: FloatArray | None = None  # bound multipliers (with ``keep_multipliers``)
    lam_g: FloatArray | None = None  # constraint multipliers
    iterate: Any = None  # the stagewise solver's primal-dual point (its warm start)
    backend: str = "ipopt"  # the solver that ran (``stagewise`` hands a scene to IPOPT)
