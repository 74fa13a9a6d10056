"""Loading a URDF into Pinocchio the way forte plans with it: continuous joints become revolute.

Pinocchio models a continuous joint by ``(cos q, sin q)`` (two coordinates, one velocity); forte's
planner, its CasADi twin and its NLP take one coordinate per joint. A continuous joint is therefore
loaded as a revolute joint limited to +-:data:`CONTINUOUS_RANGE` (two turns each way, more than a
trajectory of seconds uses; the URDF's effort and velocity limits kept). Everything that builds a
Pinocchio model or geometry from a robot's URDF goes through here, so the planner, the
self-collision check and the clearance check agree; MuJoCo reads the URDF itself and keeps the
joint unlimited.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from forte.exceptions import RobotModelError
from forte.model.description import _link_inertial
from forte.validation import FloatArray, did_you_mean

#: The range (rad) a continuous joint is planned within, each way.
CONTINUOUS_RANGE = 2 * np.pi
#: Effort (Nm) and velocity (rad/s) given to a continuous joint whose URDF has no <limit>.
UNLIMITED_EFFORT, UNLIMITED_VELOCITY = 1e3, 10.0


@lru_cache(maxsize=16)
def _text(path: str, mtime: float) -> str:
    text = Path(path).read_text(encoding="utf-8")
    if 'type="continuous"' not in text and "type='continuous'" not in text:
        return text
    root = ET.fromstring(text)
    for joint in root.iter("joint"):
        if joint.get("type") != "continuous":
            continue
        joint.set("type", "revolute")
        limit = joint.find("limit")
        if limit is None:
            limit = ET.SubElement(joint, "limit", {"effort": f"{UNLIMITED_EFFORT:g}",
                                                   "velocity": f"{UNLIMITED_VELOCITY:g}"})
        limit.set("lower", repr(-CONTINUOUS_RANGE))
        limit.set("upper", repr(CONTINUOUS_RANGE))
    return ET.tostring(root, encoding="unicode")


def planning_urdf_text(path: Path) -> str:
    """The URDF's text with every continuous joint revolute within +-:data:`CONTINUOUS_RANGE`."""
    path = Path(path)
    return _text(str(path.resolve()), path.stat().st_mtime)


def load_model(path: Path) -> pin.Model:
    """The Pinocchio model of the URDF at ``path`` (continuous joints as revolute)."""
    return pin.buildModelFromXML(planning_urdf_text(path))


def load_geometry(model: pin.Model, path: Path, kind: Any, package_dirs: list[str]) -> pin.GeometryModel:
    """The URDF's geometry of ``kind`` (``pin.COLLISION`` or ``pin.VISUAL``) for ``model``."""
    return pin.buildGeomFromUrdfString(model, planning_urdf_text(path), kind, package_dirs=package_dirs)


def set_link_mass(full: pin.Model, urdf: Path, link: str, mass: float) -> None:
    """Replace the URDF inertia of ``link`` (merged into its joint) by one of ``mass`` (same centre
    of mass, inertia scaled), in place: the authors' hand mass."""
    found = _link_inertial(urdf, link)
    if found is None or not full.existFrame(link):
        raise RobotModelError(f"hand_mass: no link '{link}' with an inertial in {urdf.name}")
    old_mass, com, inertia = found
    frame = full.frames[full.getFrameId(link)]
    old = frame.placement.act(pin.Inertia(old_mass, com, inertia))
    new = frame.placement.act(pin.Inertia(mass, com, inertia * (mass / old_mass)))
    full.inertias[frame.parentJoint] = full.inertias[frame.parentJoint] - old + new


def check_locked(full: pin.Model, urdf_name: str, joints: tuple[str, ...], locked: Any) -> dict[str, float]:
    """``robot.locked_joints`` (``{name: value}``) checked against ``full``: each a 1-DoF joint of the
    URDF that is not planned, its value a finite number. A value beyond the joint's range is kept:
    a locked joint is geometry, not motion (MotionBenchMaker's Panda problems hold the fingers at
    0.065 m, beyond the URDF's 0.04 m, and their goals are collision-free only with them there);
    :func:`beyond_range` names such values."""
    if locked is None:
        return {}
    if not isinstance(locked, dict):
        raise RobotModelError(f"locked_joints: expected a mapping of joint name to value, got {locked!r}")
    out: dict[str, float] = {}
    for name, value in locked.items():
        if not full.existJointName(str(name)):
            raise RobotModelError(f"locked_joints: no joint '{name}' in {urdf_name}"
                                  f"{did_you_mean(name, full.names[1:])}")
        jid = full.getJointId(str(name))
        if name in joints:
            raise RobotModelError(f"locked_joints: '{name}' is a planned arm joint; lock only the others")
        if full.joints[jid].nq != 1:
            raise RobotModelError(f"locked_joints: joint '{name}' is not a 1-DoF joint")
        if isinstance(value, bool) or not isinstance(value, int | float) or not np.isfinite(value):
            raise RobotModelError(f"locked_joints: {name}: expected a finite number, got {value!r}")
        out[str(name)] = float(value)
    return out


def beyond_range(full: pin.Model, locked: dict[str, float]) -> list[str]:
    """``"name: value beyond [lower, upper]"`` for each locked value outside its joint's range."""
    out = []
    for name, value in locked.items():
        i = full.idx_qs[full.getJointId(name)]
        lo, hi = full.lowerPositionLimit[i], full.upperPositionLimit[i]
        if not lo <= value <= hi:
            out.append(f"{name}: {value:g} beyond the URDF's range [{lo:g}, {hi:g}]")
    return out


def locked_configuration(full: pin.Model, locked: dict[str, float] | None = None) -> FloatArray:
    """The full model's configuration the unplanned joints are locked at: ``locked``'s values,
    every other joint at neutral clipped to its limits (the arm joints' entries are unused)."""
    q = np.clip(pin.neutral(full), full.lowerPositionLimit, full.upperPositionLimit)
    for name, value in (locked or {}).items():
        q[full.idx_qs[full.getJointId(name)]] = value
    return q


def reduce_to_arm(full: pin.Model, joints: tuple[str, ...], mount: FloatArray, ee_frame: str,
                  ee_offset: FloatArray | None, tool: Any, locked: dict[str, float] | None = None) -> pin.Model:
    """``full`` with every joint but ``joints`` locked (at ``locked``'s values, else at neutral,
    clipped to the limits: :func:`locked_configuration`), the arm moved to ``mount`` on the base,
    and the ``tool`` load (if any) at the end effector."""
    keep = {full.getJointId(j) for j in joints}
    lock = [j for j in range(1, full.njoints) if j not in keep]
    q_ref = locked_configuration(full, locked)
    model = pin.buildReducedModel(full, lock, q_ref) if lock else full.copy()
    order = [model.names[j] for j in range(1, model.njoints)]
    if tuple(order) != joints:
        raise RobotModelError(f"arm_joints: expected the joints in kinematic order {tuple(order)}, got {joints}")
    placement = pin.SE3(mount[:3, :3].copy(), mount[:3, 3].copy())
    for j in range(1, model.njoints):
        if model.parents[j] == 0:
            model.jointPlacements[j] = placement * model.jointPlacements[j]
    for frame in model.frames:
        if frame.parentJoint == 0:
            frame.placement = placement * frame.placement
    if tool is not None:
        # The tool sits at the end effector: ``ee_frame`` composed with ``ee_offset`` when given
        # (the frame ``forte_ee`` is added after the reduction), as in the MuJoCo model.
        frame = model.frames[model.getFrameId(ee_frame)]
        inertia = pin.Inertia(float(tool.mass), np.zeros(3), np.array(tool.inertia, dtype=float))
        ee = frame.placement
        if ee_offset is not None:
            ee = ee * pin.SE3(ee_offset[:3, :3].copy(), ee_offset[:3, 3].copy())
        model.appendBodyToJoint(frame.parentJoint, inertia, ee * pin.SE3(np.eye(3), np.array(tool.com, dtype=float)))
    return model
