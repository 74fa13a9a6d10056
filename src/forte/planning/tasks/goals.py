"""Goal tasks: ``path: {kind: goal, ...}``, a motion from the start to a goal whose end-effector
path between them is free (the optimizer chooses it).

Two goals: a whole-body ``configuration`` (base x, y, yaw, then the arm; a fixed base keeps the
start's base entries) or an end-effector ``pose`` (position and orientation, reached within
``tolerance``). The task's sample times come from ``duration`` (s) when given, else from
:func:`rule_duration`; its targets are the forward kinematics of a whole-body motion (first the
straight line of :func:`straight_line`, then the plan's own, :meth:`Task.following
<forte.planning.tasks.tasks.Task.following>`), so the payload's force ``m (p'' - g)`` is the force
along that motion. Only the goal is a pose equality of the NLP (a pose goal: the last waypoint;
a configuration goal: none, the last configuration is bounded to the goal), and each via pose at
its waypoint (``via:`` and pick and place's ``goals:``, :mod:`forte.planning.tasks.goal_poses`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from forte.exceptions import InvalidInputError
from forte.model.robot import N_BASE, MobileManipulator
from forte.model.trajectory import quintic_blend, quintic_path
from forte.planning.tasks.goal_poses import (
    GOAL_ANGLE_TOL,
    GOAL_POSITION_TOL,
    Via,
    arrival,
    reach,
    read_configuration,
    read_goal_list,
    read_grasp,
    read_pose,
    read_tolerance,
    read_vias,
    timed_vias,
    via_steps,
)
from forte.planning.tasks.schema import Reader
from forte.settings import KinematicLimits
from forte.validation import MAX_DURATION_S, MAX_WAYPOINTS, FloatArray

#: The fields of a goal path besides ``kind``, ``samples`` and ``rate``.
GOAL_FIELDS = frozenset({"configuration", "pose", "tolerance", "duration", "via", "goals", "grasp"})
#: Waypoints of a goal task when neither ``samples`` nor ``rate`` is given.
DEFAULT_GOAL_SAMPLES = 30
#: A goal task's IPOPT iteration limit when the task file gives none (``solver.max_iter``): of
#: MotionBenchMaker's 127 feasible plans at df18d3d, 99 % converged within 98 iterations (the most:
#: 287), while the solves that failed ran to the limit of 500 (tens of seconds with ~1,600 clearance
#: rows); the route is judged as the plan when the NLP stops (:mod:`forte.planning.planner`).
GOAL_MAX_ITER = 200
#: CPU seconds a goal task's NLP solves may take in all when the task file gives none
#: (``solver.time_budget_s``). The route is the plan when they run out and it passes the verdict
#: (as when the NLP fails): the NLP's tail then costs seconds, not tens of seconds.
GOAL_SOLVE_BUDGET_S = 4.0
#: A configuration goal is met when the last configuration is this close (rad, m) at every coordinate.
GOAL_CONFIGURATION_TOL = 1e-6
#: The rule's duration: at least this long (s), and this many times the quintic's bound.
MIN_GOAL_DURATION_S = 1.0
DURATION_MARGIN = 2.0
#: Peak speed and acceleration of the quintic blend ``10 s^3 - 15 s^4 + 6 s^5`` over a unit step in
#: unit time: ``max s' = 15 / 8``, ``max s'' = 10 sqrt(3) / 3``.
QUINTIC_PEAK_SPEED, QUINTIC_PEAK_ACCELERATION = 15 / 8, 10 * np.sqrt(3) / 3


@dataclass(frozen=True)
class Goal:
    """Where a goal task ends.

    Attributes:
        q_end: the whole-body configuration the straight-line guess ends at (the goal
            configuration, or the IK solution of the goal pose from the start).
        pose: the goal pose (4 x 4, world) of a pose goal; ``None`` for a configuration goal.
        position_tol, angle_tol: how close (m, rad) the plan's last pose must come to ``pose``.
        duration_given: whether the task file gave ``duration`` (else :func:`rule_duration`'s).
        route: the motion (N x nq, at the task's times) the planner found to the goal
            (:mod:`forte.planning.search.route`), the NLP's guess and nominal; ``None``: the
            straight line.
        law: the route's time law it was sampled from (dense times from 0 and the states at them,
            :func:`forte.planning.search.route.routed`), so the route can be sampled again on more
            waypoints (:func:`forte.planning.search.route.on_samples`); ``None``: none (the
            straight line, or a route through vias).
        vias: the poses passed on the way, in order (:mod:`forte.planning.tasks.goal_poses`).
        grasp: the via (index) where the payload attaches (pick and place); ``None``: carried throughout.
    """

    q_end: FloatArray
    pose: FloatArray | None = None
    position_tol: float = GOAL_POSITION_TOL
    angle_tol: float = GOAL_ANGLE_TOL
    duration_given: bool = False
    route: FloatArray | None = None
    law: tuple[FloatArray, FloatArray] | None = None
    vias: tuple[Via, ...] = ()
    grasp: int | None = None

    def motion(self, q0: FloatArray, t: FloatArray) -> FloatArray:
        """The guess along ``t``: the route when found, else the straight line from ``q0`` (through
        the vias' configurations, :func:`through_vias`)."""
        if self.route is not None and len(self.route) == len(t):
            return self.route
        return through_vias(q0, self, t) if self.vias else straight_line(q0, self.q_end, t)

    def steps(self, t: FloatArray) -> FloatArray:
        """The waypoint (0-based) at which each via is passed on the sample times ``t``."""
        return via_steps(self.vias, t)

    def grasp_step(self, t: FloatArray) -> int | None:
        """The waypoint where the payload attaches (``None``: no grasp)."""
        return None if self.grasp is None else int(self.steps(t)[self.grasp])

    @property
    def kind(self) -> str:
        """``configuration`` or ``pose``."""
        return "configuration" if self.pose is None else "pose"

    @property
    def configuration(self) -> FloatArray | None:
        """The goal configuration of a configuration goal (``None`` for a pose goal)."""
        return self.q_end if self.pose is None else None


def rule_duration(robot: MobileManipulator, limits: KinematicLimits, q0: FloatArray, q1: FloatArray) -> float:
    """A duration (s) for the straight line from ``q0`` to ``q1`` with a quintic time law:

        ``T = max(1 s, 2 max_i max(15/8 |dq_i| / v_i, sqrt(10 sqrt(3)/3 |dq_i| / a_i)))``

    the time at which the quintic's peak velocity and acceleration meet the limits of the slowest
    coordinate (base velocity and arm velocity and acceleration; the base's acceleration limits are
    the planner's), with a margin for the payload's torques. A placeholder for a time-optimal rule."""
    vel, acc = limits.resolve(robot)
    acc = np.r_[np.full(N_BASE, np.inf), acc[N_BASE:]]
    step = np.abs(np.asarray(q1, dtype=float) - np.asarray(q0, dtype=float))
    with np.errstate(divide="ignore", invalid="ignore"):
        t_vel = np.where(np.isfinite(vel), QUINTIC_PEAK_SPEED * step / vel, 0.0)
        t_acc = np.where(np.isfinite(acc), np.sqrt(QUINTIC_PEAK_ACCELERATION * step / acc), 0.0)
    bound = float(np.max(np.maximum(np.nan_to_num(t_vel), np.nan_to_num(t_acc)), initial=0.0))
    return float(min(max(MIN_GOAL_DURATION_S, DURATION_MARGIN * bound), MAX_DURATION_S))


def straight_line(q0: FloatArray, q1: FloatArray, t: FloatArray) -> FloatArray:
    """The straight line from ``q0`` to ``q1`` in configuration space at the times ``t`` (N x nq):
    ``q_k = q0 + s_k (q1 - q0)`` with the quintic blend ``s_k`` reaching 1 at ``t_{N-3}`` (N >= 4),
    so the motion starts at rest and rests over the last two samples (the end at rest of the NLP)."""
    t = np.asarray(t, dtype=float)
    arrive = t[-3] if t.size >= 4 else t[-1]
    span = max(float(arrive - t[0]), 1e-12)
    s = quintic_blend(np.clip((t - t[0]) / span, 0.0, 1.0))
    return np.asarray(q0, dtype=float)[None] + s[:, None] * (np.asarray(q1, dtype=float) - q0)[None]


def through_vias(q0: FloatArray, goal: Goal, t: FloatArray) -> FloatArray:
    """Straight lines in configuration space from ``q0`` through the vias' configurations to the
    goal's, one quintic blend each (at rest at every knot), passing via ``i`` at its waypoint's
    time and arriving at ``t_{N-3}`` (0-based), at rest over the last two samples."""
    t = np.asarray(t, dtype=float)
    knot_t = np.r_[t[0], t[goal.steps(t)], arrival(t)]
    knots = np.vstack([q0, *[v.q for v in goal.vias], goal.q_end])
    return quintic_path(knot_t, knots, np.minimum(t, knot_t[-1]))


def goal_targets(robot: MobileManipulator, goal: Goal, q: FloatArray, t: FloatArray) -> FloatArray:
    """The end-effector poses of the motion ``q`` (N x nq) at times ``t``, the last one the goal pose
    of a pose goal and each via's waypoint its pose (the NLP's pose equalities)."""
    targets = np.array([robot.ee_pose(qk) for qk in np.asarray(q, dtype=float)])
    if goal.pose is not None:
        targets[-1] = goal.pose
    for via, k in zip(goal.vias, goal.steps(t), strict=True):
        targets[k] = via.pose
    return targets


def _end(r: Reader, robot: MobileManipulator, q_init: FloatArray, duration: float | None
         ) -> tuple[FloatArray | None, FloatArray, float, float, list[Via], int | None]:
    """The goal ``(pose or None, q_end, position_tol, angle_tol)``, the vias and the grasp: from
    ``goals:`` (pick and place), else ``configuration`` or ``pose`` with ``via:``."""
    if r.has("goals"):
        for name in ("configuration", "pose", "tolerance", "via"):
            if r.has(name):
                raise r.error(name, "give goals (the last is where the motion ends) or configuration/pose, not both")
        vias, end = read_goal_list(r, robot, q_init, duration)
        return (*end, vias, read_grasp(r, len(vias) + 1))
    if r.has("grasp"):
        raise r.error("grasp", "applies to a goal list (path.goals: [pre-grasp, grasp, place])")
    if r.has("configuration") == r.has("pose"):
        raise r.error("configuration", "give exactly one of configuration (whole-body) and pose (or a list of goals)")
    vias = read_vias(r, robot, q_init, duration) if r.has("via") else []
    seed = vias[-1].q if vias else q_init
    if r.has("configuration"):
        if r.has("tolerance"):
            raise r.error("tolerance", "applies to a pose goal; a configuration goal is met exactly")
        q_end = read_configuration(r, robot, q_init)
        return None, q_end, *read_tolerance(r), vias, None
    p = r.sub("pose")
    p.unknown({"position", "orientation"})
    T = read_pose(p, robot.ee_pose(q_init)[:3, :3])
    return T, reach(r, "pose", robot, T, seed, "from the last via" if vias else "from the start"), \
        *read_tolerance(r), vias, None


def _rule_duration(robot: MobileManipulator, limits: KinematicLimits, knots: list[FloatArray]) -> float:
    """:func:`rule_duration` summed over the straight lines between consecutive ``knots``."""
    total = sum(rule_duration(robot, limits, a, b) for a, b in zip(knots[:-1], knots[1:], strict=True))
    return float(min(total, MAX_DURATION_S))


def read_goal(r: Reader, robot: MobileManipulator, q_init: FloatArray, limits: KinematicLimits,
              waypoints: int | None) -> tuple[FloatArray, Goal]:
    """``path: {kind: goal, ...}``: the sample times and the :class:`Goal`."""
    r.unknown({"kind", "samples", "rate", "keep_level"} | GOAL_FIELDS)  # keep_level: tasks/keep_level.py
    given = r.has("duration")
    duration = r.number("duration", positive=True, maximum=MAX_DURATION_S, unit=" s") if given else None
    pose, q_end, position_tol, angle_tol, vias, grasp = _end(r, robot, q_init, duration)
    if duration is None:
        duration = _rule_duration(robot, limits, [q_init, *[v.q for v in vias], q_end])
    if waypoints is not None:
        n = waypoints
    elif r.has("samples"):
        n = r.integer("samples", minimum=4, maximum=MAX_WAYPOINTS)
    elif r.has("rate"):
        n = int(np.clip(round(duration * r.number("rate", positive=True) + 1), 4, MAX_WAYPOINTS))
    else:
        n = DEFAULT_GOAL_SAMPLES
    name = "goals" if r.has("goals") else "via"
    end = pose[:3, 3] if pose is not None else robot.ee_position(q_end)
    goal = Goal(q_end, pose, position_tol, angle_tol, given,
                vias=timed_vias(r, name, vias, robot.ee_position(q_init), end) if vias else (), grasp=grasp)
    t = np.linspace(0.0, duration, n)
    for i, via in enumerate(goal.vias):
        if via.time is not None and via.time >= arrival(t):
            raise r.error(f"{name}[{i}].time", f"expected a time before the motion arrives at t = {arrival(t):.4g} s "
                          "(it rests over the last two samples)")
    if vias:
        try:
            goal.steps(t)
        except InvalidInputError as exc:
            raise r.error("samples" if waypoints is None else name, str(exc)) from None
    return t, goal


def goal_errors(robot: MobileManipulator, goal: Goal, q_last: FloatArray) -> tuple[float, float]:
    """The position (m) and orientation (rad) error of the configuration ``q_last`` against a pose goal."""
    T = robot.ee_pose(q_last)
    return (float(np.linalg.norm(T[:3, 3] - goal.pose[:3, 3])),
            float(np.linalg.norm(pin.log3(goal.pose[:3, :3].T @ T[:3, :3]))))


def goal_section(reader: Reader, robot: MobileManipulator, mode: str, q_init: FloatArray, limits: KinematicLimits,
                 waypoints: int | None) -> tuple[FloatArray, FloatArray, Goal] | None:
    """A goal task's sample times, its targets along the straight line and its :class:`Goal`;
    ``None`` when the task's path is not a goal."""
    path = reader.get("path")
    if mode != "trajectory" or not isinstance(path, dict) or path.get("kind") != "goal":
        return None
    if waypoints is not None and not 4 <= waypoints <= MAX_WAYPOINTS:
        raise reader.error("path", f"--waypoints: expected 4 to {MAX_WAYPOINTS} for a goal task, got {waypoints}")
    t, goal = read_goal(reader.sub("path"), robot, q_init, limits, waypoints)
    return t, goal_targets(robot, goal, goal.motion(q_init, t), t), goal
