"""The parts of the MuJoCo model's ``MjSpec`` (:func:`forte.execution.model.build_sim_spec`
puts them together; what each holds and why is in :mod:`forte.execution.model`).

* :func:`world_spec`: the options (time step, gravity, ``implicitfast``), a floor plane, a light;
* :func:`add_base`: a kinematic base: slide x, slide y and yaw hinge joints (:data:`BASE_JOINTS`),
  welded in effect for a ``base: fixed`` robot (:data:`FIXED_BASE_ARMATURE`);
* :func:`add_base_box`: the base box up to the mount;
* :func:`add_end_effector`: the ``ee`` site, the tool body and the welded payload body;
* :func:`add_actuators`: arm torque motors and the base's velocity actuators (gains :data:`BASE_KV`).
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np
import pinocchio as pin

from forte.execution.arm_spec import ARM_PREFIX
from forte.execution.bodies import _principal, _rot_to_quat, _solid_sphere
from forte.model.description import BASE_BOX_HALF_XY, BASE_BOX_MIN_HEIGHT, has_base_box
from forte.model.robot import MobileManipulator
from forte.validation import FloatArray

#: Velocity-actuator gains of the base joints: slides (N s/m) and yaw (N m s/rad). With the base
#: mass (``forte.model.description.BASE_MASS``), the velocity loop has a time constant of ~ m / kv = 30 ms.
BASE_KV = (2000.0, 2000.0, 400.0)
#: Reflected inertia (kg, kg m^2) of each base joint of a ``base: fixed`` robot: the base is welded
#: in effect (the arm's reactions move it by nanometres), while ``qpos[:3]`` keeps its meaning.
FIXED_BASE_ARMATURE = 1e9
#: Names of the base joints in the MuJoCo model, in planner order ``[x, y, yaw]``.
BASE_JOINTS = ("base_x", "base_y", "base_yaw")


def world_spec(robot: MobileManipulator, timestep: float) -> mujoco.MjSpec:
    """Empty world: options (time step, gravity, ``implicitfast``), a floor plane and a light."""
    spec = mujoco.MjSpec()
    spec.modelname = f"forte-{robot.name}"
    spec.option.timestep = timestep
    spec.option.gravity = [0.0, 0.0, -robot.gravity]
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.compiler.autolimits = True
    world = spec.worldbody
    world.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[5, 5, 0.1], rgba=[0.85, 0.85, 0.85, 1],
                   contype=0, conaffinity=0)
    world.add_light(pos=[0, 0, 4], dir=[0, 0, -1])
    return spec


def add_base(spec: mujoco.MjSpec, robot: MobileManipulator, mass: float,
              inertia: tuple[float, float, float]) -> Any:
    """The base body with its slide x, slide y and yaw hinge joints and a box up to the mount."""
    base = spec.worldbody.add_body(name="base", mass=mass, inertia=list(inertia), explicitinertial=True)
    # a fixed base is welded: its joints keep their qpos slots but carry an immovable inertia
    weld = {"armature": FIXED_BASE_ARMATURE} if robot.base == "fixed" else {}
    base.add_joint(name="base_x", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[1, 0, 0], **weld)
    base.add_joint(name="base_y", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[0, 1, 0], **weld)
    base.add_joint(name="base_yaw", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 0, 1], **weld)
    add_base_box(base, robot)
    return base


def add_base_box(base: Any, robot: MobileManipulator) -> None:
    """The base box up to the mount (none for a bare arm: its root link is its base, as in the
    clearance check)."""
    height = max(float(robot.mount[2, 3]), BASE_BOX_MIN_HEIGHT)
    if not has_base_box(robot):
        return
    base.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[*BASE_BOX_HALF_XY, height / 2], pos=[0, 0, height / 2],
                  rgba=[0.3, 0.3, 0.35, 1], contype=0, conaffinity=0, mass=0.0)


def add_end_effector(spec: mujoco.MjSpec, robot: MobileManipulator, payload_mass: float,
                      com: FloatArray, payload_radius: float, inertia: Any = None) -> None:
    """The ``ee`` site, the tool body and the payload body on the end-effector link."""
    # End effector: the Pinocchio frame placement relative to its parent joint; the MuJoCo body
    # of that joint has the URDF child-link frame, which is Pinocchio's joint frame.
    ee = robot.model.frames[robot.ee_frame_id]
    parent_joint = robot.model.names[ee.parentJoint]
    link = spec.joint(ARM_PREFIX + parent_joint).parent
    M_ee: pin.SE3 = ee.placement
    ee_pos = M_ee.translation.tolist()
    ee_quat = _rot_to_quat(M_ee.rotation).tolist()
    link.add_site(name="ee", pos=ee_pos, quat=ee_quat, size=[0.01, 0, 0], rgba=[1, 0, 0, 1], group=3)
    if robot.tool is not None:
        # The tool and payload bodies sit at the end-effector frame with their centre of mass
        # given as ``ipos`` (set explicitly: MjSpec defaulted ``ipos`` to the body ``pos``).
        tool = link.add_body(name="tool", pos=ee_pos, quat=ee_quat)
        tool.explicitinertial = True
        tool.ipos = list(robot.tool.com)
        tool.mass = float(robot.tool.mass)
        # Principal axes ourselves: MuJoCo 4.0 sorted ``fullinertia``'s eigenvalues without
        # rotating ``iquat`` (measured: a diagonal box inertia came out permuted).
        tool.inertia, tool.iquat = _principal(np.asarray(robot.tool.inertia, dtype=float))
    if payload_mass > 0:
        payload = link.add_body(name="payload", pos=ee_pos, quat=ee_quat)
        payload.explicitinertial = True
        payload.ipos = com.tolist()
        payload.mass = payload_mass
        if inertia is None:
            payload.iquat = [1.0, 0.0, 0.0, 0.0]
            payload.inertia = list(_solid_sphere(payload_mass, payload_radius))
        else:  # principal axes ourselves, as the tool's
            payload.inertia, payload.iquat = _principal(np.asarray(inertia, dtype=float))
        payload.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[payload_radius, 0, 0], pos=com.tolist(),
                         rgba=[0.9, 0.5, 0.1, 1], contype=0, conaffinity=0, mass=0.0)


def add_actuators(spec: mujoco.MjSpec, robot: MobileManipulator, base_kv: tuple[float, float, float] | None) -> None:
    """Arm torque motors clipped at the torque limits and base velocity actuators of gain ``kv``
    (none for a floor base: ``base_kv`` None)."""
    for name, limit in zip(robot.arm_joints or (), robot.torque_limits, strict=True):
        act = spec.add_actuator(
            name=f"tau_{name}", target=ARM_PREFIX + name, trntype=mujoco.mjtTrn.mjTRN_JOINT
        )
        act.set_to_motor()
        act.ctrllimited = True
        act.ctrlrange = [-float(limit), float(limit)]
    for name, kv in zip(BASE_JOINTS, base_kv or (), strict=base_kv is not None):
        act = spec.add_actuator(name=f"v_{name}", target=name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        act.set_to_velocity(kv=float(kv))


__all__ = ["BASE_JOINTS", "BASE_KV", "FIXED_BASE_ARMATURE", "add_actuators", "add_base", "add_base_box",
           "add_end_effector", "world_spec"]
