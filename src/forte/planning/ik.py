"""Damped least-squares whole-body inverse kinematics along a path of end-effector poses.

Used for the optimizer's initial guess and as the *quintic* baseline (the interpolated path
followed without optimization). Each waypoint starts from the previous solution, so the
result is continuous; base motion is weighted ``base_weight`` times more than arm motion, so
the arm does most of the work, as a teach-pendant style controller would.

Step (weighted, damped): ``dq = W^-1 J^T (J W^-1 J^T + lambda^2 I)^-1 e`` with the 6-D world
pose error ``e = [p_d - p; log(R_d R^T)]``, then a clamp to the arm joint limits.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import pinocchio as pin

from forte.exceptions import InfeasibleTaskError
from forte.model.robot import N_BASE, MobileManipulator
from forte.validation import FloatArray


@dataclass(frozen=True)
class IKOptions:
    damping: float = 1e-3
    base_weight: float = 10.0
    max_iterations: int = 200
    tolerance: float = 1e-9
    position_tolerance: float = 1e-4  # m: above this a waypoint is reported unreachable
    orientation_tolerance: float = 1e-3  # rad


def pose_error(robot: MobileManipulator, q: FloatArray, target: FloatArray) -> FloatArray:
    """6-D world-frame error ``[p_d - p; log(R_d R^T)]`` of the end-effector pose."""
    T = robot.ee_pose(q)
    return np.concatenate([target[:3, 3] - T[:3, 3], pin.log3(target[:3, :3] @ T[:3, :3].T)])


def solve_pose(
    robot: MobileManipulator, target: FloatArray, q_start: FloatArray, options: IKOptions = IKOptions(),
) -> tuple[FloatArray, FloatArray]:
    """One waypoint: returns ``(q, final error)``."""
    q = q_start.copy()
    base = 0.0 if robot.base == "fixed" else 1.0 / options.base_weight  # a fixed base: infinite weight
    winv = np.concatenate([np.full(N_BASE, base), np.ones(robot.n_arm)])
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


def follow_path(
    robot: MobileManipulator, targets: FloatArray, q_init: FloatArray, options: IKOptions = IKOptions(),
    name: Callable[[int], str] | None = None,
) -> FloatArray:
    """Whole-body configurations (N x nq) tracking the poses ``targets`` (N x 4 x 4).

    The first configuration is ``q_init`` itself (the paper fixes ``q_1 = q_init``); its pose
    must match ``targets[0]``.

    Raises:
        InfeasibleTaskError: naming the first waypoint the IK cannot reach and the distance.
    """
    q_init = robot.check_configuration(q_init, "q_init")
    out = np.empty((len(targets), robot.nq))
    q = q_init
    for k, target in enumerate(targets):
        if k > 0:
            q, err = solve_pose(robot, target, q, options)
        else:
            err = pose_error(robot, q, target)
        pos, ang = float(np.linalg.norm(err[:3])), float(np.linalg.norm(err[3:]))
        if pos > options.position_tolerance or ang > options.orientation_tolerance:
            label = name(k) if name is not None else f"waypoint {k}"
            where = f"the initial configuration does not reach {label}" if k == 0 else label
            raise InfeasibleTaskError(
                f"{where}: end-effector pose unreachable, position error {pos!r} m, "
                f"orientation error {ang!r} rad (target position {target[:3, 3].tolist()!r})"
                + (" with the base fixed (robot.base: the arm alone must reach it)" if robot.base == "fixed" else "")
            )
        out[k] = q
    return out


def initial_guess(task: Any) -> FloatArray:
    """Feasible, smooth start for a task: IK along the path (trajectory) or onto the pose (hold).

    Also the ``quintic`` baseline (the interpolated path followed without optimization).
    """
    if task.mode == "hold":
        q, err = solve_pose(task.robot, task.targets[0], task.q_init)
        if np.linalg.norm(err[:3]) > 1e-4:
            raise InfeasibleTaskError(f"hold pose unreachable from initial_configuration: position error "
                                      f"{np.linalg.norm(err[:3]):.4f} m")
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
