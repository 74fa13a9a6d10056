"""forte: task-adaptive force-capability trajectory optimization for mobile manipulators.

The package follows the data flow, one subpackage per stage (each imports only the ones above
it in this list):

- :mod:`forte.model`: the mobile manipulator (Pinocchio), its CasADi twin, time differences;
- :mod:`forte.force`: payloads, mass estimation (VLM or offline), desired task forces;
- :mod:`forte.capability`: the dynamic residual force polytope and the capability metric;
- :mod:`forte.planning`: task files, cost terms, methods, the NLP and the planner;
- :mod:`forte.io`: plan directories, reports and figures;
- :mod:`forte.execution`: MuJoCo simulation with the paper's controllers;
- :mod:`forte.experiments`: the paper's experiments;
- :mod:`forte.cli`: the ``forte`` command.

The names below are the public API; they are imported on first use, so ``import forte`` is
quick.

Examples:
    A short session (run from the repository root):

    >>> import forte
    >>> task = forte.load_task("examples/tasks/hold.yaml", mass=0.35)
    >>> task.mode, task.n
    ('hold', 1)
    >>> [name for name in forte.METHODS if forte.METHODS[name].in_paper]
    ['forte', 'manipulability', 'rfp-radius', 'rfp-cone', 'quintic', 'teaching']
"""

from __future__ import annotations

import importlib
from typing import Any

__version__ = "0.1.0"

#: Public name -> module that defines it.
_API: dict[str, str] = {
    "load_task": "forte.planning.tasks.tasks",
    "Task": "forte.planning.tasks.tasks",
    "plan": "forte.planning.planner",
    "compare": "forte.planning.planner",
    "Plan": "forte.planning.planner",
    "evaluate": "forte.planning.verdict.evaluation",
    "Replanner": "forte.planning.online.replan",
    "RealTimeIteration": "forte.planning.online.realtime",
    "StartMotion": "forte.model.trajectory",
    "METHODS": "forte.planning.methods.catalog",
    "Method": "forte.planning.methods.catalog",
    "MethodStyle": "forte.planning.methods.catalog",
    "register_method": "forte.planning.methods.catalog",
    "COST_TERMS": "forte.planning.terms.costs",
    "CostTerm": "forte.planning.terms.costs",
    "Stage": "forte.planning.terms.costs",
    "register_term": "forte.planning.terms.costs",
    "CostWeights": "forte.settings",
    "CapabilityParameters": "forte.settings",
    "SolverOptions": "forte.settings",
    "KinematicLimits": "forte.settings",
    "default_robot": "forte.model.robot",
    "MobileManipulator": "forte.model.robot",
    "residual_force_polytope": "forte.capability.polytope",
    "ResidualForcePolytope": "forte.capability.polytope",
    "capability_margin": "forte.capability.metrics",
    "payload_force": "forte.force.taskforce",
    "Payload": "forte.force.payload",
    "estimate_payload": "forte.force.estimate",
    "write_plan": "forte.io.plandir",
    "read_plan_dir": "forte.io.plandir",
    "simulate": "forte.execution.run",
}

__all__ = sorted(_API)


def __getattr__(name: str) -> Any:
    if name not in _API:
        raise AttributeError(f"module 'forte' has no attribute '{name}'")
    module = importlib.import_module(_API[name])
    value = getattr(module, name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted([*globals(), *_API])
