"""The arm's URDF as a MuJoCo ``MjSpec``, reduced to the joints the planner controls.

* joints that Pinocchio locks (the Panda's fingers) are deleted: their bodies become rigidly
  fixed at the locked value (the robot's ``locked_joints``, else the neutral configuration clipped
  to the joint range); every
  equality constraint (a URDF ``mimic``, e.g. between the fingers) is deleted;
* the arm joints keep their range limits, lose damping and friction loss (Pinocchio's ``rnea``
  models neither) and get the reflected rotor inertia as ``armature``;
* ``package://example-robot-data/...`` mesh URIs point to the installed share folder; every
  geometry is kept massless with contacts off (:func:`forte.execution.contact.enable_robot_contacts`
  switches them on), and without ``meshes`` every geometry is dropped.

Bodies and joints keep their URDF names; :func:`forte.execution.model.build_sim_model` attaches
the arm under the prefix :data:`ARM_PREFIX`.
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np

from forte.exceptions import SimulationError
from forte.model.description import set_urdf_link_mass
from forte.model.robot import MobileManipulator, example_robot_data_dir
from forte.validation import FloatArray

#: Name prefix of the arm's bodies and joints in the MuJoCo model (``arm/panda_joint1``, ...).
ARM_PREFIX = "arm/"


def _urdf_text(robot: MobileManipulator, meshes: bool) -> str:
    text = robot.urdf_path.read_text()
    # Mesh URIs: package://example-robot-data/robots/... -> the real share folder.
    text = text.replace("package://example-robot-data/robots/", str(example_robot_data_dir()) + "/")
    if "package://" in text and meshes:
        raise SimulationError(
            f"urdf: {robot.urdf_path} refers to package:// meshes outside example-robot-data; MuJoCo "
            "cannot load them for rendering or for contact with a scene (simulate without either)"
        )
    if robot.hand_mass is not None:
        text = _with_link_mass(text, robot.hand_link, robot.hand_mass)
    return _valid_inertias(text)


def _valid_inertias(text: str) -> str:
    """The URDF with every inertia MuJoCo would reject (not positive definite, or breaking the
    triangle inequality) replaced by the isotropic one of the same largest magnitude. Such links
    carry micrograms in the example-robot-data descriptions (TIAGo's antennas: 1 mg); MuJoCo
    refuses to compile them, Pinocchio takes them as they are."""
    import xml.etree.ElementTree as ET

    if "<inertia" not in text:
        return text
    root = ET.fromstring(text)
    changed = False
    for inertia in root.iterfind(".//inertial/inertia"):
        keys = ("ixx", "iyy", "izz", "ixy", "ixz", "iyz")
        v = {k: float(inertia.get(k, "0")) for k in keys}
        matrix = np.array([[v["ixx"], v["ixy"], v["ixz"]], [v["ixy"], v["iyy"], v["iyz"]],
                           [v["ixz"], v["iyz"], v["izz"]]])
        eig = np.linalg.eigvalsh(matrix)
        if eig.min() > 0 and 2 * eig.max() <= eig.sum() * (1 + 1e-9):
            continue
        value = max(float(np.abs(eig).max()), 1e-12)
        for k in keys:
            inertia.set(k, repr(value if k in ("ixx", "iyy", "izz") else 0.0))
        changed = True
    return ET.tostring(root, encoding="unicode") if changed else text


#: Mesh formats MuJoCo reads (a URDF with others, e.g. Collada ``.dae``, is simulated without
#: its geometry: no rendering, no contact).
MUJOCO_MESH_FORMATS = (".stl", ".obj", ".msh")


def geometry_loadable(robot: MobileManipulator) -> bool:
    """Whether MuJoCo can load the URDF's geometry: no ``package://`` URI outside
    example-robot-data and every collision mesh in a format MuJoCo reads
    (:data:`MUJOCO_MESH_FORMATS`; MuJoCo's URDF import discards the visual ones)."""
    import xml.etree.ElementTree as ET

    text = _urdf_text(robot, False)
    meshes = [m.get("filename", "") for m in ET.fromstring(text).iterfind(".//collision/geometry/mesh")]
    return "package://" not in text and all(m.lower().endswith(MUJOCO_MESH_FORMATS) for m in meshes)


def _with_link_mass(text: str, link: str, mass: float) -> str:
    """The URDF with ``link``'s mass set to ``mass`` and its inertia scaled alike (as the planner's model)."""
    import xml.etree.ElementTree as ET

    root = ET.fromstring(text)
    set_urdf_link_mass(root, link, mass)
    return ET.tostring(root, encoding="unicode")


def load_arm_spec(robot: MobileManipulator, meshes: bool, rotor: FloatArray) -> mujoco.MjSpec:
    """The arm's URDF as an ``MjSpec`` with ``robot``'s joints only (see the module docstring).

    Args:
        robot: The robot whose URDF and arm joints are used.
        meshes: Keep the URDF geometry (massless, contacts off) instead of dropping it: for
            rendering, or for contact with the scene.
        rotor: Reflected rotor inertia of each arm joint (kg m^2), set as the joint armature.

    Raises:
        SimulationError: MuJoCo cannot parse the URDF, or a joint to lock is not 1-DoF.
    """
    try:
        arm = mujoco.MjSpec.from_string(_urdf_text(robot, meshes))
    except Exception as exc:  # MuJoCo raises plain ValueError on parse/compile problems
        raise SimulationError(f"urdf: MuJoCo cannot load {robot.urdf_path}: {exc}") from exc
    _prepare_arm(arm, robot, meshes, rotor)
    return arm


def _prepare_arm(arm: mujoco.MjSpec, robot: MobileManipulator, meshes: bool, armature: FloatArray) -> None:
    """Lock non-arm joints, zero damping/friction, set the armature, disable contacts, drop meshes."""
    rotor = dict(zip(robot.arm_joints or (), armature, strict=True))
    for eq in list(arm.equalities):  # URDF mimic joints become equality constraints
        arm.delete(eq)
    for joint in list(arm.joints):
        if joint.name in rotor:
            joint.damping = np.zeros(3)  # MuJoCo 4: damping polynomial coefficients
            joint.armature = float(rotor[joint.name])
            joint.frictionloss = 0.0
            continue
        given = robot.locked_joints.get(joint.name)  # already clipped to the URDF's range
        _fix_body_at(joint, _locked_value(joint) if given is None else given)
        arm.delete(joint)
    for geom in list(arm.geoms):
        if not meshes:
            arm.delete(geom)
            continue
        geom.contype = 0
        geom.conaffinity = 0
        geom.mass = 0.0
        geom.density = 0.0
    if not meshes:  # their files too: MuJoCo decodes every mesh asset when it compiles (not .dae)
        for mesh in list(arm.meshes):
            arm.delete(mesh)


def _fix_body_at(joint: Any, value: float) -> None:
    """Move the body of a 1-DoF ``joint`` to where the joint at ``value`` would put it."""
    if value == 0.0:
        return
    body = joint.parent
    axis = np.asarray(joint.axis, dtype=float)
    axis = axis / np.linalg.norm(axis)
    if joint.type == mujoco.mjtJoint.mjJNT_SLIDE:
        body.pos = (np.asarray(body.pos) + _quat_rotate(body.quat, axis) * value).tolist()
    elif joint.type == mujoco.mjtJoint.mjJNT_HINGE:
        dq = np.zeros(4)
        mujoco.mju_axisAngle2Quat(dq, axis, value)
        out = np.zeros(4)
        mujoco.mju_mulQuat(out, np.asarray(body.quat, dtype=float), dq)
        body.quat = out.tolist()
    else:
        raise SimulationError(f"urdf: cannot lock joint '{joint.name}' (not 1-DoF)")


def _quat_rotate(quat: Any, v: FloatArray) -> FloatArray:
    out = np.zeros(3)
    mujoco.mju_rotVecQuat(out, v, np.asarray(quat, dtype=float))
    return out


def _locked_value(joint: Any) -> float:
    """The value Pinocchio's reduced model locks a joint at: neutral (0) clipped to its range."""
    lo, hi = (float(v) for v in joint.range)
    limited = joint.limited == mujoco.mjtLimited.mjLIMITED_TRUE or (
        joint.limited == mujoco.mjtLimited.mjLIMITED_AUTO and lo < hi
    )
    return float(np.clip(0.0, lo, hi)) if limited and lo < hi else 0.0
