"""Exports of a plan and of the robot model, one owner per format.

Plans (:func:`export_plan`, format from the file suffix):

- ``.npz``: ``t``, ``q``, ``qd``, ``qdd`` (N x nq), ``joint_names``, the units of each, the task
  force (``force_t``, ``force_f``, ``force_r``), every column of ``metrics.csv`` as
  ``metric_<name>`` and the plan's ``method`` / ``status``;
- ``.csv``: one row per waypoint, columns ``t``, ``<joint>``, ``<joint>.velocity``,
  ``<joint>.acceleration``; comment lines (``#``) above the header give the plan and the unit of
  every column;
- ``.mcap``: ROS 2 topics (CDR, ``ros2msg`` schemas), written with ``mcap-ros2-support``; ``ros2 bag``
  (rosbag2's MCAP storage) and Foxglove read it: the ``trajectory_msgs/JointTrajectory``, the
  robot description (``package://`` meshes, as ``forte robot export`` writes it), ``/tf_static`` and
  ``/tf``, ``/joint_states``, the force and RFP markers and the scene's bodies, each topic with the
  QoS ``ros2 bag play`` offers it with (:mod:`forte.io.mcap_export`).

Velocities and accelerations are the plan's own: the backward differences from rest the planner
optimizes (:func:`forte.model.trajectory.backward_differences`), ``v_k = (q_k - q_{k-1}) / dt``,
``a_k = (v_k - v_{k-1}) / dt``, ``v_1 = a_1 = 0``.

Joints are named as in the whole-body model (:func:`whole_body_urdf`): ``base_x``, ``base_y``
(prismatic, m), ``base_yaw`` (revolute, rad) and the arm joints of the URDF.

The robot: :func:`whole_body_urdf` is the arm's URDF mounted on the three base joints (the MJCF of
the simulation model is :func:`forte.execution.model.whole_body_mjcf`; ``forte robot export``
writes either).
"""

from __future__ import annotations

import copy
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from forte.exceptions import InvalidInputError, OutputError, RobotModelError
from forte.io.plandir import read_metrics, read_plan_dir
from forte.model.description import BASE_INERTIA, BASE_MASS, ERD_PACKAGE_PREFIX, set_urdf_link_mass
from forte.model.robot import EE_FRAME_NAME, MobileManipulator, example_robot_data_dir
from forte.model.scene import Scene
from forte.model.trajectory import backward_differences
from forte.validation import FloatArray

#: Names of the base joints (the same in the URDF, the MJCF and every export).
BASE_JOINTS = ("base_x", "base_y", "base_yaw")
PLAN_FORMATS = (".npz", ".csv", ".mcap")
#: Links the whole-body URDF adds below the arm's root.
BASE_LINKS = ("mobile_world", "mobile_base_x", "mobile_base_y", "mobile_base")
#: Bound of the base joints in the URDF (a planar base is unbounded; URDF needs numbers).
BASE_RANGE = 1000.0

@dataclass
class ExportedPlan:
    """What every plan export holds (arrays N x nq, times N)."""

    method: str
    status: str
    t: FloatArray
    q: FloatArray
    qd: FloatArray
    qdd: FloatArray
    joint_names: tuple[str, ...]
    units: tuple[str, ...]  # position unit per joint: m or rad
    force: dict[str, FloatArray] = field(default_factory=dict)  # t, f, r
    metrics: dict[str, FloatArray] = field(default_factory=dict)
    robot: MobileManipulator | None = None  # the plan's robot (the MCAP's description and transforms)
    scene: Scene = field(default_factory=Scene)  # the bodies the plan avoided (the MCAP's scene markers)

    @property
    def velocity_units(self) -> tuple[str, ...]:
        return tuple(f"{u}/s" for u in self.units)

    @property
    def acceleration_units(self) -> tuple[str, ...]:
        return tuple(f"{u}/s^2" for u in self.units)


def joint_names(robot: MobileManipulator) -> tuple[str, ...]:
    """Whole-body joint names: :data:`BASE_JOINTS` and the arm joints."""
    return (*BASE_JOINTS, *(robot.arm_joints or ()))


def joint_units(robot: MobileManipulator) -> tuple[str, ...]:
    """Position unit of each whole-body joint (``m`` for prismatic, ``rad`` for revolute)."""
    arm = []
    for j in range(1, robot.model.njoints):
        kind = robot.model.joints[j].shortname()
        arm.append("m" if "JointModelP" in kind else "rad")
    return ("m", "m", "rad", *arm)


def plan_data(plan_dir: str | Path) -> ExportedPlan:
    """Read a plan directory and add the plan's velocities and accelerations."""
    plan = read_plan_dir(plan_dir)
    qd, qdd = backward_differences(plan.q, plan.t, "q")
    force = {} if plan.force is None else {"t": plan.force.t, "f": plan.force.f, "r": plan.force.r}
    return ExportedPlan(method=plan.method, status=plan.status, t=plan.t, q=plan.q, qd=qd, qdd=qdd,
                        joint_names=joint_names(plan.robot), units=joint_units(plan.robot), force=force,
                        metrics=read_metrics(plan_dir), robot=plan.robot, scene=plan.scene)


def export_plan(plan_dir: str | Path, path: str | Path) -> Path:
    """Write the plan in ``plan_dir`` to ``path``; the format is the suffix (:data:`PLAN_FORMATS`)."""
    path = Path(path)
    writers = {".npz": write_npz, ".csv": write_csv_export, ".mcap": _write_mcap}
    suffix = path.suffix.lower()
    if suffix not in writers:
        raise InvalidInputError(f"{path}: unknown export format {path.suffix or '(no suffix)'}; expected one of "
                                f"{', '.join(PLAN_FORMATS)}")
    _check_target(path)
    data = plan_data(plan_dir)
    writers[suffix](data, path)
    return path


def _check_target(path: Path) -> None:
    if path.is_dir():
        raise OutputError(f"{path}: is a directory; expected a file name")
    if not path.parent.is_dir():
        raise OutputError(f"{path}: folder {path.parent} does not exist")


def _write_mcap(data: ExportedPlan, path: Path) -> None:
    from forte.io.mcap_export import write_mcap

    write_mcap(data, path)


def write_npz(data: ExportedPlan, path: Path) -> None:
    """The ``.npz`` export (see the module docstring)."""
    arrays: dict[str, Any] = {
        "t": data.t, "q": data.q, "qd": data.qd, "qdd": data.qdd,
        "joint_names": np.array(data.joint_names), "position_units": np.array(data.units),
        "velocity_units": np.array(data.velocity_units), "acceleration_units": np.array(data.acceleration_units),
        "time_unit": np.array("s"), "method": np.array(data.method), "status": np.array(data.status),
    }
    if data.force:
        arrays |= {"force_t": data.force["t"], "force_f": data.force["f"], "force_r": data.force["r"],
                   "force_unit": np.array("N")}
    arrays |= {f"metric_{name}": values for name, values in data.metrics.items()}
    with open(path, "wb") as fh:  # np.savez would append .npz to any other name
        np.savez(fh, **arrays)


def csv_columns(data: ExportedPlan) -> tuple[list[str], list[str]]:
    """Column names and units of the ``.csv`` export."""
    names = ["t", *data.joint_names, *(f"{j}.velocity" for j in data.joint_names),
             *(f"{j}.acceleration" for j in data.joint_names)]
    units = ["s", *data.units, *data.velocity_units, *data.acceleration_units]
    return names, units


def write_csv_export(data: ExportedPlan, path: Path) -> None:
    """The ``.csv`` export: ``#`` comment lines (plan, units), a header and one row per waypoint."""
    names, units = csv_columns(data)
    rows = np.column_stack([data.t, data.q, data.qd, data.qdd])
    lines = [f"# forte plan export: method {data.method}, status {data.status}; velocities and accelerations "
             "are backward differences from rest",
             "# units: " + ",".join(units), ",".join(names)]
    lines += [",".join(repr(float(v)) for v in row) for row in rows]
    path.write_text("\n".join(lines) + "\n")


# -- the robot ------------------------------------------------------------------------------------
def _origin(parent: ET.Element, T: FloatArray) -> None:
    rpy = pin.rpy.matrixToRpy(T[:3, :3])
    ET.SubElement(parent, "origin", xyz=" ".join(repr(float(v)) for v in T[:3, 3]),
                  rpy=" ".join(repr(float(v)) for v in rpy))


def _origin_matrix(joint: ET.Element) -> FloatArray:
    T = np.eye(4)
    o = joint.find("origin")
    if o is not None:
        T[:3, 3] = [float(v) for v in o.get("xyz", "0 0 0").split()]
        T[:3, :3] = pin.rpy.rpyToMatrix(*[float(v) for v in o.get("rpy", "0 0 0").split()])
    return T


def _lock(joint: ET.Element) -> None:
    """Turn a joint the planner locks into a fixed joint at its locked value (neutral, clipped)."""
    kind = joint.get("type")
    limit = joint.find("limit")
    value = 0.0
    if limit is not None and kind in ("revolute", "prismatic"):
        lo, hi = float(limit.get("lower", 0)), float(limit.get("upper", 0))
        value = float(np.clip(0.0, lo, hi)) if lo < hi else 0.0
    if kind in ("revolute", "continuous", "prismatic") and value != 0.0:
        axis_el = joint.find("axis")
        axis = np.array([float(v) for v in (axis_el.get("xyz") if axis_el is not None else "1 0 0").split()])
        axis /= np.linalg.norm(axis)
        M = np.eye(4)
        if kind == "prismatic":
            M[:3, 3] = axis * value
        else:
            M[:3, :3] = pin.exp3(axis * value)
        T = _origin_matrix(joint) @ M
        for old in joint.findall("origin"):
            joint.remove(old)
        _origin(joint, T)
    joint.set("type", "fixed")
    for tag in ("axis", "limit", "mimic", "dynamics", "safety_controller", "calibration"):
        for child in joint.findall(tag):
            joint.remove(child)


def _fixed_link(name: str, parent: str, T: FloatArray | None = None) -> tuple[ET.Element, ET.Element]:
    """A link ``name`` (no inertial) and the fixed joint ``<name>_joint`` from ``parent`` at ``T``."""
    link = ET.Element("link", name=name)
    joint = ET.Element("joint", name=f"{name}_joint", type="fixed")
    ET.SubElement(joint, "parent", link=parent)
    ET.SubElement(joint, "child", link=name)
    if T is not None:
        _origin(joint, T)
    return link, joint


def portable_urdf(robot: MobileManipulator) -> str:
    """:func:`whole_body_urdf` for a file that leaves this machine (``forte robot export``, the MCAP's
    ``/robot_description``): example-robot-data's meshes stay ``package://`` URIs."""
    return whole_body_urdf(robot, mesh_uris="package")


def whole_body_urdf(robot: MobileManipulator, mesh_uris: str = "file") -> str:
    """The robot as one URDF: the base joints and the arm mounted on them.

    ``mobile_world -[base_x, prismatic]-> mobile_base_x -[base_y, prismatic]-> mobile_base_y
    -[base_yaw, revolute]-> mobile_base -[arm_mount, fixed: the mount]-> the arm's root link``;
    the base joints are bounded at +-:data:`BASE_RANGE` (m, rad). Arm joints that the planner
    locks become fixed joints at their locked value; ``robot.hand_mass`` replaces the mass of
    ``robot.hand_link`` (inertia scaled alike); with ``robot.ee_offset`` the end effector is a
    link ``forte_ee`` fixed to ``robot.ee_frame`` at that offset; the tool load is a link
    ``forte_tool`` fixed to the end-effector link; the base link ``mobile_base`` carries the
    simulator's base mass and inertia (:data:`~forte.model.description.BASE_MASS`, ``BASE_INERTIA``).
    ``mesh_uris="file"`` rewrites example-robot-data's ``package://`` mesh URIs to ``file://`` paths of
    the installed meshes (this machine only); ``"package"`` keeps them (``forte robot export``: the
    file travels; resolve ``package://example-robot-data`` against its ``share`` folder,
    :func:`forte.model.description.mesh_package_dirs`, or a ROS workspace that has the package).

    Raises:
        RobotModelError: the arm URDF cannot be parsed, or it already uses a name this adds.
    """
    try:
        tree = ET.parse(robot.urdf_path)
    except (ET.ParseError, OSError) as exc:
        raise RobotModelError(f"urdf: cannot parse {robot.urdf_path}: {exc}") from exc
    root = copy.deepcopy(tree.getroot())
    links = {e.get("name") for e in root.findall("link")}
    joints = root.findall("joint")
    clash = (set(BASE_LINKS) & links) | ({*BASE_JOINTS, "arm_mount"} & {j.get("name") for j in joints})
    if clash:
        raise RobotModelError(f"urdf: {robot.urdf_path.name} already has {sorted(clash)[0]!r}")
    children = {j.find("child").get("link") for j in joints if j.find("child") is not None}
    roots = sorted(links - children)
    if len(roots) != 1:
        raise RobotModelError(f"urdf: {robot.urdf_path.name}: expected one root link, got {roots}")
    for joint in joints:
        if joint.get("type") != "fixed" and joint.get("name") not in (robot.arm_joints or ()):
            _lock(joint)
    for el in root.iter():  # gazebo plug-ins and transmissions do not describe the model
        for child in [c for c in el if c.tag in ("gazebo", "transmission")]:
            el.remove(child)
    root.set("name", f"forte_{robot.name}")
    chain = [(BASE_JOINTS[0], "prismatic", "1 0 0"), (BASE_JOINTS[1], "prismatic", "0 1 0"),
             (BASE_JOINTS[2], "revolute", "0 0 1")]
    added: list[ET.Element] = [ET.Element("link", name=BASE_LINKS[0])]
    for i, (name, kind, axis) in enumerate(chain):
        link = ET.Element("link", name=BASE_LINKS[i + 1])
        if i == len(chain) - 1:  # the base body: the simulator's mass and inertia, about the base origin
            inertial = ET.SubElement(link, "inertial")
            ET.SubElement(inertial, "origin", xyz="0 0 0", rpy="0 0 0")
            ET.SubElement(inertial, "mass", value=repr(float(BASE_MASS)))
            ixx, iyy, izz = (repr(float(v)) for v in BASE_INERTIA)
            ET.SubElement(inertial, "inertia", ixx=ixx, iyy=iyy, izz=izz, ixy="0", ixz="0", iyz="0")
        joint = ET.Element("joint", name=name, type=kind)
        ET.SubElement(joint, "parent", link=BASE_LINKS[i])
        ET.SubElement(joint, "child", link=BASE_LINKS[i + 1])
        ET.SubElement(joint, "axis", xyz=axis)
        ET.SubElement(joint, "limit", lower=repr(-BASE_RANGE), upper=repr(BASE_RANGE), effort="1000",
                      velocity="10")
        added += [link, joint]
    mount = ET.Element("joint", name="arm_mount", type="fixed")
    ET.SubElement(mount, "parent", link=BASE_LINKS[-1])
    ET.SubElement(mount, "child", link=roots[0])
    _origin(mount, robot.mount)
    added.append(mount)
    if robot.hand_mass is not None and not set_urdf_link_mass(root, robot.hand_link, robot.hand_mass):
        raise RobotModelError(f"urdf: hand_mass: no link {robot.hand_link!r} with an inertial")
    ee_link = robot.ee_frame
    if robot.ee_offset is not None:
        if robot.ee_frame not in links or EE_FRAME_NAME in links:
            raise RobotModelError(f"urdf: ee_offset needs a link named {robot.ee_frame!r} and no {EE_FRAME_NAME!r}")
        ee_link = EE_FRAME_NAME
        added += _fixed_link(EE_FRAME_NAME, robot.ee_frame, robot.ee_offset)
    if robot.tool is not None:
        if robot.ee_frame not in links or "forte_tool" in links:
            raise RobotModelError(f"urdf: the tool load needs a link named {robot.ee_frame!r}")
        tool = ET.Element("link", name="forte_tool")
        inertial = ET.SubElement(tool, "inertial")
        ET.SubElement(inertial, "origin", xyz=" ".join(repr(float(v)) for v in robot.tool.com), rpy="0 0 0")
        ET.SubElement(inertial, "mass", value=repr(float(robot.tool.mass)))
        inertia = np.asarray(robot.tool.inertia, dtype=float)
        ET.SubElement(inertial, "inertia", ixx=repr(float(inertia[0, 0])), iyy=repr(float(inertia[1, 1])),
                      izz=repr(float(inertia[2, 2])), ixy=repr(float(inertia[0, 1])), ixz=repr(float(inertia[0, 2])),
                      iyz=repr(float(inertia[1, 2])))
        joint = ET.Element("joint", name="forte_tool_joint", type="fixed")
        ET.SubElement(joint, "parent", link=ee_link)  # the tool's centre of mass is in end-effector axes
        ET.SubElement(joint, "child", link="forte_tool")
        added += [tool, joint]
    for i, el in enumerate(added):
        root.insert(i, el)
    if mesh_uris == "file":
        for mesh in root.iter("mesh"):
            name = mesh.get("filename", "")
            if name.startswith(ERD_PACKAGE_PREFIX):
                mesh.set("filename", (example_robot_data_dir() / name[len(ERD_PACKAGE_PREFIX):]).resolve().as_uri())
    ET.indent(root)
    return '<?xml version="1.0"?>\n' + ET.tostring(root, encoding="unicode") + "\n"
