"""A collision-free whole-body path from start to goal configuration (OMPL's RRT-Connect).

**The space** is the joints that move: the arm's joints within their limits for ``base: fixed``
(the base entries of every waypoint stay at the start's), else ``x, y, yaw`` and the arm. The base
box is the start's and goal's ``x, y`` plus :data:`BASE_REACH` on each side, and ``yaw`` a bounded
real within pi of both. A *differential* base is searched as a holonomic one: the path may slide
sideways, and the NLP that takes the path as its initial guess enforces the drive.

**Valid states** (:class:`~forte.planning.search.validity.StateChecker`): within the joint limits,
no self-collision, and every scene distance >= the clearance. The search keeps
:data:`SEARCH_MARGIN` more than the asked ``clearance`` when the start and goal allow it, so the
NLP that smooths the path and keeps only the asked clearance starts strictly inside it; a search
that finds no path in :data:`MARGIN_SHARE` of its budget with the margin spends the rest
without it (a narrow passage, a shelf's slot, is often open at the asked clearance only). Motions
between states are checked every :data:`CHECK_STEP` (C-space distance: rad for a joint, m for the
base), i.e. 1-2 cm of end-effector motion for a hand up to ~1 m from the moving joint.

**The path**: RRT-Connect's solution, shortcut by OMPL's ``simplifySolution`` (reduce vertices,
shortcut, smooth; every new segment checked), then states inserted on the segments so that no two
are more than :data:`SPACING` apart. OMPL's generator is seeded, so a seed repeats a path when the
search ends before its time limit.
"""

from __future__ import annotations

import time
from typing import Any, NamedTuple

import numpy as np

from forte.exceptions import InvalidInputError
from forte.model.robot import N_BASE, MobileManipulator
from forte.model.scene import Scene
from forte.planning.search.validity import StateChecker
from forte.validation import FloatArray

#: Extra clearance (m) the search keeps beyond the asked one (when the start and goal have it).
SEARCH_MARGIN = 0.01
#: The share of the time limit (and of the check budget) the search spends with the margin before it
#: tries without.
MARGIN_SHARE = 0.4
#: Largest C-space step (rad or m) between two checked states of a motion.
CHECK_STEP = 0.015
#: Largest C-space distance between two states of the returned path.
SPACING = 0.2
#: How far (m) beyond the start's and goal's base position the base may go.
BASE_REACH = 1.0
#: The planners find_path knows.
PLANNERS = ("rrtconnect",)


class SearchResult(NamedTuple):
    """``q``: M x nq waypoints from start to goal (``None`` when not found); ``reason``: why not
    (``""`` when found); ``states``: states the planner sampled; ``checks``: validity checks;
    ``time_s``: wall time of the whole search, of which ``shortcut_s`` went to shortcutting the
    found path."""

    q: FloatArray | None
    found: bool
    reason: str
    states: int
    checks: int
    time_s: float
    shortcut_s: float = 0.0


def ompl_modules() -> tuple[Any, Any, Any]:
    """OMPL's ``base``, ``geometric`` and ``util`` with its log silenced, or one clear line."""
    try:
        from ompl import base as ob
        from ompl import geometric as og
        from ompl import util as ou
    except ImportError as exc:
        raise InvalidInputError("the path search needs the 'ompl' package (a dependency of forte): pip install ompl"
                                ) from exc
    ou.setLogLevel(ou.LogLevel.LOG_WARN)
    return ob, og, ou


def moving_joints(robot: MobileManipulator) -> FloatArray:
    """Indices into ``q`` of the searched joints (module docstring)."""
    start = N_BASE if robot.base == "fixed" else 0
    return np.arange(start, robot.nq)


def space_bounds(robot: MobileManipulator, q_start: FloatArray, q_goal: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Lower and upper bounds of the searched joints."""
    lo, hi = robot.lower, robot.upper
    if robot.base == "fixed":
        return lo.copy(), hi.copy()
    ends = np.array([q_start[:N_BASE], q_goal[:N_BASE]])
    reach = np.array([BASE_REACH, BASE_REACH, np.pi])
    return np.r_[ends.min(axis=0) - reach, lo], np.r_[ends.max(axis=0) + reach, hi]


def find_path(robot: MobileManipulator, scene: Scene, q_start: Any, q_goal: Any, clearance: float = 0.0, *,
              time_limit: float = 2.0, seed: int = 0, planner: str = "rrtconnect",
              floor: float | None = None, checks: int | None = None) -> SearchResult:
    """A collision-free path from ``q_start`` to ``q_goal`` (whole-body, nq each) with the scene
    distance >= ``clearance`` (m) everywhere (module docstring); ``floor`` replaces the scene's.

    The search stops at ``time_limit`` (s) or, when given, after ``checks`` state checks: a budget
    of checks makes the outcome the same on a busy machine as on an idle one (a seed repeats its
    path), where a time limit finds less the busier the machine."""
    t0 = time.perf_counter()
    if planner not in PLANNERS:
        raise InvalidInputError(f"planner: expected one of {', '.join(PLANNERS)}, got {planner!r}")
    q_start = robot.check_configuration(q_start, "q_start")
    q_goal = robot.check_configuration(q_goal, "q_goal")
    if robot.base == "fixed":
        q_goal = np.r_[q_start[:N_BASE], q_goal[N_BASE:]]
    checker = StateChecker(robot, scene, clearance, floor)
    for label, q in (("start", q_start), ("goal", q_goal)):
        if not checker.valid(q):
            return SearchResult(None, False, f"{label} configuration in collision: {checker.why(q)}", 0,
                                checker.checks, time.perf_counter() - t0)
    margin = StateChecker(robot, scene, clearance + SEARCH_MARGIN, floor)
    path, states, shortcut = None, 0, 0.0
    if margin.valid(q_start) and margin.valid(q_goal):  # first with the margin, for part of the time
        budget = None if checks is None else int(MARGIN_SHARE * checks)
        path, states, shortcut = _search(robot, margin, q_start, q_goal, (MARGIN_SHARE * time_limit, budget), seed)
        checker.checks += margin.checks
    if path is None:  # the margin may close a narrow passage the asked clearance leaves open
        left = (time_limit - (time.perf_counter() - t0), None if checks is None else checks - checker.checks)
        path, more, shortcut = _search(robot, checker, q_start, q_goal, left, seed)
        states += more
    elapsed = time.perf_counter() - t0
    if path is None:
        spent = f"{checker.checks} state checks" if checks is not None and elapsed < time_limit else f"{time_limit:g} s"
        return SearchResult(None, False, f"no collision-free path in {spent} ({states} states sampled, "
                            f"{elapsed:.1f} s)", states, checker.checks, elapsed)
    return SearchResult(path, True, "", states, checker.checks, elapsed, shortcut)


def _search(robot: MobileManipulator, checker: StateChecker, q_start: FloatArray, q_goal: FloatArray,
            limit: tuple[float, int | None], seed: int) -> tuple[FloatArray | None, int, float]:
    """RRT-Connect until ``limit`` (seconds, and state checks when not ``None``), shortcut and
    interpolated; the path (or ``None``), the states sampled and the shortcut's time (s)."""
    ob, og, ou = ompl_modules()
    ou.setLogLevel(ou.LogLevel.LOG_NONE)  # re-seeding after an earlier search logs an error, yet
    ou.RNG.setSeed(int(seed) + 1)  # every generator made after it (planner, sampler) is seeded; 0 = none
    ou.setLogLevel(ou.LogLevel.LOG_WARN)
    joints = moving_joints(robot)
    lo, hi = space_bounds(robot, q_start, q_goal)
    space = ob.RealVectorStateSpace(len(joints))
    bounds = ob.RealVectorBounds(len(joints))
    for i, (a, b) in enumerate(zip(lo, hi, strict=True)):
        bounds.setLow(i, float(a))
        bounds.setHigh(i, float(b))
    space.setBounds(bounds)
    setup = og.SimpleSetup(space)
    q = q_start.copy()

    def valid(state: Any) -> bool:
        q[joints] = [state[i] for i in range(len(joints))]
        return checker.valid(q)

    setup.setStateValidityChecker(valid)
    info = setup.getSpaceInformation()
    info.setStateValidityCheckingResolution(CHECK_STEP / space.getMaximumExtent())
    start, goal = space.allocState(), space.allocState()
    for i, j in enumerate(joints):
        start[i], goal[i] = float(q_start[j]), float(q_goal[j])
    setup.setStartAndGoalStates(start, goal)
    setup.setPlanner(og.RRTConnect(info))
    seconds, budget = limit
    stop = ob.timedPlannerTerminationCondition(max(float(seconds), 0.0))
    if budget is not None:
        first = checker.checks
        spent = ob.PlannerTerminationCondition(lambda: checker.checks - first >= budget)
        stop = ob.plannerOrTerminationCondition(stop, spent)
    solved = setup.solve(stop) and setup.haveExactSolutionPath()
    data = ob.PlannerData(info)
    setup.getPlannerData(data)
    states = int(data.numVertices())
    if not solved:
        return None, states, 0.0
    begin = time.perf_counter()
    setup.simplifySolution()
    shortcut = time.perf_counter() - begin
    path = setup.getSolutionPath()
    path.interpolate(max(path.getStateCount(), int(np.ceil(path.length() / SPACING)) + 1))
    out = np.repeat(q_start[None], path.getStateCount(), axis=0)
    for k in range(path.getStateCount()):
        out[k, joints] = [path.getState(k)[i] for i in range(len(joints))]
    return out, states, shortcut
