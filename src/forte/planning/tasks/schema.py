"""Readers of the task-file schema: typed access to YAML mappings with errors that name the file,
the dotted field and what was expected, and the sections shared by every task (robot, options).

The world around the robot is read by :mod:`forte.planning.tasks.scene_section`: ``scene:`` (bodies),
``scene_file:`` (a URDF's or MJCF's static bodies), ``clearance:`` (m, default 0.02) and
``floor:``, the floor every world has: ``{height: h}`` (m, world z; default 0, the plane MuJoCo's
robot rides on) or ``none``. The arm's links and the payload keep the clearance from it; the
parts rigid with the base rest on it (one more than 1 mm below it is an arm mounted in the floor,
an error naming the link).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from forte.exceptions import ForteError, TaskFileError
from forte.model.base_support import BaseSupport, box_support
from forte.model.presets import ROBOT_PRESETS, preset_robot, with_torque_limits
from forte.model.robot import (
    BASE_MODES,
    MobileManipulator,
    ToolLoad,
    default_robot,
    robot_from_description,
)
from forte.settings import CapabilityParameters
from forte.validation import MAX_MASS_KG, FloatArray, _short, unknown_field


class Reader:
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

    def choice(self, name: str, allowed: tuple[str, ...], default: str) -> str:
        """The value of ``name`` (``default`` when absent), one of ``allowed``."""
        value = self.get(name, default)
        if value not in allowed:
            raise self.error(name, f"expected one of {', '.join(allowed)}, got {value!r}")
        return value

    def sub(self, name: str) -> Reader:
        return Reader(self.data[name], self.path, f"{self.key(name)}.")

    def number(self, name: str, default: float | None = None, positive: bool = False,
               nonnegative: bool = False, maximum: float | None = None, unit: str = "") -> float:
        value = self.data.get(name, default)
        if value is None:
            raise self.error(name, "required field is missing")
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self.error(name, f"expected a finite number, got {_short(value)}")
        try:
            x = float(value)
        except OverflowError:  # an integer too large for a float
            x = float("inf")
        if not np.isfinite(x):
            raise self.error(name, f"expected a finite number, got {_short(value)}")
        if positive and x <= 0:
            raise self.error(name, f"expected a number > 0, got {value!r}")
        if nonnegative and x < 0:
            raise self.error(name, f"expected a number >= 0, got {value!r}")
        if maximum is not None and x > maximum:
            raise self.error(name, f"expected a number <= {maximum:g}{unit} (forte's documented bound), "
                             f"got {x:g}")
        return x

    def vector(self, name: str, size: int | None = None, default: Any = None) -> FloatArray:
        value = self.data.get(name, default)
        if value is None:
            raise self.error(name, "required field is missing")
        expected = f"a list of {size} numbers" if size else "a list of numbers"
        if not isinstance(value, list | tuple) or any(isinstance(v, bool) for v in value):
            raise self.error(name, f"expected {expected}, got {_short(value)}")
        try:
            arr = np.asarray(value, dtype=float)
        except (TypeError, ValueError, OverflowError):
            raise self.error(name, f"expected {expected}, got {_short(value)}") from None
        if arr.ndim != 1 or (size is not None and arr.size != size):
            raise self.error(name, f"expected {expected}, got {_short(value)}")
        if not np.all(np.isfinite(arr)):
            raise self.error(name, f"expected finite numbers, got {_short(value)}")
        return arr

    def matrix(self, name: str, rows: int, cols: int, default: Any = None) -> FloatArray:
        """A ``rows`` x ``cols`` list of lists of finite numbers."""
        value = self.data.get(name, default)
        what = f"a {rows}x{cols} matrix (a list of {rows} lists of {cols} numbers)"
        if (not isinstance(value, list | tuple) or len(value) != rows
                or not all(isinstance(r, list | tuple) and len(r) == cols for r in value)
                or any(isinstance(v, bool) or not isinstance(v, int | float) for r in value for v in r)):
            raise self.error(name, f"expected {what}, got {_short(value)}")
        try:
            arr = np.asarray(value, dtype=float)
        except OverflowError:
            arr = np.full((rows, cols), np.inf)
        if not np.all(np.isfinite(arr)):
            raise self.error(name, f"expected finite numbers, got {_short(value)}")
        return arr

    def integer(self, name: str, default: int | None = None, minimum: int = 1, maximum: int | None = None) -> int:
        value = self.data.get(name, default)
        if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
            raise self.error(name, f"expected an integer >= {minimum}, got {_short(value)}")
        if maximum is not None and value > maximum:
            raise self.error(name, f"expected an integer <= {maximum} (forte's documented bound), got {value}")
        return value

    def unknown(self, allowed: set[str]) -> None:
        extra = sorted(set(self.data) - allowed)
        if extra:
            raise self.error(extra[0], unknown_field(extra[0], sorted(allowed)))


def rotation(reader: Reader, name: str, default: FloatArray) -> FloatArray:
    if not reader.has(name):
        return default
    value = reader.get(name)
    if isinstance(value, dict):
        r = reader.sub(name)
        r.unknown({"rpy", "quaternion", "matrix"})
        if r.has("rpy"):
            return pin.rpy.rpyToMatrix(*r.vector("rpy", 3))
        if r.has("quaternion"):  # [x, y, z, w], as ROS and MoveIt write it
            xyzw = r.vector("quaternion", 4)
            norm = float(np.linalg.norm(xyzw))
            if abs(norm - 1.0) > 1e-3:
                raise r.error("quaternion", f"expected a unit quaternion [x, y, z, w], got norm {norm:.6g}")
            return pin.Quaternion(xyzw[3], *xyzw[:3]).normalized().toRotationMatrix()
        try:
            R = np.asarray(r.get("matrix"), dtype=float)
        except (TypeError, ValueError):
            raise r.error("matrix", f"expected a 3x3 matrix of numbers, got {r.get('matrix')!r}") from None
        if R.shape != (3, 3) or not np.all(np.isfinite(R)) or not np.allclose(R @ R.T, np.eye(3), atol=1e-6):
            raise r.error("matrix", "expected an orthonormal 3x3 rotation matrix")
        return R
    raise reader.error(name, "expected a mapping with 'rpy' (radians), 'quaternion' ([x, y, z, w]) or 'matrix'")


def _mount(m: Reader) -> FloatArray:
    """``robot.mount``: the arm's base frame on the mobile base (``xyz``, ``rpy``)."""
    m.unknown({"xyz", "rpy"})
    T = np.eye(4)
    T[:3, 3] = m.vector("xyz", 3, default=[0, 0, 0])
    T[:3, :3] = pin.rpy.rpyToMatrix(*m.vector("rpy", 3, default=[0, 0, 0]))
    return T


def _tool(tl: Reader) -> ToolLoad:
    """``robot.tool``: a load rigid with the hand (mass, centre of mass, inertia: a 3 x 3 matrix or
    its diagonal)."""
    tl.unknown({"mass", "com", "inertia"})
    inertia_value = tl.get("inertia", [[0, 0, 0]] * 3)
    if isinstance(inertia_value, list | tuple) and len(inertia_value) == 3 and all(
            not isinstance(v, list | tuple) for v in inertia_value):
        inertia = np.diag(tl.vector("inertia", 3))  # the diagonal
    else:
        inertia = tl.matrix("inertia", 3, 3, [[0, 0, 0]] * 3)
    mass = tl.number("mass", positive=True, maximum=MAX_MASS_KG, unit=" kg")
    com = tl.vector("com", 3, [0, 0, 0])
    try:
        return ToolLoad(mass=mass, com=tuple(com), inertia=tuple(map(tuple, inertia)))
    except ForteError as exc:
        raise tl.error("", str(exc)) from exc


def _locked_joints(lj: Reader) -> dict[str, float]:
    """``robot.locked_joints``: ``{joint name: value}`` (rad or m) of joints that are not planned;
    the names are checked against the URDF by the robot model."""
    return {str(name): lj.number(str(name)) for name in lj.data}


def robot_section(reader: Reader, base: Path) -> MobileManipulator:
    """``robot:`` (a preset, or a URDF with its end-effector frame, and what the description does
    not carry), or the built-in robot when the file has none."""
    if not reader.has("robot"):
        overrides: dict[str, Any] = {}
        if reader.has("torque_limits"):
            overrides["torque_limits"] = reader.vector("torque_limits", 7)
        return default_robot(**overrides)
    r = reader.sub("robot")
    r.unknown({"preset", "urdf", "ee_frame", "arm_joints", "mount", "tool", "torque_limits", "gravity", "name",
               "tool_force_mass", "home_arm", "acceleration_limits", "base", "locked_joints", *SUPPORT_FIELDS})
    kwargs: dict[str, Any] = {}
    if r.has("base"):
        kwargs["base"] = r.choice("base", BASE_MODES, "holonomic")
    preset = str(r.get("preset", "authors"))
    if preset not in ROBOT_PRESETS:
        raise r.error("preset", f"expected one of {', '.join(ROBOT_PRESETS)}, got {preset!r}")
    if r.has("tool_force_mass"):
        kwargs["tool_force_mass"] = r.number("tool_force_mass", nonnegative=True)
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
    if r.has("locked_joints"):
        kwargs["locked_joints"] = _locked_joints(r.sub("locked_joints"))
    if r.has("mount"):
        kwargs["mount"] = _mount(r.sub("mount"))
    if "tool" in r.data:
        kwargs["tool"] = None if r.get("tool") is None else _tool(r.sub("tool"))
    limits_key = "torque_limits" if r.has("torque_limits") else None
    if limits_key:
        kwargs["torque_limits"] = r.vector("torque_limits")
    top_limits = reader.vector("torque_limits") if limits_key is None and reader.has("torque_limits") else None
    if r.has("gravity"):
        kwargs["gravity"] = r.number("gravity", positive=True, maximum=1000.0, unit=" m/s^2")
    if r.has("name"):
        kwargs["name"] = str(r.get("name"))
    for key in ("home_arm", "acceleration_limits"):  # what a URDF does not carry
        if r.has(key):
            kwargs[key] = tuple(r.vector(key))
    try:
        robot = MobileManipulator(**kwargs) if "urdf" in kwargs and not r.has("preset") \
            else preset_robot(preset, **kwargs)
        if top_limits is not None:  # the file's top-level torque_limits: one per arm joint of this robot
            if top_limits.size != robot.n_arm:
                raise reader.error("torque_limits", f"expected a list of {robot.n_arm} numbers (one per arm "
                                   f"joint), got {top_limits.size}")
            robot = with_torque_limits(robot, top_limits)
        return support_section(r, robot)
    except TaskFileError:
        raise
    except ForteError as exc:
        raise r.error("", str(exc)) from exc


#: The ``robot:`` fields that state the base's support (:mod:`forte.model.base_support`).
SUPPORT_FIELDS = ("base_footprint", "base_mass", "base_com")


def support_section(r: Reader, robot: MobileManipulator) -> MobileManipulator:
    """``robot`` with the base support of ``robot.base_footprint`` (a list of ``[x, y]`` vertices, m,
    base frame; ``box``: forte's base box with the simulator's base mass; ``null``: none) and
    ``base_mass`` (kg, default 0 with a list) and ``base_com`` (m) on top of the footprint or of
    the preset's support."""
    if not any(key in r.data for key in SUPPORT_FIELDS):
        return robot
    support = robot.base_support
    if "base_footprint" in r.data:
        value = r.get("base_footprint")
        if value is None:
            support = None
        elif value == "box":
            support = box_support(robot.mount[2, 3])
        else:
            support = BaseSupport(value, source="the task file")
    if support is None and (r.has("base_mass") or r.has("base_com")):
        raise r.error("base_footprint", "required with base_mass or base_com (the support polygon, m)")
    if support is not None:
        mass = r.number("base_mass", nonnegative=True, maximum=MAX_MASS_KG, unit=" kg") if r.has("base_mass") \
            else support.mass
        com = tuple(r.vector("base_com", 3)) if r.has("base_com") else support.com
        support = dataclasses.replace(support, mass=mass, com=com)
    return robot_from_description({**robot.describe(), "base_support": support})


#: Fields of a ``controller:`` block (their values are checked against the robot by
#: :func:`forte.execution.gains.gains_from_mapping` when the plan is simulated).
CONTROLLER_FIELDS = frozenset({"bandwidth_hz", "damping_ratio", "K_a", "D_a", "M_b", "B_b", "K_b", "D_b",
                               "base_feedforward", "force_feedforward", "base_coupling", "force_along_reference"})


def controller_section(reader: Reader) -> dict[str, Any]:
    """The task's ``controller:`` mapping (empty when absent); unknown fields are errors."""
    if "controller" not in reader.data or reader.get("controller") is None:
        return {}
    r = reader.sub("controller")
    r.unknown(set(CONTROLLER_FIELDS))
    return dict(r.data)


#: Fields whose length follows the robot (checked against it once the robot is known).
ROBOT_SIZED_FIELDS = frozenset({"joint_dof_weights"})


def dataclass_from(reader: Reader, name: str, cls: type, base: Any) -> Any:
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
                    values[key] = dataclasses.replace(getattr(base, key), **{k: sub.number(k) for k in sub.data})
                except ForteError as exc:
                    raise sub.error("", str(exc)) from exc
            elif kind.startswith("tuple"):
                default = getattr(base, key)
                size = None if default is None or key in ROBOT_SIZED_FIELDS else len(default)
                values[key] = tuple(r.vector(key, size))
            elif kind in ("bool", "bool | None"):
                if not isinstance(value, bool) and not (value is None and kind == "bool | None"):
                    raise r.error(key, f"expected true or false{' or null' if '|' in kind else ''}, got {value!r}")
                values[key] = value
            elif kind == "int":
                values[key] = r.integer(key, minimum=0, maximum=10**9)
            elif kind == "float":
                values[key] = r.number(key, nonnegative=True, maximum=1e12)
            elif kind == "float | None":
                values[key] = None if value is None else r.number(key, nonnegative=True, maximum=1e12)
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


def check_joint_limits(reader: Reader, name: str, robot: MobileManipulator, q: FloatArray) -> None:
    arm = q[3:]
    bad = np.flatnonzero((arm < robot.lower - 1e-9) | (arm > robot.upper + 1e-9))
    if bad.size:
        i = int(bad[0])
        raise reader.error(f"{name}[{i + 3}]", f"joint {robot.arm_joints[i]} = {arm[i]} is outside its limits "
                           f"[{robot.lower[i]}, {robot.upper[i]}]")
