"""Whether a trajectory's start posture can carry the task's load at all.

A trajectory starts where the robot is (``q_1 = q_init``, fixed in the NLP), so when the start
posture itself cannot hold the task force with its uncertainty ball, no plan from it is feasible
on capacity, whatever the optimizer does. :func:`start_load` judges the start alone, at rest
(zero velocity and acceleration: the posture's share, not the motion's), on the capacity
requirement (:class:`~forte.planning.verdict.requirements.Capacity`: ``d >= 0`` with the
``alpha``-scaled RFP and the RFP's capacity along the force ``>= |f| + r``) with the task force at
its first time. When it fails it gives the largest payload mass the start carries (bisection,
:func:`~forte.planning.verdict.verdict.largest_mass`) and, when one is found cheaply, a posture
with the same end-effector pose that carries the asked mass: the damped walk of
:func:`~forte.planning.tasks.posture.better_posture` onto the start's pose (no null-space step)
from the start, the home, the joints' centres and :data:`RESTARTS` seeded draws (the base may move
as the arm does); of those within :data:`POSE_TOL` of the pose, free of self-collision and carrying the mass, the
one nearest the start in joint space. :func:`said_at_start` (called by
:func:`forte.planning.planner.plan` on every plan's verdict) adds the sentence to a capacity
failure that includes waypoint 0.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

from forte.model.robot import N_BASE
from forte.model.self_collision import arm_geometry
from forte.planning.tasks.ik import pose_error
from forte.planning.tasks.posture import _walk
from forte.planning.verdict.motion_samples import sample_motion
from forte.planning.verdict.requirements import Capacity
from forte.planning.verdict.verdict import MIN_MASS, Verdict, context, largest_mass, with_load_line
from forte.validation import FloatArray

#: Seeded arm postures tried for a start that carries the load, besides the start, home and centres.
RESTARTS = 24
#: A carrying posture reaches the start's end-effector pose within this (m and rad).
POSE_TOL = 1e-5


class StartLoad(NamedTuple):
    """The start posture's load: ``asked_kg``, the largest mass it ``carries_kg`` (``None``: not even
    an empty hand) and a ``better`` whole-body posture with the same hand pose that carries
    ``asked_kg`` (``None``: none found)."""

    asked_kg: float
    carries_kg: float | None
    better: FloatArray | None

    def line(self) -> str:
        """One sentence for a verdict's capacity detail."""
        most = "not even an empty hand" if self.carries_kg is None else f"at most {self.carries_kg:.3g} kg"
        fix = ("; a posture with the same end-effector pose that can (IK): initial_configuration: "
               f"{[round(float(v), 4) for v in self.better]}" if self.better is not None
               else "; no posture with the same end-effector pose that can was found")
        return (f"the start posture (waypoint 0, t = 0 s: the plan cannot move it) cannot carry "
                f"{self.asked_kg:.3g} kg with its uncertainty ball (it carries {most}){fix}")

    def to_json(self) -> dict[str, Any]:
        return {"asked_kg": self.asked_kg, "carries_kg": self.carries_kg,
                "better": None if self.better is None else [float(v) for v in self.better]}


def carries(task: Any, q: FloatArray, mass: float) -> bool:
    """Whether posture ``q``, at rest, meets the capacity requirement with ``mass`` kg at the task's
    first time."""
    samples = sample_motion(task.robot, task.t[:1], q[None], per_interval=0)
    ctx = context(task.robot, samples, task.force(mass=max(mass, MIN_MASS)), task.settings.alpha, None,
                  task.limits, {}, False)
    return Capacity().check(ctx) is None


def carrying_posture(task: Any, mass: float) -> FloatArray | None:
    """A posture with the start's end-effector pose that carries ``mass`` (see the module's
    docstring), or ``None``."""
    robot, q0 = task.robot, np.asarray(task.q_init, dtype=float)
    target = robot.ee_pose(q0)
    centre = (robot.lower + robot.upper) / 2
    lower, upper = np.maximum(robot.lower, centre - np.pi), np.minimum(robot.upper, centre + np.pi)
    arms = [q0[N_BASE:], robot.home_arm, centre,
            *np.random.default_rng(0).uniform(lower, upper, (RESTARTS, robot.n_arm))]
    geometry = arm_geometry(robot)
    best, best_distance = None, np.inf
    for arm in arms:
        q = _walk(robot, target, np.r_[q0[:N_BASE], arm], nullspace=0.0)
        err = pose_error(robot, q, target)
        if np.linalg.norm(err[:3]) > POSE_TOL or np.linalg.norm(err[3:]) > POSE_TOL:
            continue
        distance = float(np.linalg.norm(q - q0))
        if distance >= best_distance or (geometry is not None and geometry.contact(q[N_BASE:]) is not None):
            continue
        if carries(task, q, mass):
            best, best_distance = q, distance
    return best


def start_load(task: Any) -> StartLoad | None:
    """The start posture's load when it cannot carry the task's payload (``None`` when it can,
    in hold mode, where the start only seeds the solver, and without a payload mass)."""
    mass = task.payload.mass
    if task.mode != "trajectory" or mass is None:
        return None
    q0 = np.asarray(task.q_init, dtype=float)
    force = task.force()
    key = (task.robot.fingerprint, tuple(q0), float(mass), tuple(force.f[0]), float(force.r[0]), float(task.t[0]))
    if key not in _RECENT:  # the matrix asks before planning, the planner after
        if len(_RECENT) > 16:
            _RECENT.clear()
        _RECENT[key] = None if carries(task, q0, mass) else StartLoad(
            float(mass), largest_mass(lambda m: carries(task, q0, m), float(mass)), carrying_posture(task, mass))
    return _RECENT[key]


#: Answers of :func:`start_load` for recent starts (robot, start, mass, the force at the start).
_RECENT: dict[tuple, StartLoad | None] = {}


def said_at_start(task: Any, verdict: Verdict) -> Verdict:
    """``verdict`` with its capacity failure at waypoint 0 said as the start posture's when the
    start, at rest, cannot carry the payload (:func:`start_load`; ``payload_bound["start"]``
    records it)."""
    return with_load_line(verdict, 0, "start", lambda: start_load(task))
