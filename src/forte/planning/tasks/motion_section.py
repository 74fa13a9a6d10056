"""The task file's top-level motion fields: the start configuration, the path or the hold pose
(the targets at the sample times), the kinematic limits and a force profile given directly."""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin

from forte.exceptions import ForteError, TaskFileError
from forte.force.taskforce import given_force
from forte.model.robot import MobileManipulator
from forte.planning.tasks.paths import ForceAt, build_path, sine_parameters, starting_at, taught_knots, windowed_sine
from forte.planning.tasks.schema import Reader, check_joint_limits, dataclass_from, rotation
from forte.planning.tasks.weights_section import by_joint_name
from forte.settings import KinematicLimits
from forte.validation import MAX_DURATION_S, MAX_WAYPOINTS, FloatArray


def force_profile(reader: Reader, t: FloatArray, radius: float) -> ForceAt | None:
    """The task's force profile as a function of time, or ``None`` without one."""
    if not reader.has("force"):
        return None
    r = reader.sub("force")
    r.unknown({"kind", "offset", "amplitude", "frequency", "phase", "duration", "vector"})
    kind = r.get("kind", "constant")
    if kind == "windowed-sine":
        span = float(t[-1] - t[0])
        duration = r.number("duration", default=span or 1.0, positive=True, maximum=MAX_DURATION_S, unit=" s")
        if duration < span - 1e-9:  # the window is zero after its end: the rest of the path would get no force
            raise r.error("duration", f"the force profile lasts {duration:g} s but the path lasts {span:g} s; "
                          "expected a profile at least as long as the path")
        sine = sine_parameters(r)
        t0 = float(t[0])
        return lambda ts: given_force(ts, windowed_sine(ts - t0, duration, *sine), radius)
    if kind == "constant":
        vector = r.vector("vector", 3)
        return lambda ts: given_force(ts, np.tile(vector, (len(ts), 1)), radius)
    raise r.error("kind", f"expected 'windowed-sine' or 'constant', got {kind!r}")


def start_configuration(reader: Reader, robot: MobileManipulator, mode: str) -> tuple[FloatArray, Any]:
    """The start configuration (``initial_configuration``, else the first taught configuration,
    else the robot's home) and the taught knots (or None)."""
    q_init, knots = robot.home(), None
    if mode == "trajectory" and reader.has("path") and isinstance(reader.get("path"), dict) \
            and reader.get("path").get("kind") == "taught":
        knots = taught_knots(reader.sub("path"), robot)
        q_init = knots[1][0].copy()
    if reader.has("initial_configuration"):
        q_init = reader.vector("initial_configuration", robot.nq)
        check_joint_limits(reader, "initial_configuration", robot, q_init)
        if knots is not None and not np.allclose(q_init, knots[1][0], atol=1e-9):
            raise reader.error("initial_configuration", "differs from the first taught configuration "
                               "(path.configurations[0].q); leave it out")
    return q_init, knots


def path_targets(reader: Reader, robot: MobileManipulator, mode: str, T0: FloatArray, waypoints: int | None,
             teaching: FloatArray | None) -> tuple[FloatArray, FloatArray, Any]:
    """The sample times, the end-effector targets there and the path in time (None for a hold)."""
    if mode == "trajectory":
        if waypoints is not None and not 2 <= waypoints <= MAX_WAYPOINTS:
            raise TaskFileError(f"--waypoints: expected 2 to {MAX_WAYPOINTS} (forte's documented bound), "
                                f"got {waypoints}")
        t, targets_at = build_path(reader, T0, waypoints, robot)
        targets_at = starting_at(reader, targets_at(t)[0], T0, targets_at)
        return t, targets_at(t), targets_at
    if waypoints is not None:
        raise TaskFileError(f"--waypoints: applies to mode 'trajectory', {reader.path} is a 'hold' task")
    if reader.has("path"):
        raise reader.error("path", "not used in mode 'hold' (give pose or teaching_configuration)")
    return np.zeros(1), hold_pose(reader, robot, T0, teaching), None


def limits_section(reader: Reader, robot: MobileManipulator) -> KinematicLimits:
    """``limits:`` (per-joint entries by name), checked against the robot."""
    for key, default in (("arm_velocity", robot.model.velocityLimit), ("arm_acceleration", robot.acceleration_limits)):
        by_joint_name(reader, "limits", key, tuple(robot.arm_joints), default)
    limits = dataclass_from(reader, "limits", KinematicLimits, KinematicLimits())
    try:
        limits.resolve(robot)
    except ForteError as exc:
        raise reader.error("limits", str(exc)) from exc
    return limits


def hold_pose(reader: Reader, robot: MobileManipulator, T0: FloatArray, teaching: FloatArray | None) -> FloatArray:
    """A hold task's pose (``pose``, absolute or relative to the start), or the teaching configuration's."""
    if reader.has("pose"):
        r = reader.sub("pose")
        r.unknown({"position", "relative", "orientation"})
        p = r.vector("position", 3)
        if r.get("relative", False):
            p = T0[:3, 3] + p
        T = np.eye(4)
        T[:3, :3] = rotation(r, "orientation", T0[:3, :3])
        T[:3, 3] = p
        if teaching is not None:
            Tt = robot.ee_pose(teaching)
            gap = np.linalg.norm(Tt[:3, 3] - T[:3, 3])
            if gap > 1e-4 or np.linalg.norm(pin.log3(Tt[:3, :3] @ T[:3, :3].T)) > 1e-3:
                raise reader.error("teaching_configuration",
                                   f"does not reach the hold pose (position error {gap:.4f} m)")
        return T[None]
    if teaching is None:
        raise reader.error("pose", "mode 'hold' needs a pose or a teaching_configuration")
    return robot.ee_pose(teaching)[None]
