"""The robot as one URDF: the arm's URDF mounted on the three base joints (:func:`whole_body_urdf`).

Every export names the joints alike: ``base_x``, ``base_y`` (prismatic, m), ``base_yaw``
(revolute, rad) and the arm joints of the URDF. :mod:`forte.io.export` (``forte robot export``)
and :mod:`forte.io.mcap_export` (the MCAP's ``/robot_description``) write it; the viewer reads
its kinematics.
"""

from __future__ import annotations

import copy
import xml.etree.ElementTree as ET

import numpy as np
import pinocchio as pin

from forte.exceptions import RobotModelError
from forte.model.description import BASE_INERTIA, BASE_MASS, ERD_PACKAGE_PREFIX, set_urdf_link_mass
from forte.model.robot import EE_FRAME_NAME, MobileManipulator, example_robot_data_dir
from forte.validation import FloatArray

#: Names of the base joints (the same in the URDF, the MJCF and every export).
BASE_JOINTS = ("base_x", "base_y", "base_yaw")
#: Links the whole-body URDF adds below the arm's root.
BASE_LINKS = ("mobile_world", "mobile_base_x", "mobile_base_y", "mobile_base")
#: Bound of the base joints in the URDF (a planar base is unbounded; URDF needs numbers).
BASE_RANGE = 1000.0


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


def _lock(joint: ET.Element, given: float | None = None) -> None:
    """Turn a joint the planner locks into a fixed joint at its locked value (``given``: the
    robot's ``locked_joints``, already clipped; else neutral, clipped)."""
    kind = joint.get("type")
    limit = joint.find("limit")
    value = 0.0 if given is None else given
    if given is None and limit is not None and kind in ("revolute", "prismatic"):
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
    root, links, arm_root = _arm_tree(robot)
    added = [*_base_chain(), _mount(arm_root, robot.mount)]
    if robot.hand_mass is not None and not set_urdf_link_mass(root, robot.hand_link, robot.hand_mass):
        raise RobotModelError(f"urdf: hand_mass: no link {robot.hand_link!r} with an inertial")
    added += _end_effector(robot, links)
    for i, el in enumerate(added):
        root.insert(i, el)
    if mesh_uris == "file":
        _file_mesh_uris(root)
    ET.indent(root)
    return '<?xml version="1.0"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def _arm_tree(robot: MobileManipulator) -> tuple[ET.Element, set[str], str]:
    """A copy of the arm's URDF tree ready to mount, its link names and its one root link.

    Arm joints the planner locks become fixed joints (:func:`_lock`); gazebo plug-ins and
    transmissions go (they do not describe the model); the robot is named ``forte_<name>``.
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
            _lock(joint, robot.locked_joints.get(joint.get("name")))
    for el in root.iter():
        for child in [c for c in el if c.tag in ("gazebo", "transmission")]:
            el.remove(child)
    root.set("name", f"forte_{robot.name}")
    return root, links, roots[0]


def _base_chain() -> list[ET.Element]:
    """:data:`BASE_LINKS` joined by :data:`BASE_JOINTS` (x, y prismatic, yaw revolute, bounded at
    +-:data:`BASE_RANGE`); the last link carries the simulator's base mass and inertia."""
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
    return added


def _mount(arm_root: str, T: FloatArray) -> ET.Element:
    """The fixed joint ``arm_mount`` from the base link to the arm's root link at ``T``."""
    mount = ET.Element("joint", name="arm_mount", type="fixed")
    ET.SubElement(mount, "parent", link=BASE_LINKS[-1])
    ET.SubElement(mount, "child", link=arm_root)
    _origin(mount, T)
    return mount


def _end_effector(robot: MobileManipulator, links: set[str]) -> list[ET.Element]:
    """The link ``forte_ee`` at ``robot.ee_offset`` and the tool load ``forte_tool``, when the robot has them."""
    added: list[ET.Element] = []
    ee_link = robot.ee_frame
    if robot.ee_offset is not None:
        if robot.ee_frame not in links or EE_FRAME_NAME in links:
            raise RobotModelError(f"urdf: ee_offset needs a link named {robot.ee_frame!r} and no {EE_FRAME_NAME!r}")
        ee_link = EE_FRAME_NAME
        added += _fixed_link(EE_FRAME_NAME, robot.ee_frame, robot.ee_offset)
    if robot.tool is not None:
        if robot.ee_frame not in links or "forte_tool" in links:
            raise RobotModelError(f"urdf: the tool load needs a link named {robot.ee_frame!r}")
        added += _tool_link(robot, ee_link)
    return added


def _tool_link(robot: MobileManipulator, ee_link: str) -> list[ET.Element]:
    """The link ``forte_tool`` (the tool's mass, centre of mass and inertia) fixed to ``ee_link``."""
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
    return [tool, joint]


def _file_mesh_uris(root: ET.Element) -> None:
    """Rewrite example-robot-data's ``package://`` mesh URIs to ``file://`` paths of the installed meshes."""
    for mesh in root.iter("mesh"):
        name = mesh.get("filename", "")
        if name.startswith(ERD_PACKAGE_PREFIX):
            mesh.set("filename", (example_robot_data_dir() / name[len(ERD_PACKAGE_PREFIX):]).resolve().as_uri())
