"""A pose goal's configuration clear of the scene, before the search runs to it.

A pose goal (``path.pose``) fixes the hand, not the body: the task reader solves one IK
configuration from the start (:func:`~forte.planning.tasks.goal_poses.reach`), which knows nothing
of the scene, and the search (:mod:`forte.planning.search.sampling`) plans to that configuration.
In clutter it can be in collision while another arm posture, or another base placement, holds
the hand at the same pose clear of every body (MotionBenchMaker's goals on the authors' mobile
base: the IK from the start put ``panda_link5`` 4-8 cm into a table or the base).

:func:`free_goal` keeps the reader's configuration when it is valid (joint limits, the scene at
the clearance a configuration held at rest keeps, the executor's margin at rest plus the slip
at least (:data:`~forte.planning.verdict.margin.REST_MARGIN`: the goal is where the robot stops, and a
grasp's fingers end within 1-2 cm of the object), no self-collision:
:class:`~forte.planning.search.validity.StateChecker`; or at the task's own clearance when no
other start finds one),
else solves the same pose from :data:`GOAL_IK_STARTS` seeded starts (the arm drawn within its
limits; a mobile base held at the start's place for every other start, the arm alone solving,
else drawn within :data:`BASE_SPREAD` of the reader's) and keeps, of the
valid solutions that reach the pose within the IK's own tolerances, the one nearest the start
(largest joint step). The NLP poses the goal pose, not the configuration, so any of them is the
same task.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from forte.model.robot import N_BASE, MobileManipulator
from forte.model.scene import Scene
from forte.planning.search.sampling import wanted
from forte.planning.search.validity import StateChecker
from forte.planning.tasks.ik import IKOptions, solve_pose
from forte.validation import FloatArray

#: IK starts tried when the reader's goal configuration is not free.
GOAL_IK_STARTS = 48
#: Valid solutions gathered before the nearest is kept.
ENOUGH = 4
#: How far (m, m, rad) a mobile base's IK start may be drawn from the reader's goal base.
BASE_SPREAD = (0.4, 0.4, np.pi / 3)


class FreeGoal(NamedTuple):
    """``q``: a valid configuration at the goal pose (``None`` when no start found one);
    ``tried``: IK starts solved; ``reason``: why the reader's configuration was replaced or why
    none was found (``""`` when it was kept)."""

    q: FloatArray | None
    tried: int
    reason: str


def free_goal(robot: MobileManipulator, scene: Scene, clearance: float, q_start: FloatArray, q_goal: FloatArray,
              pose: FloatArray, seed: int = 0) -> FreeGoal:
    """A configuration reaching ``pose`` (4 x 4) that is valid in ``scene`` at the clearance a route
    keeps at rest (:func:`~forte.planning.search.sampling.wanted`: ``clearance``, the executor's
    margin at rest at least, plus the slip), else at ``clearance`` (module docstring); ``q_goal``
    is kept when it is."""
    checker = StateChecker(robot, scene, wanted(clearance, None))
    asked = StateChecker(robot, scene, clearance)
    if checker.valid(q_goal):
        return FreeGoal(np.asarray(q_goal, dtype=float), 0, "")
    why = checker.why(q_goal) or asked.why(q_goal) or "within the executor's margin"
    options = IKOptions()
    arm_only = IKOptions(base_weight=1e9)  # the base all but held where it stands
    rng = np.random.default_rng(seed)
    found: list[FloatArray] = []
    tried = 0
    for i in range(GOAL_IK_STARTS):
        start = np.asarray(q_goal, dtype=float).copy()
        start[N_BASE:] = rng.uniform(robot.lower, robot.upper)
        if robot.base != "fixed":  # every other start from where the base stands at the start
            start[:N_BASE] = (np.asarray(q_goal[:N_BASE], dtype=float) + rng.uniform(-1.0, 1.0, N_BASE)
                              * np.asarray(BASE_SPREAD)) if i % 2 else np.asarray(q_start[:N_BASE], dtype=float)
        tried += 1
        q, err = solve_pose(robot, pose, start, options if i % 2 or robot.base == "fixed" else arm_only)
        reached = np.linalg.norm(err[:3]) <= options.position_tolerance and \
            np.linalg.norm(err[3:]) <= options.orientation_tolerance
        if reached and checker.valid(q):
            found.append(q)
            if len(found) >= ENOUGH:
                break
    if not found and asked.valid(q_goal):  # clear at the asked clearance, only closer than the margin
        return FreeGoal(np.asarray(q_goal, dtype=float), tried, "")
    if not found:
        return FreeGoal(None, tried, f"the goal pose's IK configuration is in collision ({why}) and none of "
                                     f"{tried} IK starts reaches the pose clear of the scene")
    steps = [float(np.max(np.abs(q - np.asarray(q_start, dtype=float)))) for q in found]
    best = found[int(np.argmin(steps))]
    return FreeGoal(best, tried, f"the goal pose's IK configuration from the start was in collision ({why}); "
                                 f"one of {len(found)} clear IK solutions ({tried} starts) replaces it")
