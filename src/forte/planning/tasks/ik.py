"""Damped least-squares whole-body inverse kinematics along a path of end-effector poses.

Used for the optimizer's initial guess and as the *quintic* baseline (the interpolated path
followed without optimization). Each waypoint starts from the previous solution, so the
result is continuous; base motion is weighted ``base_weight`` times more than arm motion, so
the arm does most of the work, as a teach-pendant style controller would.

Step (weighted, damped): ``dq = W^-1 J^T (J W^-1 J^T + lambda^2 I)^-1 e`` with the 6-D world
pose error ``e = [p_d - p; log(R_d R^T)]``, then a clamp to the arm joint limits. ``W^-1``
(:func:`step_weights`): ``1 / base_weight`` on the base, 1 on a revolute joint, and on a prismatic
joint ``(range / mean revolute range)^2``: its metres count as the fraction of its range they use,
as a revolute joint's radians do. Unweighted, a joint's share of the step grows with its lever,
1 m/m for a lift against 0.3-0.6 m/rad for a shoulder: the TIAGo preset's 0.1, 0.3 and 0.5 m
reaches down dropped its torso from 0.2 m to 0.108, 0 and 0 m and barely moved its arm, and below
~0.115 m the URDF's ``arm_1_link`` meets the torso column's box (at 6, 13 and 14 of 21 waypoints).
This reference is also the posture the nominal and joint-limit terms pull towards (their centre
on arms other than the authors' Panda). Weighted, the torso ends at 0.190, 0.167 and 0.133 m, the
arm doing the rest, clear of the column. An arm without a prismatic joint is unchanged.

The guess never decides reachability on its own: a waypoint the tracking IK leaves above
``position_tolerance`` is solved again from several postures (:func:`thorough_pose`). Below
:data:`REACH_POSITION_M` and :data:`REACH_ORIENTATION_RAD` the best posture is the NLP's start:
the damped step stalls millimetres short where a joint sits at its clamp or the base cannot move
sideways (a differential drive), which the NLP, moving every waypoint together, closes. Above
them the same starts are tried for the position alone (:func:`position_reach`, the orientation
left free): when the whole body brings the end effector's origin within
:data:`REACH_POSITION_M` of the point, the pose is the NLP's to try from the best full-pose
guess, and its verdict judges the tracking (naming the waypoint, the time and the distance).
Only a point no start brings the end effector near is an unreachable pose (exit 2), said with
the distance the nearest posture leaves.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import pinocchio as pin

from forte.exceptions import InfeasibleTaskError
from forte.model.robot import N_BASE, MobileManipulator
from forte.model.twin import is_prismatic
from forte.validation import FloatArray


@dataclass(frozen=True)
class IKOptions:
    damping: float = 1e-3
    base_weight: float = 10.0
    max_iterations: int = 200
    tolerance: float = 1e-9
    position_tolerance: float = 1e-4  # m: above this a waypoint is reported unreachable
    orientation_tolerance: float = 1e-3  # rad


#: A pose the thorough IK leaves farther than this (m, rad) is unreachable; a few centimetres is
#: a start the NLP's pose constraints close, tens of centimetres is out of the robot's reach.
REACH_POSITION_M = 0.05
REACH_ORIENTATION_RAD = 0.1
#: Postures :func:`thorough_pose` starts from besides the tracking ones (seeded: reproducible).
RESTARTS = 6


def pose_error(robot: MobileManipulator, q: FloatArray, target: FloatArray) -> FloatArray:
    """6-D world-frame error ``[p_d - p; log(R_d R^T)]`` of the end-effector pose."""
    T = robot.ee_pose(q)
    return np.concatenate([target[:3, 3] - T[:3, 3], pin.log3(target[:3, :3] @ T[:3, :3].T)])


def step_weights(robot: MobileManipulator, base_weight: float) -> FloatArray:
    """The step's inverse weights ``W^-1`` over (x, y, yaw, arm joints) (module docstring): 0 on a
    fixed base (infinite weight), else ``1 / base_weight``; 1 per revolute arm joint; per prismatic
    one ``(range_i / r)^2``, ``r`` the mean range of the revolute joints with finite limits (2 pi
    when there are none)."""
    base = 0.0 if robot.base == "fixed" else 1.0 / base_weight
    arm = np.ones(robot.n_arm)
    prismatic = np.array([is_prismatic(robot.model.joints[j + 1]) for j in range(robot.n_arm)])
    if prismatic.any():
        span = np.asarray(robot.upper, dtype=float) - np.asarray(robot.lower, dtype=float)
        revolute = span[~prismatic & np.isfinite(span)]
        r = float(revolute.mean()) if revolute.size else 2 * np.pi
        arm[prismatic] = np.where(np.isfinite(span[prismatic]), (span[prismatic] / r) ** 2, 1.0)
    return np.concatenate([np.full(N_BASE, base), arm])


def solve_pose(
    robot: MobileManipulator, target: FloatArray, q_start: FloatArray, options: IKOptions = IKOptions(),
) -> tuple[FloatArray, FloatArray]:
    """One waypoint: returns ``(q, final error)``."""
    q = q_start.copy()
    winv = step_weights(robot, options.base_weight)
    margin = 1e-6
    for _ in range(options.max_iterations):
        err = pose_error(robot, q, target)
        if np.linalg.norm(err) < options.tolerance:
            break
        J = robot.whole_body_jacobian(q)
        JW = J * winv
        step = JW.T @ np.linalg.solve(JW @ J.T + options.damping**2 * np.eye(6), err)
        q = q + step
        q[N_BASE:] = np.clip(q[N_BASE:], robot.lower + margin, robot.upper - margin)
    return q, pose_error(robot, q, target)


def thorough_pose(robot: MobileManipulator, target: FloatArray, q_near: FloatArray,
                  options: IKOptions = IKOptions()) -> tuple[FloatArray, FloatArray]:
    """The best of :func:`solve_pose` from ``q_near``, from its base with the arm at its home and
    at its joints' centres, and from :data:`RESTARTS` arm postures drawn in the limits (seed 0),
    each with four times the iterations; returns ``(q, error)`` of the smallest weighted error
    (1 m of position per rad), stopping at the first within the tolerances."""
    arms = _starts(robot, q_near)
    thorough = IKOptions(options.damping, options.base_weight, 4 * options.max_iterations, options.tolerance,
                         options.position_tolerance, options.orientation_tolerance)
    best: tuple[FloatArray, FloatArray] | None = None
    for arm in arms:
        q, err = solve_pose(robot, target, np.r_[q_near[:N_BASE], arm], thorough)
        if best is None or np.linalg.norm(err) < np.linalg.norm(best[1]):
            best = (q, err)
        if _within(err, options.position_tolerance, options.orientation_tolerance):
            break
    return best


def _within(err: FloatArray, position: float, orientation: float) -> bool:
    return float(np.linalg.norm(err[:3])) <= position and float(np.linalg.norm(err[3:])) <= orientation


def position_reach(robot: MobileManipulator, target: FloatArray, q_near: FloatArray,
                   options: IKOptions = IKOptions()) -> float:
    """The smallest distance (m) from ``target``'s position to the end effector's origin that the
    damped step of :func:`solve_pose` on the position rows alone (``J_p``, 3 x nq; the orientation
    free) reaches from the starts of :func:`thorough_pose`, with four times the iterations."""
    winv = step_weights(robot, options.base_weight)
    best = np.inf
    for arm in _starts(robot, q_near):
        q = np.r_[q_near[:N_BASE], arm]
        for _ in range(4 * options.max_iterations):
            err = target[:3, 3] - robot.ee_pose(q)[:3, 3]
            if np.linalg.norm(err) < options.position_tolerance:
                return float(np.linalg.norm(err))
            J = robot.whole_body_jacobian(q)[:3]
            JW = J * winv
            q = q + JW.T @ np.linalg.solve(JW @ J.T + options.damping**2 * np.eye(3), err)
            q[N_BASE:] = np.clip(q[N_BASE:], robot.lower + 1e-6, robot.upper - 1e-6)
        best = min(best, float(np.linalg.norm(target[:3, 3] - robot.ee_pose(q)[:3, 3])))
    return best


def _starts(robot: MobileManipulator, q_near: FloatArray) -> list[FloatArray]:
    """The arm postures :func:`thorough_pose` starts from."""
    arms = [q_near[N_BASE:], robot.home_arm, (robot.lower + robot.upper) / 2]
    return arms + list(np.random.default_rng(0).uniform(robot.lower, robot.upper, (RESTARTS, robot.n_arm)))


def reachable_pose(robot: MobileManipulator, target: FloatArray, q_near: FloatArray,
                   options: IKOptions = IKOptions()) -> tuple[FloatArray, FloatArray, bool]:
    """``(q, error, reachable)``: the tracking IK from ``q_near``, and :func:`thorough_pose` where it
    stays above the tolerances; ``reachable`` unless the best error is above
    :data:`REACH_POSITION_M` / :data:`REACH_ORIENTATION_RAD`."""
    q, err = solve_pose(robot, target, q_near, options)
    if not _within(err, options.position_tolerance, options.orientation_tolerance):
        q2, err2 = thorough_pose(robot, target, q_near, options)
        if np.linalg.norm(err2) < np.linalg.norm(err):
            q, err = q2, err2
    return q, err, _within(err, REACH_POSITION_M, REACH_ORIENTATION_RAD)


def follow_path(
    robot: MobileManipulator, targets: FloatArray, q_init: FloatArray, options: IKOptions = IKOptions(),
    name: Callable[[int], str] | None = None,
) -> FloatArray:
    """Whole-body configurations (N x nq) tracking the poses ``targets`` (N x 4 x 4).

    The first configuration is ``q_init`` itself (the paper fixes ``q_1 = q_init``); its pose
    must match ``targets[0]`` within the tolerances. A later waypoint may stay off by more than
    :data:`REACH_POSITION_M` / :data:`REACH_ORIENTATION_RAD` where its point is in the whole
    body's reach (:func:`position_reach`; see the module's docstring): the NLP tries it.

    Raises:
        InfeasibleTaskError: naming the first waypoint whose point no IK start brings the end
            effector within :data:`REACH_POSITION_M` of, and that distance.
    """
    q_init = robot.check_configuration(q_init, "q_init")
    out = np.empty((len(targets), robot.nq))
    q = q_init
    for k, target in enumerate(targets):
        if k > 0:
            q, err, ok = reachable_pose(robot, target, q, options)
            reach = None if ok else position_reach(robot, target, q, options)
            ok = ok or reach <= REACH_POSITION_M  # the point is in reach: the NLP tries the pose
        else:
            err, reach = pose_error(robot, q, target), None
            ok = _within(err, options.position_tolerance, options.orientation_tolerance)
        if not ok:
            raise InfeasibleTaskError(_unreachable(robot, target, err, reach, name(k) if name else f"waypoint {k}", k))
        out[k] = q
    return out


def _unreachable(robot: MobileManipulator, target: FloatArray, err: FloatArray, reach: float | None,
                 label: str, k: int) -> str:
    """The line for waypoint ``k`` out of reach: ``reach`` is :func:`position_reach`'s distance."""
    pos, ang = float(np.linalg.norm(err[:3])), float(np.linalg.norm(err[3:]))
    where = f"the initial configuration does not reach {label}" if k == 0 else label
    if k == 0:
        what = f"position error {pos!r} m, orientation error {ang!r} rad"
    else:
        what = (f"position error {reach!r} m: no posture of the whole body brings the end effector nearer "
                f"(the best of {RESTARTS + 3} IK starts on the position alone, above {REACH_POSITION_M} m; "
                f"with the orientation too: {pos:.4g} m, {ang:.4g} rad)")
    return (f"{where}: end-effector pose unreachable, {what} (target position {target[:3, 3].tolist()!r})"
            + (" with the base fixed (robot.base: the arm alone must reach it)" if robot.base == "fixed" else ""))


def initial_guess(task: Any) -> FloatArray:
    """Feasible, smooth start for a task: IK along the path (trajectory) or onto the pose (hold).

    Also the ``quintic`` baseline (the interpolated path followed without optimization).
    """
    if task.mode == "hold":
        q, err, ok = reachable_pose(task.robot, task.targets[0], task.q_init)
        if not ok:
            raise InfeasibleTaskError(f"hold pose unreachable: position error {np.linalg.norm(err[:3]):.4f} m, "
                                      f"orientation error {np.linalg.norm(err[3:]):.4f} rad, the best of "
                                      f"{RESTARTS + 3} IK starts (above {REACH_POSITION_M} m or "
                                      f"{REACH_ORIENTATION_RAD} rad)")
        return q[None]
    return follow_path(task.robot, task.targets, task.q_init, name=lambda k: sample_name(task, k))


def sample_name(task: Any, k: int) -> str:
    """``waypoint k`` named as the user wrote the path: its time and the task file's items around it."""
    t = float(task.t[k])
    path = task.raw.get("path") if isinstance(getattr(task, "raw", None), dict) else None
    items = path.get("waypoints") or path.get("configurations") if isinstance(path, dict) else None
    label = f"waypoint {k} (t = {t!r} s"
    if isinstance(items, list) and items and all(isinstance(i, dict) and isinstance(i.get("t"), int | float)
                                                 for i in items):
        key = "waypoints" if path.get("waypoints") else "configurations"
        times = [float(i["t"]) for i in items]
        j = int(np.clip(np.searchsorted(times, t, side="right") - 1, 0, len(times) - 1))
        label += f", path.{key}[{j}]" if t == times[j] or j == len(times) - 1 else \
            f", between path.{key}[{j}] and path.{key}[{j + 1}]"
    return label + ")"
