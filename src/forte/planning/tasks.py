"""Task files: YAML descriptions of a planning problem, validated with precise errors.

A task names the robot (default: the built-in one), the mode (``trajectory`` or ``hold``), the
end-effector path or pose, the payload (a mass, or a description and an image for the
estimator) or a force profile given directly, the uncertainty radius, weights, torque limits
and solver options. Every error names the file, the field and what was expected. See
``examples/tasks/*.yaml`` and the README for the schema.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin
import yaml

from forte.capability.metrics import CapabilityParameters
from forte.exceptions import ForteError, TaskFileError
from forte.force.taskforce import DEFAULT_RADIUS, TaskForce, given_force, payload_force
from forte.model.robot import MobileManipulator, ToolLoad, default_robot
from forte.model.trajectory import quintic_blend, quintic_path
from forte.planning.costs import CostWeights
from forte.planning.optimizer import KinematicLimits, SolverOptions
from forte.validation import FloatArray

MODES = ("trajectory", "hold")


@dataclass
class Task:
    """A validated planning problem."""

    name: str
    source: Path | None
    robot: MobileManipulator
    mode: str
    t: FloatArray  # N
    targets: FloatArray  # N x 4 x 4 world-frame end-effector poses
    q_init: FloatArray
    radius: float
    payload: dict[str, Any]  # mass, description, image, estimate (filled by the planner)
    force_profile: TaskForce | None  # a force given directly instead of a payload
    weights: CostWeights
    solver: SolverOptions
    teaching: FloatArray | None = None
    limits: KinematicLimits = field(default_factory=KinematicLimits)
    raw: dict[str, Any] = field(default_factory=dict)

    @property
    def n(self) -> int:
        return len(self.t)

    def force(self, mass: float | None = None) -> TaskForce:
        """Desired forces: the given profile, or ``m (p'' - g)`` along the path."""
        if self.force_profile is not None:
            return self.force_profile
        m = mass if mass is not None else self.payload.get("mass")
        if m is None:
            raise TaskFileError(
                f"{self._where('payload.mass')}: no payload mass; give payload.mass, --mass KG, "
                "or a payload description/image for the estimator"
            )
        return payload_force(self.t, self.targets[:, :3, 3], m, self.radius, self.robot.gravity)

    def _where(self, key: str) -> str:
        return f"{self.source}: {key}" if self.source else key


class _Reader:
    """Typed access to a mapping with errors that name file and dotted key."""

    def __init__(self, data: Any, path: Path | None, prefix: str = "") -> None:
        self.path, self.prefix = path, prefix
        if not isinstance(data, dict):
            raise self.error("", f"expected a mapping, got {type(data).__name__}")
        self.data = data

    def key(self, name: str) -> str:
        return f"{self.prefix}{name}" if self.prefix else name

    def error(self, name: str, message: str) -> TaskFileError:
        where = self.key(name).rstrip(".") or "(top level)"
        return TaskFileError(f"{self.path or '<task>'}: {where}: {message}")

    def has(self, name: str) -> bool:
        return self.data.get(name) is not None

    def get(self, name: str, default: Any = None) -> Any:
        return self.data.get(name, default)

    def sub(self, name: str) -> _Reader:
        return _Reader(self.data[name], self.path, f"{self.key(name)}.")

    def number(self, name: str, default: float | None = None, positive: bool = False,
               nonnegative: bool = False) -> float:
        value = self.data.get(name, default)
        if value is None:
            raise self.error(name, "required field is missing")
        if isinstance(value, bool) or not isinstance(value, int | float) or not np.isfinite(value):
            raise self.error(name, f"expected a finite number, got {value!r}")
        if positive and value <= 0:
            raise self.error(name, f"expected a number > 0, got {value!r}")
        if nonnegative and value < 0:
            raise self.error(name, f"expected a number >= 0, got {value!r}")
        return float(value)

    def vector(self, name: str, size: int | None = None, default: Any = None) -> FloatArray:
        value = self.data.get(name, default)
        if value is None:
            raise self.error(name, "required field is missing")
        try:
            arr = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            raise self.error(name, f"expected a list of numbers, got {value!r}") from None
        if arr.ndim != 1 or (size is not None and arr.size != size):
            expected = f"a list of {size} numbers" if size else "a list of numbers"
            raise self.error(name, f"expected {expected}, got {value!r}")
        if not np.all(np.isfinite(arr)):
            raise self.error(name, f"expected finite numbers, got {value!r}")
        return arr

    def integer(self, name: str, default: int | None = None, minimum: int = 1) -> int:
        value = self.data.get(name, default)
        if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
            raise self.error(name, f"expected an integer >= {minimum}, got {value!r}")
        return value

    def unknown(self, allowed: set[str]) -> None:
        extra = sorted(set(self.data) - allowed)
        if extra:
            raise self.error(extra[0], f"unknown field; expected one of {', '.join(sorted(allowed))}")


def _rotation(reader: _Reader, name: str, default: FloatArray) -> FloatArray:
    if not reader.has(name):
        return default
    value = reader.get(name)
    if isinstance(value, dict):
        r = reader.sub(name)
        r.unknown({"rpy", "matrix"})
        if r.has("rpy"):
            return pin.rpy.rpyToMatrix(*r.vector("rpy", 3))
        try:
            R = np.asarray(r.get("matrix"), dtype=float)
        except (TypeError, ValueError):
            raise r.error("matrix", f"expected a 3x3 matrix of numbers, got {r.get('matrix')!r}") from None
        if R.shape != (3, 3) or not np.all(np.isfinite(R)) or not np.allclose(R @ R.T, np.eye(3), atol=1e-6):
            raise r.error("matrix", "expected an orthonormal 3x3 rotation matrix")
        return R
    raise reader.error(name, "expected a mapping with 'rpy' (radians) or 'matrix'")


def _robot(reader: _Reader, base: Path) -> MobileManipulator:
    if not reader.has("robot"):
        overrides: dict[str, Any] = {}
        if reader.has("torque_limits"):
            overrides["torque_limits"] = reader.vector("torque_limits", 7)
        return default_robot(**overrides)
    r = reader.sub("robot")
    r.unknown({"urdf", "ee_frame", "arm_joints", "mount", "tool", "torque_limits", "gravity", "name"})
    kwargs: dict[str, Any] = {}
    if r.has("urdf"):
        urdf = str(r.get("urdf"))
        if not urdf.startswith("erd:") and not Path(urdf).is_absolute():
            urdf = str(base / urdf)
        kwargs["urdf"] = urdf
        if not r.has("ee_frame"):
            raise r.error("ee_frame", "required when urdf is given")
        kwargs["ee_frame"] = str(r.get("ee_frame"))
    elif r.has("ee_frame"):
        kwargs["ee_frame"] = str(r.get("ee_frame"))
    if r.has("arm_joints"):
        joints = r.get("arm_joints")
        if not isinstance(joints, list) or not all(isinstance(j, str) for j in joints):
            raise r.error("arm_joints", "expected a list of joint names")
        kwargs["arm_joints"] = tuple(joints)
    if r.has("mount"):
        m = r.sub("mount")
        m.unknown({"xyz", "rpy"})
        T = np.eye(4)
        T[:3, 3] = m.vector("xyz", 3, default=[0, 0, 0])
        T[:3, :3] = pin.rpy.rpyToMatrix(*m.vector("rpy", 3, default=[0, 0, 0]))
        kwargs["mount"] = T
    if "tool" in r.data:
        if r.get("tool") is None:
            kwargs["tool"] = None
        else:
            tl = r.sub("tool")
            tl.unknown({"mass", "com", "inertia"})
            inertia = tl.get("inertia", [[0, 0, 0]] * 3)
            if np.shape(inertia) == (3,):
                inertia = np.diag(inertia)
            kwargs["tool"] = ToolLoad(mass=tl.number("mass", positive=True), com=tuple(tl.vector("com", 3, [0, 0, 0])),
                                      inertia=tuple(map(tuple, np.asarray(inertia, dtype=float))))
    limits_key = "torque_limits" if r.has("torque_limits") else None
    if limits_key:
        kwargs["torque_limits"] = r.vector("torque_limits")
    elif reader.has("torque_limits"):
        kwargs["torque_limits"] = reader.vector("torque_limits")
    if r.has("gravity"):
        kwargs["gravity"] = r.number("gravity", positive=True)
    if r.has("name"):
        kwargs["name"] = str(r.get("name"))
    try:
        if "urdf" in kwargs:
            return MobileManipulator(**kwargs)
        return default_robot(**kwargs)
    except ForteError as exc:
        raise r.error("", str(exc)) from exc


def _windowed_sine(t: FloatArray, duration: float, offset: FloatArray, amp: FloatArray, freq: FloatArray,
                   phase: FloatArray) -> FloatArray:
    """Paper Section 5.2: ``y(t) = w(t) (c + a * sin(2 pi f t + phi))``, ``w = 4 s (1 - s)``."""
    s = quintic_blend(np.clip(t / duration, 0, 1))
    w = 4 * s * (1 - s)
    return w[:, None] * (offset + amp * np.sin(2 * np.pi * freq * t[:, None] + phase))


def _sine_parameters(r: _Reader) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    return (r.vector("offset", 3, [0, 0, 0]), r.vector("amplitude", 3), r.vector("frequency", 3),
            r.vector("phase", 3, [0, 0, 0]))


def _samples(r: _Reader, t0: float, t1: float, waypoints: int | None) -> FloatArray:
    if waypoints is not None:
        n = waypoints
    elif r.has("samples"):
        n = r.integer("samples", minimum=2)
    elif r.has("rate"):
        n = int(round((t1 - t0) * r.number("rate", positive=True))) + 1
        if n < 2:
            raise r.error("rate", f"gives {n} waypoint over {t1 - t0} s; expected at least 2")
    else:
        n = 50
    return np.linspace(t0, t1, n)


def _path(reader: _Reader, T0: FloatArray, waypoints: int | None) -> tuple[FloatArray, FloatArray]:
    if not reader.has("path"):
        raise reader.error("path", "required for mode 'trajectory'")
    r = reader.sub("path")
    r.unknown({"kind", "waypoints", "relative", "samples", "rate", "orientation", "duration", "amplitude",
               "frequency", "phase", "offset"})
    kind = r.get("kind", "waypoints")
    R = _rotation(r, "orientation", T0[:3, :3])
    if kind == "waypoints":
        pts = r.get("waypoints")
        if not isinstance(pts, list) or len(pts) < 2:
            raise r.error("waypoints", "expected a list of at least 2 waypoints {t, position}")
        times, positions = [], []
        relative = r.get("relative", False)
        if not isinstance(relative, bool):
            raise r.error("relative", f"expected true or false, got {relative!r}")
        for i, item in enumerate(pts):
            w = _Reader(item, r.path, f"{r.key('waypoints')}[{i}].")
            w.unknown({"t", "position"})
            times.append(w.number("t"))
            p = w.vector("position", 3)
            positions.append(T0[:3, 3] + p if relative else p)
        times_arr = np.asarray(times)
        bad = np.flatnonzero(np.diff(times_arr) <= 0)
        if bad.size:
            raise r.error(f"waypoints[{bad[0] + 1}].t", f"times must increase, got {times_arr[bad[0]]} then "
                          f"{times_arr[bad[0] + 1]}")
        t = _samples(r, times_arr[0], times_arr[-1], waypoints)
        P = quintic_path(times_arr, np.asarray(positions), t)
    elif kind == "windowed-sine":
        duration = r.number("duration", positive=True)
        t = _samples(r, 0.0, duration, waypoints)
        P = T0[:3, 3] + _windowed_sine(t, duration, *_sine_parameters(r))
    else:
        raise r.error("kind", f"expected 'waypoints' or 'windowed-sine', got {kind!r}")
    targets = np.repeat(np.eye(4)[None], len(t), axis=0)
    targets[:, :3, :3] = R
    targets[:, :3, 3] = P
    return t, targets


def _force_profile(reader: _Reader, t: FloatArray, radius: float) -> TaskForce | None:
    if not reader.has("force"):
        return None
    r = reader.sub("force")
    r.unknown({"kind", "offset", "amplitude", "frequency", "phase", "duration", "vector"})
    kind = r.get("kind", "constant")
    if kind == "windowed-sine":
        duration = r.number("duration", default=float(t[-1] - t[0]) or 1.0, positive=True)
        return given_force(t, _windowed_sine(t - t[0], duration, *_sine_parameters(r)), radius)
    if kind == "constant":
        return given_force(t, np.tile(r.vector("vector", 3), (len(t), 1)), radius)
    raise r.error("kind", f"expected 'windowed-sine' or 'constant', got {kind!r}")


def _dataclass_from(reader: _Reader, name: str, cls: type, base: Any) -> Any:
    """Override fields of the dataclass instance ``base`` from ``reader[name]``, by field type."""
    if not reader.has(name):
        return base
    r = reader.sub(name)
    fields = {f.name: str(f.type) for f in dataclasses.fields(cls)}
    r.unknown(set(fields) - {"extra"})
    values: dict[str, Any] = {}
    try:
        for key, value in r.data.items():
            kind = fields[key]
            if key == "capability_params":
                sub = r.sub(key)
                sub.unknown({f.name for f in dataclasses.fields(CapabilityParameters)})
                try:
                    values[key] = CapabilityParameters(**{k: sub.number(k) for k in sub.data})
                except ForteError as exc:
                    raise sub.error("", str(exc)) from exc
            elif kind.startswith("tuple"):
                default = getattr(base, key)
                values[key] = tuple(r.vector(key, len(default) if default is not None else None))
            elif kind == "bool":
                if not isinstance(value, bool):
                    raise r.error(key, f"expected true or false, got {value!r}")
                values[key] = value
            elif kind == "int":
                values[key] = r.integer(key, minimum=0)
            elif kind == "float":
                values[key] = r.number(key, nonnegative=True)
            elif kind.startswith("str"):
                if not isinstance(value, str):
                    raise r.error(key, f"expected a string, got {value!r}")
                values[key] = value
            else:  # pragma: no cover - every field type is handled above
                raise r.error(key, "cannot be set from a task file")
        return dataclasses.replace(base, **values)
    except ForteError as exc:
        if isinstance(exc, TaskFileError):
            raise
        raise r.error("", str(exc)) from exc


def load_task(
    path: str | Path, mass: float | None = None, waypoints: int | None = None,
) -> Task:
    """Read and validate a task file.

    Args:
        path: The YAML file.
        mass: Payload mass overriding the file's (kg).
        waypoints: Number of samples overriding the file's (trajectory mode).
    """
    path = Path(path)
    if not path.is_file():
        raise TaskFileError(f"{path}: task file does not exist")
    try:
        data = yaml.safe_load(path.read_text())
    except yaml.YAMLError as exc:
        raise TaskFileError(f"{path}: not valid YAML: {exc}") from exc
    return task_from_dict(data, path, mass=mass, waypoints=waypoints)


def task_from_dict(data: Any, path: Path | None = None, mass: float | None = None,
                   waypoints: int | None = None) -> Task:
    """Validate an already-parsed task (see :func:`load_task`)."""
    reader = _Reader(data, path)
    reader.unknown({"name", "robot", "mode", "initial_configuration", "path", "pose", "payload", "force",
                    "uncertainty_radius", "weights", "torque_limits", "solver", "teaching_configuration", "limits"})
    base = path.parent if path else Path.cwd()
    robot = _robot(reader, base)
    mode = reader.get("mode", "trajectory")
    if mode not in MODES:
        raise reader.error("mode", f"expected one of {', '.join(MODES)}, got {mode!r}")
    q_init = robot.home()
    if reader.has("initial_configuration"):
        q_init = reader.vector("initial_configuration", robot.nq)
        _check_joint_limits(reader, "initial_configuration", robot, q_init)
    radius = reader.number("uncertainty_radius", DEFAULT_RADIUS, nonnegative=True)
    teaching = None
    if reader.has("teaching_configuration"):
        teaching = reader.vector("teaching_configuration", robot.nq)
        _check_joint_limits(reader, "teaching_configuration", robot, teaching)
    T0 = robot.ee_pose(q_init)
    if mode == "trajectory":
        if waypoints is not None and waypoints < 2:
            raise TaskFileError(f"waypoints: expected at least 2 for a trajectory, got {waypoints}")
        t, targets = _path(reader, T0, waypoints)
        if not np.allclose(targets[0], T0, atol=1e-6):
            raise reader.error("path", "the path must start at the end-effector pose of initial_configuration "
                               f"(at {np.round(T0[:3, 3], 4).tolist()}); use 'relative: true'")
    else:
        if waypoints is not None:
            raise TaskFileError(f"--waypoints: applies to mode 'trajectory', {path} is a 'hold' task")
        if reader.has("path"):
            raise reader.error("path", "not used in mode 'hold' (give pose or teaching_configuration)")
        t = np.zeros(1)
        targets = _hold_pose(reader, robot, T0, teaching)
    payload: dict[str, Any] = {}
    if reader.has("payload"):
        pr = reader.sub("payload")
        pr.unknown({"mass", "description", "image"})
        if pr.has("mass"):
            payload["mass"] = pr.number("mass", positive=True)
        if pr.has("description"):
            payload["description"] = str(pr.get("description"))
        if pr.has("image"):
            image = Path(str(pr.get("image")))
            payload["image"] = str(image if image.is_absolute() else base / image)
    if mass is not None:
        if not np.isfinite(mass) or mass <= 0:
            raise TaskFileError(f"--mass: expected a finite number > 0 kg, got {mass}")
        payload["mass"] = float(mass)
    force_profile = _force_profile(reader, t, radius)
    if force_profile is None and not payload:
        raise reader.error("payload", "give a payload (mass, or description/image) or a force profile")
    weights = _dataclass_from(reader, "weights", CostWeights, CostWeights())
    solver = _dataclass_from(reader, "solver", SolverOptions, SolverOptions())
    limits = _dataclass_from(reader, "limits", KinematicLimits, KinematicLimits())
    try:
        limits.resolve(robot)
    except ForteError as exc:
        raise reader.error("limits", str(exc)) from exc
    name = str(reader.get("name", path.stem if path else "task"))
    return Task(name=name, source=path, robot=robot, mode=mode, t=t, targets=targets, q_init=q_init,
                radius=radius, payload=payload, force_profile=force_profile, weights=weights, solver=solver,
                teaching=teaching, limits=limits, raw=data)


def _check_joint_limits(reader: _Reader, name: str, robot: MobileManipulator, q: FloatArray) -> None:
    arm = q[3:]
    bad = np.flatnonzero((arm < robot.lower - 1e-9) | (arm > robot.upper + 1e-9))
    if bad.size:
        i = int(bad[0])
        raise reader.error(f"{name}[{i + 3}]", f"joint {robot.arm_joints[i]} = {arm[i]} is outside its limits "
                           f"[{robot.lower[i]}, {robot.upper[i]}]")


def _hold_pose(reader: _Reader, robot: MobileManipulator, T0: FloatArray, teaching: FloatArray | None) -> FloatArray:
    if reader.has("pose"):
        r = reader.sub("pose")
        r.unknown({"position", "relative", "orientation"})
        p = r.vector("position", 3)
        if r.get("relative", False):
            p = T0[:3, 3] + p
        T = np.eye(4)
        T[:3, :3] = _rotation(r, "orientation", T0[:3, :3])
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
