"""What a robot description is made of: where its URDF lives, end-effector loads, and the
constants of the built-in presets (the authors' MOCA and the earlier MOCA-like estimate).
"""

from __future__ import annotations

from dataclasses import dataclass
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from forte.exceptions import InvalidInputError, RobotModelError
from forte.validation import FloatArray, as_array, as_positive, as_vector

#: Torque limits used in the paper's experiments (Nm): joints 1-4 and 5-7 of the Franka arm.
PAPER_TORQUE_LIMITS: tuple[float, ...] = (60.0, 60.0, 60.0, 60.0, 12.0, 12.0, 12.0)
#: Named torque-limit sets (``forte experiment --torque-limits``): ``paper``, the paper's 60/12 Nm
#: (the default), or ``urdf``, the robot's URDF efforts (``None``: read from the model; 87/12 Nm
#: on the Panda), a what-if.
TORQUE_LIMIT_SETS: dict[str, tuple[float, ...] | None] = {"paper": PAPER_TORQUE_LIMITS, "urdf": None}
#: Joint names of the Franka Panda arm in example-robot-data.
PANDA_ARM_JOINTS: tuple[str, ...] = tuple(f"panda_joint{i}" for i in range(1, 8))
#: The Panda's usual "ready" pose.
PANDA_HOME: tuple[float, ...] = (0.0, -np.pi / 4, 0.0, -3 * np.pi / 4, 0.0, np.pi / 2, np.pi / 4)
#: Franka Panda joint acceleration limits (rad/s^2, datasheet).
PANDA_ACCELERATION_LIMITS: tuple[float, ...] = (15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0)
#: Defaults that come with a known arm description (example-robot-data path): home pose and
#: acceleration limits, which a URDF does not carry.
KNOWN_ARMS: dict[str, dict[str, tuple[float, ...]]] = {
    "panda_description/urdf/panda.urdf": {"home": PANDA_HOME, "acceleration_limits": PANDA_ACCELERATION_LIMITS},
}
N_BASE = 3
#: Half extents (m) of the base's body in its own x and y axes: a box of 0.6 m x 0.5 m from the
#: floor up to the arm's mount (a MOCA-like platform), the base's collision geometry in the
#: planner, the exact clearance check and the MuJoCo model alike.
BASE_BOX_HALF_XY: tuple[float, float] = (0.3, 0.25)
#: The base box's height when the mount is lower than this (m).
BASE_BOX_MIN_HEIGHT = 0.05


def has_base_box(robot: Any) -> bool:
    """Whether the robot has forte's base box under the arm's mount: every mobile base, and a fixed
    base whose arm is mounted above it; not an arm mounted at its base frame's origin with the
    base fixed (a bare arm, e.g. a MoveIt scene's Panda, whose root link is its base)."""
    return not (robot.base == "fixed" and float(robot.mount[2, 3]) <= 1e-3)
#: Radius (m) of the payload's shape: a sphere centred at the end-effector frame, the body
#: MuJoCo's hand holds and the part the planner's cover and the clearance check carry.
PAYLOAD_RADIUS = 0.05
STANDARD_GRAVITY = 9.81
#: Mass (kg) and principal inertia about its origin (kg m^2) of the base body: a MOCA-like
#: omnidirectional platform; MuJoCo's base body and the exported URDF's ``mobile_base`` link.
BASE_MASS = 60.0
BASE_INERTIA: tuple[float, float, float] = (2.5, 2.5, 3.0)
#: Prefix of the mesh URIs of example-robot-data's descriptions (``package://`` resolves it
#: against :func:`mesh_package_dirs`).
ERD_PACKAGE_PREFIX = "package://example-robot-data/robots/"


def example_robot_data_dir() -> Path:
    """Folder of the robot descriptions shipped by the ``example-robot-data`` PyPI package."""
    try:
        dist = metadata.distribution("example-robot-data")
    except metadata.PackageNotFoundError as exc:  # pragma: no cover - dependency of forte
        raise RobotModelError("the 'example-robot-data' package is not installed") from exc
    root = Path(str(dist.locate_file("cmeel.prefix/share/example-robot-data/robots")))
    if not root.is_dir():  # pragma: no cover
        raise RobotModelError(f"example-robot-data found, but {root} does not exist")
    return root


def mesh_package_dirs() -> list[str]:
    """Folders that ``package://example-robot-data/...`` URIs resolve against (Pinocchio's
    ``package_dirs``): the ``share`` folder of the installed example-robot-data."""
    return [str(example_robot_data_dir().parents[1])]


def urdf_reference(path: Path) -> str:
    """How a description names its URDF: ``erd:<path inside example-robot-data>`` for one of that
    package's (valid wherever it is installed), else the path itself."""
    try:
        return "erd:" + path.resolve().relative_to(example_robot_data_dir().resolve()).as_posix()
    except ValueError:
        return str(path)


def resolve_urdf(urdf: str | Path) -> Path:
    """Resolve ``urdf``: a path, or ``erd:<relative path>`` inside example-robot-data."""
    text = str(urdf)
    path = example_robot_data_dir() / text[4:] if text.startswith("erd:") else Path(text)
    if not path.is_file():
        raise RobotModelError(f"urdf: file {path} does not exist")
    return path


@dataclass(frozen=True)
class ToolLoad:
    """A rigid load fixed to the end-effector frame and modelled as part of the arm.

    Attributes:
        mass: Mass in kg (> 0).
        com: Centre of mass in the end-effector frame (m).
        inertia: 3x3 rotational inertia about the centre of mass, end-effector axes (kg m^2).
    """

    mass: float
    com: tuple[float, float, float] = (0.0, 0.0, 0.0)
    inertia: tuple[tuple[float, float, float], ...] = ((0.0,) * 3,) * 3

    def __post_init__(self) -> None:
        as_positive(self.mass, "tool.mass")
        as_vector(self.com, "tool.com", 3)
        inertia = as_array(self.inertia, "tool.inertia", (3, 3))
        if not np.allclose(inertia, inertia.T) or np.linalg.eigvalsh(inertia).min() < -1e-12:
            raise InvalidInputError("tool.inertia: expected a symmetric positive semi-definite 3x3")

    def to_dict(self) -> dict[str, Any]:
        return {
            "mass": float(self.mass),
            "com": [float(c) for c in self.com],
            "inertia": [[float(v) for v in row] for row in self.inertia],
        }


def _box_inertia(mass: float, sx: float, sy: float, sz: float) -> tuple[tuple[float, ...], ...]:
    k = mass / 12.0
    return ((k * (sy**2 + sz**2), 0.0, 0.0), (0.0, k * (sx**2 + sz**2), 0.0),
            (0.0, 0.0, k * (sx**2 + sy**2)))


#: Basket, RealSense D435i camera and brackets of the MOCA set-up (an estimate: a 0.8 kg
#: box of 0.20 x 0.15 x 0.10 m centred 2 cm behind the tool centre point).
MOCA_TOOL = ToolLoad(mass=0.8, com=(0.0, 0.0, -0.02), inertia=_box_inertia(0.8, 0.20, 0.15, 0.10))
#: Arm base 0.45 m above the floor and 0.2 m ahead of the base centre (MOCA-like).
MOCA_MOUNT: tuple[tuple[float, ...], ...] = (
    (1.0, 0.0, 0.0, 0.2), (0.0, 1.0, 0.0, 0.0), (0.0, 0.0, 1.0, 0.45), (0.0, 0.0, 0.0, 1.0))


#: The authors' mount (``my_robot_fix_wheels.urdf``): Panda base 0.2575 m ahead, 0.52 m up.
AUTHORS_MOUNT: tuple[tuple[float, ...], ...] = (
    (1.0, 0.0, 0.0, 0.2575), (0.0, 1.0, 0.0, 0.0), (0.0, 0.0, 1.0, 0.52), (0.0, 0.0, 0.0, 1.0))
#: The authors' end effector ``moca_franka_EE`` relative to ``panda_hand`` (= flange, -45 deg about z).
AUTHORS_EE_OFFSET: tuple[tuple[float, ...], ...] = (
    (1.0, 0.0, 0.0, 0.0), (0.0, 1.0, 0.0, 0.0), (0.0, 0.0, 1.0, 0.10), (0.0, 0.0, 0.0, 1.0))
#: Mass of the Franka hand in the authors' description (kg); example-robot-data's is 0.73 kg.
AUTHORS_HAND_MASS = 0.54
#: The end-effector load the authors add to the required force (kg, ``payload_mass.json``).
AUTHORS_TOOL_FORCE_MASS = 1.146
#: The authors' taught home configuration of the arm (their public code, the lift task).
AUTHORS_HOME: tuple[float, ...] = (0.131, -0.104, -0.130, -1.864, 0.058, 1.779, 0.804)
#: Name of the end-effector frame forte adds when ``ee_offset`` is given.
EE_FRAME_NAME = "forte_ee"


def _link_inertial(urdf: Path, link: str) -> tuple[float, FloatArray, FloatArray] | None:
    """``(mass, com, inertia)`` of a URDF link's ``<inertial>`` in the link frame (``None`` if absent)."""
    import xml.etree.ElementTree as ET

    for node in ET.parse(urdf).getroot().iter("link"):
        if node.get("name") != link:
            continue
        inertial = node.find("inertial")
        if inertial is None:
            return None
        origin = inertial.find("origin")
        com = np.array([float(v) for v in (origin.get("xyz", "0 0 0") if origin is not None else "0 0 0").split()])
        rpy = [float(v) for v in (origin.get("rpy", "0 0 0") if origin is not None else "0 0 0").split()]
        mass = float(inertial.find("mass").get("value"))
        i = {k: float(v) for k, v in inertial.find("inertia").attrib.items()}
        inertia = np.array([[i["ixx"], i["ixy"], i["ixz"]], [i["ixy"], i["iyy"], i["iyz"]],
                            [i["ixz"], i["iyz"], i["izz"]]])
        R = pin.rpy.rpyToMatrix(*rpy)
        return mass, com, R @ inertia @ R.T
    return None


def set_urdf_link_mass(root: Any, link: str, mass: float) -> bool:
    """Give ``link``'s inertial in a parsed URDF (``xml.etree`` root) the mass ``mass``, its
    inertia scaled alike (as the planner's model does); False when the link has no inertial."""
    for node in root.iter("link"):
        inertial = node.find("inertial") if node.get("name") == link else None
        if inertial is None or inertial.find("mass") is None or inertial.find("inertia") is None:
            continue
        mass_node, inertia = inertial.find("mass"), inertial.find("inertia")
        scale = mass / float(mass_node.get("value"))
        mass_node.set("value", repr(float(mass)))
        for key, value in list(inertia.attrib.items()):
            inertia.set(key, repr(float(value) * scale))
        return True
    return False


def torque_limit_set(name: str) -> tuple[float, ...] | None:
    """The limits of the named set of :data:`TORQUE_LIMIT_SETS` (``None``: the URDF's efforts)."""
    if name not in TORQUE_LIMIT_SETS:
        raise InvalidInputError(f"torque-limit set: expected one of {', '.join(TORQUE_LIMIT_SETS)}, got {name!r}")
    return TORQUE_LIMIT_SETS[name]
