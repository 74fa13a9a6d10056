"""What would work: the largest payload a task's path can carry with a method.

When a plan's verdict fails on capacity or torque, two bounds answer "how much could it carry?":

- ``fixed_motion_kg``: with the plan's own motion (computed with the verdict,
  :func:`forte.planning.verdict.verdict.fixed_motion_bound`: the force recomputed for each mass, the
  motion unchanged);
- ``replanned_kg`` (:func:`replanned_bound`): with the method re-planning the task for each mass,
  by bisection on the verdict of the new plan. The largest mass whose plan was judged feasible is
  returned, so planning the task at that mass gives a feasible plan (a re-plan is deterministic).
"""

from __future__ import annotations

from typing import NamedTuple

from forte.planning.planner import plan
from forte.planning.tasks.tasks import Task
from forte.planning.verdict.verdict import MIN_MASS, largest_mass

#: Mass resolution (kg) of the re-planned bound (each step is one solve).
REPLANNED_RESOLUTION = 0.05


class PayloadBound(NamedTuple):
    """The largest payload (kg) the path carries: ``asked_kg`` the task's mass, ``replanned_kg``
    with ``method`` re-planning for each mass (``None``: not even without payload, when the
    re-plan without payload failed on ``unloaded_failed``)."""

    method: str
    asked_kg: float
    replanned_kg: float | None
    unloaded_failed: tuple[str, ...] = ()

    def sentence(self) -> str:
        """What was tried and what came of it, in one clause."""
        if self.replanned_kg is None:
            failed = ", ".join(self.unloaded_failed) or "its verdict"
            return f"re-planned with {self.method} without payload, the task still fails on {failed}"
        if self.replanned_kg >= self.asked_kg:
            return f"{self.method} plans this task feasibly at the asked {self.asked_kg:g} kg"
        return (f"this path can carry at most {self.replanned_kg:.2f} kg with {self.method} "
                f"(asked: {self.asked_kg:g} kg)")


def replanned_bound(task: Task, method: str = "forte", resolution: float = REPLANNED_RESOLUTION) -> PayloadBound:
    """The largest payload mass for which ``method`` plans ``task`` feasibly (bisection between 0
    and the task's own mass, to ``resolution``); when even the plan without payload fails, the
    requirements it fails on."""
    asked = task.payload.mass
    if asked is None:
        raise ValueError("replanned_bound: the task has no payload mass")
    failed: dict[float, tuple[str, ...]] = {}

    def holds(mass: float) -> bool:
        verdict = plan(task.with_payload(task.payload.with_mass(max(mass, MIN_MASS), "bound")), method).verdict
        failed[mass] = verdict.failed
        return verdict.feasible

    found = largest_mass(holds, asked, resolution)
    return PayloadBound(method, float(asked), found, failed.get(0.0, ()) if found is None else ())
