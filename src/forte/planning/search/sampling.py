"""A collision-free whole-body path from start to goal configuration (OMPL's RRT-Connect).

**The space** is the joints that move: the arm's joints within their limits for ``base: fixed``
(the base entries of every waypoint stay at the start's), else ``x, y, yaw`` and the arm. The base
box is the start's and goal's ``x, y`` plus :data:`BASE_REACH` on each side, and ``yaw`` a bounded
real within pi of both. A *differential* base is searched as a holonomic one: the path may slide
sideways, and the NLP that takes the path as its initial guess enforces the drive.

**Valid states** (:class:`~forte.planning.search.validity.StateChecker`): within the joint limits,
no self-collision, and every scene distance >= a clearance. The path keeps the *kept clearance*
(:func:`kept`): what the verdict will ask of the motion (the executor's margin of the robot's base
kind, :func:`~forte.planning.verdict.margin.execution_margin`: 2 mm on every base kind at present;
or the asked clearance when larger) plus :data:`SLIP`, what may be lost between two checked states;
lowered to the start's or goal's exact clearance where one keeps less (as the verdict lowers its
own). A route at clearance 0 (a cage's bar passed at 0.1-2 mm) would be refused later. The search
first keeps :data:`SEARCH_MARGIN` more, for :data:`MARGIN_SHARE` of its budget, so the NLP starts
strictly inside; then the kept clearance alone (a shelf's slot is often open only there).

**The lazy tail.** RRT-Connect checks every motion it tries; in a long narrow passage most tries
collide, and their checks are the budget. What :data:`LAZY_SHARE` of the budget leaves is spent
by :data:`LAZY`, OMPL's lazy bidirectional KPIECE, at the kept clearance: it grows its trees
unchecked and checks the motions of a candidate path only, dropping those that fail. On
MotionBenchMaker's bookshelf_tall 0002 (the hand reaches under a shelf between two cans, 3-25 mm
from them over the last 3 rad of the path) RRT-Connect needed 76-204 k checks over seeds 0-3 (not
found at seed 0 in 150 k); LBKPIECE1 alone 3.9-7.3 k at seeds 0-5. It is the tail, not the
planner: on 33 other problems (0001-0005 of each scenario) it needed 2-4 times RRT-Connect's
checks in the cages (cage 0003: 64 k against 13 k) and made their paths 10-40 % longer.

**Two check steps.** RRT-Connect (range :data:`RANGE`) checks its motions every
:data:`CHECK_STEP` (Euclidean C-space distance, MoveIt's default resolution on the Panda); its
path, shortcut by OMPL's ``simplifySolution``, is then checked densely: every segment at states
no joint apart by more than :data:`DENSE_STEP` (:func:`~forte.planning.search.validity.segment_free`)
with the kept clearance. A vertex that fails is dropped and a segment that fails is replaced by a
search between its ends at the dense step (:data:`REPAIRS` rounds); a path the repairs cannot
mend leaves what is left of the budget to one more search at the dense step from the start
(cage 0022 was found so in 107 k checks; its repairs failed only because the dense check's last
state rounded past its goal's joint limit, :func:`~forte.planning.search.validity.on_segment`:
now 5.9 k). :data:`SLIP`: a robot point
up to ~1 m from the moving joints moves <= h = 5 mm per dense step; passing a body's edge at
distance c between two checked states it comes within ``sqrt(c^2 + h^2 / 4) - c`` of them less,
0.9 mm at c = 3 mm (measured on a bookshelf route: 0.2 mm at this step, 2.0 mm at 0.015 rad).
Finally states are inserted on the segments so that no two are more than :data:`SPACING` apart.

**Figures** (``find_path`` with the route's budget, 150,000 checks, seed 0, one process on the
project's busy 2-core machine): on the 31 MotionBenchMaker Panda problems (0001-0050) that the
former settings (one check step of 0.015 rad, OMPL's default range, ~2.6 rad) did not solve in
150,000 checks, these find 30, with a median of 11.5 k checks (p95 61 k); on 20 that both solve,
the median falls from 13.8 k checks (0.55 s) to 3.0 k (0.16 s), p95 from 58 k to 14 k. Every
route keeps >= 2.65 mm from the scene (exact distance every 0.002 rad); 3 of the former 20 kept
0.18-0.3 mm. The range is what mattered: with 2.6 rad most extensions in a cage or a shelf end in
a body far from the tree; at 0.3 rad the trees grow through the openings.

OMPL's generator is seeded, so a seed repeats a path when the search ends before its time limit.
"""

from __future__ import annotations

import time
from typing import Any, NamedTuple

import numpy as np

from forte.exceptions import InvalidInputError
from forte.model.clearance import ClearanceChecker
from forte.model.robot import N_BASE, MobileManipulator
from forte.model.scene import Scene
from forte.planning.search.validity import StateChecker, on_segment, segment_free
from forte.planning.verdict.margin import REST_MARGIN, execution_margin
from forte.validation import FloatArray

#: Extra clearance (m) the search keeps beyond the kept one (when the start and goal have it).
SEARCH_MARGIN = 0.01
#: The share of the time limit (and of the check budget) the search spends with the margin before it
#: tries without.
MARGIN_SHARE = 0.4
#: Largest C-space step (rad or m, Euclidean) between two checked states of a motion while searching.
CHECK_STEP = 0.06
#: Largest step (rad or m, per joint) between two checked states of the returned path.
DENSE_STEP = 0.005
#: Clearance (m) a motion may lose between two states :data:`DENSE_STEP` apart (measured: module docstring).
SLIP = 0.001
#: Longest C-space motion (rad or m, Euclidean) RRT-Connect adds to a tree in one step.
RANGE = 0.3
#: Largest C-space distance between two states of the returned path.
SPACING = 0.2
#: How far (m) beyond the start's and goal's base position the base may go.
BASE_REACH = 1.0
#: How much (m) below the start's or goal's exact clearance the kept clearance goes (the collision
#: check's margin and the exact distance differ by round-off).
ENDS_TOLERANCE = 1e-4
#: How many times the dense check may send the path back for repair.
REPAIRS = 3
#: The planners find_path knows.
PLANNERS = ("rrtconnect",)
#: The share of the budget after which the last level's RRT-Connect hands the rest to the lazy
#: planner (:data:`LAZY`).
LAZY_SHARE = 0.7
#: OMPL's lazy bidirectional KPIECE: it checks a motion only when it lies on a candidate path.
LAZY = "LBKPIECE1"


class SearchResult(NamedTuple):
    """``q``: M x nq waypoints from start to goal (``None`` when not found); ``reason``: why not
    (``""`` when found); ``states``: states the planner sampled; ``checks``: validity checks;
    ``time_s``: wall time of the whole search, of which ``shortcut_s`` went to shortcutting the
    found path; ``clearance``: the scene distance (m) the path keeps at every state
    :data:`DENSE_STEP` apart (:func:`kept`); ``repairs``: segments the dense check sent back;
    ``planner``: OMPL's planner that found it (``RRTConnect`` or :data:`LAZY`)."""

    q: FloatArray | None
    found: bool
    reason: str
    states: int
    checks: int
    time_s: float
    shortcut_s: float = 0.0
    clearance: float = 0.0
    repairs: int = 0
    planner: str = ""


def ompl_modules() -> tuple[Any, Any, Any]:
    """OMPL's ``base``, ``geometric`` and ``util`` with its log at errors only, or one clear line.
    (Its simplifier warns that a coarsely checked path "may slightly touch on an invalid region":
    the dense re-check below decides, and the warning would only reach the user's terminal.)"""
    try:
        from ompl import base as ob
        from ompl import geometric as og
        from ompl import util as ou
    except ImportError as exc:
        raise InvalidInputError("the path search needs the 'ompl' package (a dependency of forte): pip install ompl"
                                ) from exc
    ou.setLogLevel(ou.LogLevel.LOG_ERROR)
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


def wanted(clearance: float, base: str | None) -> float:
    """The clearance (m) a route keeps where its ends allow: the asked one, at least the executor's
    margin of the ``base`` kind (:func:`~forte.planning.verdict.margin.execution_margin`; ``None``:
    a configuration held at rest, :data:`~forte.planning.verdict.margin.REST_MARGIN`), plus :data:`SLIP`."""
    return max(float(clearance), REST_MARGIN if base is None else execution_margin(base)) + SLIP


def kept(robot: MobileManipulator, scene: Scene, clearance: float, q_start: FloatArray, q_goal: FloatArray) -> float:
    """The clearance (m) the search keeps: the verdict's
    (:func:`~forte.planning.verdict.margin.kept_clearance`: the asked one, at least the executor's
    margin of the robot's base kind where the ends keep that much)
    plus :data:`SLIP`, lowered to the start's and goal's exact clearance (less
    :data:`ENDS_TOLERANCE`) where they keep less, never below the asked one."""
    ends = ClearanceChecker(robot, scene).evaluate(np.array([q_start, q_goal])).distance
    return max(float(clearance), min(wanted(clearance, robot.base), float(ends.min()) - ENDS_TOLERANCE))


class _Budget:
    """The seconds and state checks a search may spend, summed over its checkers."""

    def __init__(self, seconds: float, checks: int | None) -> None:
        self.begin, self.seconds, self.checks = time.perf_counter(), float(seconds), checks
        self.checkers: list[StateChecker] = []

    def checker(self, robot: MobileManipulator, scene: Scene, clearance: float, floor: float | None) -> StateChecker:
        made = StateChecker(robot, scene, clearance, floor)
        self.checkers.append(made)
        return made

    @property
    def spent(self) -> int:
        return sum(c.checks for c in self.checkers)

    def over(self, share: float = 1.0) -> bool:
        """Whether ``share`` of the time or of the checks is spent."""
        late = time.perf_counter() - self.begin >= share * self.seconds
        return late or (self.checks is not None and self.spent >= share * self.checks)

    def condition(self, ob: Any, share: float) -> Any:
        """OMPL's termination condition at ``share`` of the budget."""
        left = max(self.begin + share * self.seconds - time.perf_counter(), 0.0)
        timed = ob.timedPlannerTerminationCondition(left)
        if self.checks is None:
            return timed
        return ob.plannerOrTerminationCondition(timed, ob.PlannerTerminationCondition(lambda: self.over(share)))


def find_path(robot: MobileManipulator, scene: Scene, q_start: Any, q_goal: Any, clearance: float = 0.0, *,
              time_limit: float = 2.0, seed: int = 0, planner: str = "rrtconnect",
              floor: float | None = None, checks: int | None = None) -> SearchResult:
    """A collision-free path from ``q_start`` to ``q_goal`` (whole-body, nq each) with the scene
    distance >= ``clearance`` (m) everywhere, and >= the kept clearance (:func:`kept`) at every
    state :data:`DENSE_STEP` apart (module docstring); ``floor`` replaces the scene's.

    The search stops at ``time_limit`` (s) or, when given, after ``checks`` state checks: a budget
    of checks makes the outcome the same on a busy machine as on an idle one (a seed repeats its
    path), where a time limit finds less the busier the machine."""
    if planner not in PLANNERS:
        raise InvalidInputError(f"planner: expected one of {', '.join(PLANNERS)}, got {planner!r}")
    q_start = robot.check_configuration(q_start, "q_start")
    q_goal = robot.check_configuration(q_goal, "q_goal")
    if robot.base == "fixed":
        q_goal = np.r_[q_start[:N_BASE], q_goal[N_BASE:]]
    budget = _Budget(time_limit, checks)
    checker = budget.checker(robot, scene, clearance, floor)
    for label, q in (("start", q_start), ("goal", q_goal)):
        if not checker.valid(q):
            return SearchResult(None, False, f"{label} configuration in collision: {checker.why(q)}", 0,
                                budget.spent, time.perf_counter() - budget.begin)
    keep = kept(robot, checker.scene, clearance, q_start, q_goal)
    levels = [budget.checker(robot, scene, c, floor) for c in (keep + SEARCH_MARGIN, keep)]
    levels = [c for c in levels if c.valid(q_start) and c.valid(q_goal)] or [checker]
    dense = levels[-1]  # the kept clearance (the asked one where round-off makes an end fail it)
    path, states, shortcut, repairs, name = None, 0, 0.0, 0, "RRTConnect"
    stages = [(level, MARGIN_SHARE, "RRTConnect") for level in levels[:-1]]  # the margin may close a passage
    stages += [(levels[-1], LAZY_SHARE, "RRTConnect"), (levels[-1], 1.0, LAZY)]
    for level, share, name in stages:
        path, more, shortcut = _search(robot, level, q_start, q_goal, budget, share, seed, CHECK_STEP, name)
        states += more
        if path is not None:
            path, more, repairs = _repaired(robot, dense, path, budget, seed)
            states += more
        if path is not None:
            break
    if path is None and not budget.over():  # a coarse path the repairs could not mend: the rest, densely
        name = "RRTConnect"
        path, more, shortcut = _search(robot, dense, q_start, q_goal, budget, 1.0, seed, DENSE_STEP)
        states += more
        if path is not None:
            path, more, more_repairs = _repaired(robot, dense, path, budget, seed)
            states, repairs = states + more, repairs + more_repairs
    elapsed = time.perf_counter() - budget.begin
    if path is None:
        spent = f"{budget.spent} state checks" if checks is not None and elapsed < time_limit else f"{time_limit:g} s"
        return SearchResult(None, False, f"no collision-free path in {spent} ({states} states sampled, "
                            f"{elapsed:.1f} s)", states, budget.spent, elapsed, repairs=repairs)
    return SearchResult(_spaced(path), True, "", states, budget.spent, elapsed, shortcut, dense.clearance, repairs,
                        name)


def _repaired(robot: MobileManipulator, dense: StateChecker, path: FloatArray, budget: _Budget,
              seed: int) -> tuple[FloatArray | None, int, int]:
    """``path`` without its vertices that fail ``dense``, and with every segment that fails the dense
    check (:func:`segment_free` at :data:`DENSE_STEP`) replaced by a search between its ends at that step, at most
    :data:`REPAIRS` rounds; the path (``None`` when a repair fails), the states sampled and the
    segments repaired. A repair that returns the segment it was sent (OMPL checks its motions at
    other states than :func:`segment_free`) fails the path at once."""
    states, repairs = 0, 0
    path = path[[dense.valid(q) for q in path]]  # a smoothed vertex may fail (OMPL warns); the ends pass
    for round_ in range(REPAIRS + 1):
        bad = [k for k in range(len(path) - 1) if not segment_free(dense, path[k], path[k + 1], DENSE_STEP)]
        if not bad:
            return path, states, repairs
        if round_ == REPAIRS or budget.over():
            break
        pieces = [path[: bad[0] + 1]]
        for n, k in enumerate(bad):
            sub, more, _s = _search(robot, dense, path[k], path[k + 1], budget, 1.0, seed, DENSE_STEP)
            states, repairs = states + more, repairs + 1
            if sub is None or len(sub) == 2:  # two states: the search's own check passes the segment
                return None, states, repairs  # the dense one fails, and would again every round
            end = bad[n + 1] if n + 1 < len(bad) else len(path) - 1
            pieces += [sub[1:], path[k + 2: end + 1]]
        path = np.concatenate(pieces)
    return None, states, repairs


def _spaced(path: FloatArray) -> FloatArray:
    """``path`` with states inserted on its segments so that no two are more than :data:`SPACING` apart."""
    out = [path[:1]]
    for a, b in zip(path[:-1], path[1:], strict=True):
        n = max(1, int(np.ceil(np.linalg.norm(b - a) / SPACING)))
        out.append(on_segment(a, b, np.arange(1, n + 1) / n))
    return np.concatenate(out)


def _search(robot: MobileManipulator, checker: StateChecker, q_start: FloatArray, q_goal: FloatArray,
            budget: _Budget, share: float, seed: int, step: float,
            planner: str = "RRTConnect") -> tuple[FloatArray | None, int, float]:
    """OMPL's ``planner`` (RRT-Connect, or :data:`LAZY`; range :data:`RANGE`, motions checked every
    ``step``) until ``share`` of the budget is spent, shortcut; the path's vertices (or ``None``),
    the states sampled and the shortcut's time (s)."""
    ob, og, ou = ompl_modules()
    ou.setLogLevel(ou.LogLevel.LOG_NONE)  # re-seeding after an earlier search logs an error, yet
    ou.RNG.setSeed(int(seed) + 1)  # every generator made after it (planner, sampler) is seeded; 0 = none
    ou.setLogLevel(ou.LogLevel.LOG_ERROR)
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
    info.setStateValidityCheckingResolution(step / space.getMaximumExtent())
    start, goal = space.allocState(), space.allocState()
    for i, j in enumerate(joints):
        start[i], goal[i] = float(q_start[j]), float(q_goal[j])
    setup.setStartAndGoalStates(start, goal)
    made = getattr(og, planner)(info)
    made.setRange(RANGE)
    setup.setPlanner(made)
    solved = setup.solve(budget.condition(ob, share)) and setup.haveExactSolutionPath()
    data = ob.PlannerData(info)
    setup.getPlannerData(data)
    states = int(data.numVertices())
    if not solved:
        return None, states, 0.0
    begin = time.perf_counter()
    setup.simplifySolution()
    shortcut = time.perf_counter() - begin
    path = setup.getSolutionPath()
    out = np.repeat(q_start[None], path.getStateCount(), axis=0)
    for k in range(path.getStateCount()):
        out[k, joints] = [path.getState(k)[i] for i in range(len(joints))]
    out[0], out[-1] = q_start, q_goal
    return out, states, shortcut
