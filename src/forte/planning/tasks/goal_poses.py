"""Poses a goal task passes on its way: ``via:`` poses, and pick and place (``goals:``).

::

    path: {kind: goal, pose: {...},            # or configuration: [...]
           via: [{position: [x, y, z], orientation: {rpy: [...]}, tolerance: {position, angle}, time: 1.2}]}
    path: {kind: goal, goals: [PRE_GRASP, GRASP, PLACE], grasp: 1}   # each {pose: ...} or {configuration: ...}

**Via poses.** The end effector passes each via pose, in order, within its tolerance (default
:data:`GOAL_POSITION_TOL` m, :data:`GOAL_ANGLE_TOL` rad; no orientation: the start's). Via ``i``
is a pose equality of the NLP at one waypoint ``k_i`` (as the goal pose is at the last one), and
the route to the goal runs through the IK configuration of each via (solved from the one before).
The time of via ``i`` is ``time`` when given (on the task's clock: it needs ``path.duration``),
else the rule::

    t_i = t_1 + s_i (t_{N-2} - t_1),   s_i = L_i / L

with ``L_i`` the length of the straight lines from the start's end-effector position through the
via positions up to via ``i`` and ``L`` that length up to the goal (the motion arrives at
``t_{N-2}``, 1-based, and rests over the last two samples). ``k_i`` is the waypoint nearest
``t_i``, moved on where two vias would share one; every via needs its own waypoint before the
arrival (N >= number of vias + 4).

**Pick and place.** ``goals`` lists goals (each a pose goal with its ``tolerance``, or a
whole-body ``configuration``); the last is where the motion ends (the place) and every goal
before it is passed as a via (a configuration as the end-effector pose it gives, the route
through the configuration itself). ``grasp`` (0-based, default: the goal before the last) is
where the payload attaches: its mass and force count from the grasp's waypoint on
(:func:`forte.force.taskforce.attached_from`), the approach is unloaded (the robot's own tool
load only). The mass switches at the grasp's waypoint, a step in the force.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from forte.exceptions import InvalidInputError
from forte.model.robot import N_BASE, MobileManipulator
from forte.planning.tasks.ik import reachable_pose
from forte.planning.tasks.schema import Reader, check_joint_limits, rotation
from forte.validation import MAX_DURATION_S, FloatArray

#: A pose goal's (and a via's) default tolerance: the verdict's tracking tolerances (m, rad).
GOAL_POSITION_TOL, GOAL_ANGLE_TOL = 0.01, 0.05
#: Most via poses (or goals) one task may list.
MAX_VIAS = 20


@dataclass(frozen=True)
class Via:
    """A pose the end effector passes on the way to the goal.

    Attributes:
        pose: the pose (4 x 4, world).
        q: the IK configuration that reaches it (the route's knot).
        position_tol, angle_tol: how close (m, rad) the plan must pass.
        fraction: ``s_i`` of the rule (module docstring); ``time``: the given time (s), else ``None``.
    """

    pose: FloatArray
    q: FloatArray
    position_tol: float = GOAL_POSITION_TOL
    angle_tol: float = GOAL_ANGLE_TOL
    fraction: float = 0.5
    time: float | None = None


def arrival(t: FloatArray) -> float:
    """When the motion arrives at the goal: ``t_{N-2}`` (1-based) of N >= 4 samples, else the last."""
    return float(t[-3] if len(t) >= 4 else t[-1])


def via_steps(vias: tuple[Via, ...], t: FloatArray) -> FloatArray:
    """The waypoint ``k_i`` (0-based) of every via on the sample times ``t`` (module docstring)."""
    t = np.asarray(t, dtype=float)
    if not vias:
        return np.zeros(0, dtype=int)
    times = [v.time if v.time is not None else t[0] + v.fraction * (arrival(t) - t[0]) for v in vias]
    steps = np.clip(np.abs(t[None, :] - np.asarray(times)[:, None]).argmin(axis=1), 1, None)
    for i in range(1, steps.size):
        steps[i] = max(steps[i], steps[i - 1] + 1)
    if steps[-1] > t.size - 4:
        raise InvalidInputError(f"{len(vias)} via poses need a waypoint each between the start and the arrival: "
                                f"expected at least {len(vias) + 4} waypoints, got {t.size}")
    return steps


def distance_fractions(points: FloatArray) -> FloatArray:
    """``s_i = L_i / L`` of the inner points of the polyline ``points`` (M x 3): start, vias, goal."""
    legs = np.linalg.norm(np.diff(np.asarray(points, dtype=float), axis=0), axis=1)
    total = float(legs.sum())
    inner = len(points) - 2
    if total < 1e-9:  # no way to go: evenly spaced
        return np.arange(1, inner + 1) / (inner + 1)
    return np.cumsum(legs)[:-1] / total


def read_tolerance(r: Reader) -> tuple[float, float]:
    """``tolerance: {position, angle}`` of ``r`` (m, rad), the defaults where left out."""
    tol = r.sub("tolerance") if r.has("tolerance") else Reader({}, r.path, f"{r.key('tolerance')}.")
    tol.unknown({"position", "angle"})
    return (tol.number("position", GOAL_POSITION_TOL, positive=True, maximum=1.0, unit=" m"),
            tol.number("angle", GOAL_ANGLE_TOL, positive=True, maximum=np.pi, unit=" rad"))


def read_pose(p: Reader, default_rotation: FloatArray) -> FloatArray:
    """``position`` and ``orientation`` (rpy, quaternion or matrix; default ``default_rotation``) of ``p``."""
    T = np.eye(4)
    T[:3, 3] = p.vector("position", 3)
    T[:3, :3] = rotation(p, "orientation", default_rotation)
    return T


def reach(r: Reader, name: str, robot: MobileManipulator, T: FloatArray, seed: FloatArray,
          what: str = "from the start") -> FloatArray:
    """The IK configuration reaching ``T`` from ``seed``; an error naming ``name`` when none does."""
    q, err, ok = reachable_pose(robot, T, seed)
    if not ok:
        raise r.error(name, f"unreachable {what}: the best IK leaves {np.linalg.norm(err[:3]):.4g} m "
                      f"and {np.linalg.norm(err[3:]):.4g} rad" + (" with the base fixed" if robot.base == "fixed"
                                                                 else ""))
    return q


def read_configuration(r: Reader, robot: MobileManipulator, q_init: FloatArray) -> FloatArray:
    """A whole-body ``configuration`` (a fixed base keeps the start's base entries)."""
    value = r.get("configuration")
    if not isinstance(value, list | tuple) or len(value) != robot.nq:
        got = f"{len(value)}" if isinstance(value, list | tuple) else repr(value)
        raise r.error("configuration", f"expected {robot.nq} numbers (base x, y, yaw, then the arm), got {got}")
    q = r.vector("configuration", robot.nq)
    check_joint_limits(r, "configuration", robot, q)
    if robot.base == "fixed" and not np.allclose(q[:N_BASE], q_init[:N_BASE], atol=1e-9, rtol=0):
        raise r.error("configuration", f"base entries {q[:N_BASE].tolist()!r} differ from the start's "
                      f"{q_init[:N_BASE].tolist()!r}; robot.base is fixed")
    return q


def _items(r: Reader, name: str, least: int, example: str) -> list[Reader]:
    items = r.get(name)
    if not isinstance(items, list) or not least <= len(items) <= MAX_VIAS:
        got = f"{len(items)} entries" if isinstance(items, list) else repr(items)
        raise r.error(name, f"expected a list of {least} to {MAX_VIAS} {example}, got {got}")
    return [Reader(item, r.path, f"{r.key(name)}[{i}].") for i, item in enumerate(items)]


def _time(w: Reader, duration: float | None) -> float | None:
    if not w.has("time"):
        return None
    if duration is None:
        raise w.error("time", "a via's time is on the task's clock: give path.duration too")
    return w.number("time", positive=True, maximum=min(duration, MAX_DURATION_S), unit=" s")


def read_vias(r: Reader, robot: MobileManipulator, q_init: FloatArray, duration: float | None
              ) -> list[Via]:
    """``via: [{position, orientation?, tolerance?, time?}, ...]``; fractions are set by :func:`timed_vias`."""
    vias, seed = [], q_init
    start_rotation = robot.ee_pose(q_init)[:3, :3]
    for i, w in enumerate(_items(r, "via", 1, "via poses {position, orientation, tolerance, time}")):
        w.unknown({"position", "orientation", "tolerance", "time"})
        T = read_pose(w, start_rotation)
        seed = reach(w, "position", robot, T, seed, "from the start" if i == 0 else f"from via {i - 1}")
        vias.append(Via(T, seed, *read_tolerance(w), time=_time(w, duration)))
    return vias


def read_goal_list(r: Reader, robot: MobileManipulator, q_init: FloatArray, duration: float | None
                   ) -> tuple[list[Via], tuple[FloatArray | None, FloatArray, float, float]]:
    """``goals: [{pose|configuration, tolerance?, time?}, ...]``: the vias (every goal but the last)
    and the last goal ``(pose or None, q_end, position_tol, angle_tol)``."""
    readers = _items(r, "goals", 2, "goals {pose or configuration, tolerance, time} (pre-grasp, grasp, place)")
    vias, seed, start_rotation = [], q_init, robot.ee_pose(q_init)[:3, :3]
    for i, w in enumerate(readers):
        w.unknown({"pose", "configuration", "tolerance", "time"})
        if w.has("pose") == w.has("configuration"):
            raise w.error("pose", "give exactly one of pose and configuration")
        if w.has("configuration"):
            if w.has("tolerance"):
                raise w.error("tolerance", "applies to a pose goal; a configuration is met exactly")
            q = read_configuration(w, robot, q_init)
            T, tol = robot.ee_pose(q), (GOAL_POSITION_TOL, GOAL_ANGLE_TOL)
        else:
            p = w.sub("pose")
            p.unknown({"position", "orientation"})
            T, tol = read_pose(p, start_rotation), read_tolerance(w)
            q = reach(w, "pose", robot, T, seed, "from the start" if i == 0 else f"from goals[{i - 1}]")
        seed = q
        if i == len(readers) - 1:
            if w.has("time"):
                raise w.error("time", "the last goal is reached at the end of the motion; give path.duration")
            return vias, (None if w.has("configuration") else T, q, *tol)
        vias.append(Via(T, q, *tol, time=_time(w, duration)))
    raise AssertionError("unreachable")  # the loop returns at the last goal


def timed_vias(r: Reader, name: str, vias: list[Via], start: FloatArray, end: FloatArray) -> tuple[Via, ...]:
    """The vias with the rule's fractions (start and end: the end effector's positions); given
    times must be given for every via or none, and increase."""
    given = [v.time is not None for v in vias]
    if any(given) and not all(given):
        raise r.error(name, "give a time for every entry before the goal or for none")
    times = [v.time for v in vias if v.time is not None]
    bad = np.flatnonzero(np.diff(times) <= 0) if times else np.zeros(0, int)
    if bad.size:
        raise r.error(f"{name}[{bad[0] + 1}].time",
                      f"times must increase, got {times[bad[0]]} then {times[bad[0] + 1]}")
    points = np.vstack([start, *[v.pose[:3, 3] for v in vias], end])
    fractions = distance_fractions(points)
    return tuple(Via(v.pose, v.q, v.position_tol, v.angle_tol, float(s), v.time)
                 for v, s in zip(vias, fractions, strict=True))


def read_grasp(r: Reader, goals: int) -> int:
    """``grasp``: the index (0-based) of the goal where the payload attaches, a goal before the last."""
    value = r.get("grasp", goals - 2)
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= goals - 2:
        raise r.error("grasp", f"expected the index of a goal before the last (0 to {goals - 2}; the place is "
                      f"goals[{goals - 1}]), got {value!r}")
    return value
