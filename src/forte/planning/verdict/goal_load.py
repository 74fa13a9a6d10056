"""Whether a goal task's last configuration can hold the task's load at all.

A goal task's motion ends at rest at its goal configuration (a configuration goal's own; a pose
goal's: the plan's last configuration, which the IK chose). When that configuration, at rest (zero
velocity and acceleration: the posture's share alone), fails the capacity requirement
(:class:`~forte.planning.verdict.requirements.Capacity`: ``d >= 0`` with the ``alpha``-scaled RFP
and the RFP's capacity along the force ``>= |f| + r``) with the task force at the last time, no
motion that ends there is feasible on capacity, however slow: the force the arm's motion adds
(``(m + m_tool) p''`` and its own inertial torques) only shrinks as the motion slows, and at rest
it is zero. The force is the load held still (the task following a motion that stays at the goal:
``(m + m_tool) (-g)`` with ``force_model: paper``). :func:`goal_load` gives the shortfall (N,
``max(-d, |f| + r - capacity)``) and the largest payload mass the configuration holds (bisection,
:func:`~forte.planning.verdict.verdict.largest_mass`); :func:`said_at_goal` (called by
:func:`forte.planning.planner.plan` on every plan's verdict) adds the sentence to a capacity
failure that includes the last waypoint; :func:`forte.planning.rounds.slower` does not slow down
a motion whose goal cannot hold the load.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

from forte.planning.verdict.motion_samples import sample_motion
from forte.planning.verdict.requirements import Capacity
from forte.planning.verdict.verdict import MIN_MASS, Verdict, context, largest_mass, with_load_line
from forte.validation import FloatArray


class GoalLoad(NamedTuple):
    """The goal configuration's load at rest: ``asked_kg``, the ``shortfall_n`` (N) with it, the
    largest mass it ``carries_kg`` (``None``: not even an empty hand) and whether the goal is a
    ``pose`` (another configuration with the same pose may hold the load)."""

    asked_kg: float
    shortfall_n: float
    carries_kg: float | None
    pose: bool

    def line(self) -> str:
        """One sentence for a verdict's capacity detail."""
        most = "not even an empty hand" if self.carries_kg is None else f"at most {self.carries_kg:.3g} kg"
        which = ("the goal configuration (the plan's last, chosen for the goal pose)" if self.pose
                 else "the goal configuration")
        after = ("; another configuration with the goal pose may" if self.pose
                 else "; no motion that ends there can, however slow")
        return (f"{which} cannot hold the load: at rest it is {self.shortfall_n:.3g} N short of holding "
                f"{self.asked_kg:.3g} kg with its uncertainty ball (it holds {most}){after}")

    def to_json(self) -> dict[str, Any]:
        return {"asked_kg": self.asked_kg, "shortfall_n": self.shortfall_n, "carries_kg": self.carries_kg,
                "pose": self.pose}


def shortfall_at_rest(task: Any, q_end: FloatArray, mass: float) -> float:
    """The capacity shortfall (N, ``max(-d, |f| + r - capacity, 0)``) of ``q_end`` at rest holding
    ``mass`` kg still, at the task's last time."""
    q_end = np.asarray(q_end, dtype=float)
    still = task.following(np.repeat(q_end[None], task.n, axis=0))
    samples = sample_motion(task.robot, task.t[-1:], q_end[None], per_interval=0)
    ctx = context(task.robot, samples, still.force(mass=max(mass, MIN_MASS)), task.settings.alpha, None,
                  task.limits, {}, False)
    return max(0.0, *(float(m.value[0]) for m in Capacity().measures(ctx)))


def goal_load(task: Any, q_end: FloatArray) -> GoalLoad | None:
    """The load of a goal task's last configuration ``q_end`` when it cannot hold the task's payload
    at rest (``None`` when it can, for a task that is not a goal task, and without a payload mass)."""
    mass = task.payload.mass
    if task.goal is None or task.mode != "trajectory" or mass is None:
        return None
    short = shortfall_at_rest(task, q_end, float(mass))
    if short <= 0.0:
        return None
    carried = largest_mass(lambda m: shortfall_at_rest(task, q_end, m) <= 0.0, float(mass))
    return GoalLoad(float(mass), short, carried, task.goal.pose is not None)


def said_at_goal(task: Any, q: FloatArray, verdict: Verdict) -> Verdict:
    """``verdict`` with its capacity failure at the last waypoint said as the goal configuration's
    when that configuration (``q[-1]``), at rest, cannot hold the payload (:func:`goal_load`;
    ``payload_bound["goal"]`` records it)."""
    return with_load_line(verdict, len(q) - 1, "goal", lambda: goal_load(task, np.asarray(q)[-1]))
