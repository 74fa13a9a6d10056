"""MuJoCo simulation model of the mobile manipulator, built at run time with ``MjSpec``.

The model is built from the *same* URDF as the Pinocchio model of :class:`forte.model.robot.MobileManipulator`
so that both agree on the arm dynamics (checked by ``mj_inverse`` vs ``robot.rnea`` in the tests,
agreement ~1e-12 Nm):

* ``world -> base`` body with joints ``base_x`` (slide x), ``base_y`` (slide y), ``base_yaw``
  (hinge z), so ``qpos[:3] = q_b = [x, y, yaw]`` exactly as in the planner;
* the arm's root link attached to the base through a frame equal to ``robot.mount``;
* joints that Pinocchio locks (the Panda's fingers) are deleted: their bodies become rigidly
  fixed at the locked value (the neutral configuration clipped to the joint range), together
  with any equality (``mimic``) constraint that referred to them;
* joint damping and friction loss are set to zero (the URDF has damping 0.003 that Pinocchio's
  ``rnea`` does not model); joint range limits stay active (a real arm has them);
* every arm joint gets the reflected motor (rotor) inertia ``armature`` (default
  :data:`ARM_ARMATURE`, 0.1 kg m^2 per joint as in MuJoCo Menagerie's Panda). The URDF's
  rigid-body model has none, but a geared, torque-controlled arm does, and it matters for the
  1 kHz controller: without it the inertia of the wrist mode ``q5 = -q7`` drops to
  0.007 kg m^2 when ``q6 -> pi`` (axes 5 and 7 nearly parallel), and the sampled damping
  ``D_a`` of the impedance law is unstable there (``dt * eig(M^-1 D_a) > 2``, see
  :func:`forte.execution.control.sampled_loop_spectral_radius`). The controller's inertia includes the
  same armature (``M_a(q) + diag(armature)``), so ``mj_inverse = rnea + armature * ddq``;
* ``package://`` mesh URIs are replaced by the example-robot-data share path; with
  ``meshes=False`` every URDF geometry is dropped (faster, nothing to render). Every geom has
  ``contype = conaffinity = 0``: self-contacts between collision meshes would add huge forces;
* the end-effector tool load (``robot.tool``: same mass, centre of mass and inertia) as a body
  on the link that carries the end-effector frame, and a site ``ee`` at the end-effector frame;
* a payload body of configurable mass rigidly attached at the end effector (welded: a sphere
  of radius ``payload_radius`` centred at ``payload_com`` in the end-effector frame, inertia
  ``2/5 m r^2``). The weld never breaks, so a *payload drop* is judged from the motion (see
  :class:`Thresholds`): the end effector sagging more than 10 cm below the plan, or the basket
  tilting more than 0.5 rad away from the planned orientation, counts as a drop;
* torque actuators ``tau_<joint>`` on the arm joints with ``ctrlrange = +-robot.torque_limits``
  (MuJoCo clips the control, so the arm can never exceed its limits); velocity actuators
  ``v_base_x/y/yaw`` with gain ``kv`` on the base joints (the base is velocity-controlled,
  paper Section 3.1): force ``kv (v_cmd - qdot)``, integrated implicitly (``implicitfast``).

Gravity is ``[0, 0, -robot.gravity]``; the time step defaults to 1 ms (1 kHz control).

:func:`simulate_plan` runs a plan directory (``trajectory.csv`` + ``plan.json``, see
:func:`write_plan_dir`) through the controllers of :mod:`forte.execution.control` and judges the run.
When the plan has no payload (``payload.mass`` null) but a task force, the force is an
interaction with the environment: its reaction ``-f_d`` is applied at the end effector.
"""

from __future__ import annotations

import io
import json
import os
import shutil
import subprocess
import time
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import pinocchio as pin

from forte.exceptions import InvalidInputError, SimulationError
from forte.execution.control import ArmImpedance, BaseAdmittance, ControlGains, Reference, interpolate_plan
from forte.io.plandir import atomic_write, read_plan_dir
from forte.model.robot import (
    N_BASE,
    MobileManipulator,
    ToolLoad,
    example_robot_data_dir,
    robot_from_description,
)
from forte.model.trajectory import trajectory_header
from forte.validation import FloatArray, as_positive, as_vector

#: Default base mass (kg) and yaw inertia (kg m^2): a MOCA-like omnidirectional platform.
BASE_MASS = 60.0
BASE_INERTIA = (2.5, 2.5, 3.0)
#: Velocity-actuator gains of the base joints: slides (N s/m) and yaw (N m s/rad). With the base
#: mass above, the velocity loop has a time constant of ~ m / kv = 30 ms.
BASE_KV = (2000.0, 2000.0, 400.0)
#: Reflected rotor inertia of each arm joint (kg m^2), MuJoCo Menagerie's Panda value.
ARM_ARMATURE = 0.1
#: Name prefix of the arm's bodies and joints in the MuJoCo model (``arm/panda_joint1``, ...).
ARM_PREFIX = "arm/"


def _rot_to_quat(R: FloatArray) -> FloatArray:
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, np.ascontiguousarray(R, dtype=float).reshape(9))
    return quat


def _principal(inertia: FloatArray) -> tuple[list[float], list[float]]:
    """Principal moments (floored at 1e-9: MuJoCo rejects zero inertia) and their axes' quaternion."""
    w, V = np.linalg.eigh(0.5 * (inertia + inertia.T))
    if np.linalg.det(V) < 0:
        V[:, 0] = -V[:, 0]
    return np.maximum(w, 1e-9).tolist(), _rot_to_quat(V).tolist()


def _solid_sphere(mass: float, radius: float) -> tuple[float, float, float]:
    i = 0.4 * mass * radius**2
    return (i, i, i)


def combined_tool(
    tool: ToolLoad | None, mass: float, com: Any = (0.0, 0.0, 0.0), radius: float = 0.05
) -> ToolLoad | None:
    """The tool load plus a payload sphere (``mass``, ``com``, ``radius``) as one :class:`ToolLoad`.

    Used to give Pinocchio the dynamics of the simulated end-effector body (tool + payload):
    ``m = m_t + m_p``, ``c = (m_t c_t + m_p c_p) / m`` and, by the parallel-axis theorem,
    ``I = sum_i I_i + m_i (|r_i|^2 E - r_i r_i^T)`` with ``r_i = c_i - c``.
    """
    mass = as_positive(mass, "payload mass", allow_zero=True)
    if mass == 0.0:
        return tool
    parts = [(mass, np.asarray(com, dtype=float), np.diag(_solid_sphere(mass, radius)))]
    if tool is not None:
        parts.append((tool.mass, np.asarray(tool.com, dtype=float), np.asarray(tool.inertia)))
    total = sum(p[0] for p in parts)
    c = sum(p[0] * p[1] for p in parts) / total
    inertia = np.zeros((3, 3))
    for m, ci, Ii in parts:
        r = ci - c
        inertia += Ii + m * (r @ r * np.eye(3) - np.outer(r, r))
    inertia = 0.5 * (inertia + inertia.T)
    return ToolLoad(
        mass=float(total), com=tuple(float(v) for v in c),
        inertia=tuple(tuple(float(v) for v in row) for row in inertia),
    )


def _urdf_text(robot: MobileManipulator, meshes: bool) -> str:
    text = robot.urdf_path.read_text()
    # Mesh URIs: package://example-robot-data/robots/... -> the real share folder.
    text = text.replace("package://example-robot-data/robots/", str(example_robot_data_dir()) + "/")
    if "package://" in text and meshes:
        raise SimulationError(
            f"urdf: {robot.urdf_path} refers to package:// meshes outside example-robot-data; "
            "simulate without meshes (meshes=False)"
        )
    return text


@dataclass
class SimModel:
    """A compiled MuJoCo model of ``robot`` plus the index bookkeeping the controllers need.

    Attributes:
        robot: The Pinocchio robot the model was built from.
        model, data: MuJoCo model and data.
        payload_mass: Mass of the welded payload body (kg, 0 = none).
        qpos_idx, dof_idx: qpos / qvel addresses of ``[x, y, yaw, q_1..q_n]`` (whole-body order).
        arm_act, base_act: Actuator ids of the arm torque and base velocity actuators.
        ee_site: Id of the site at the end-effector frame.
        payload_body: Body id of the payload (-1 when none).
        armature: Reflected rotor inertia of each arm joint (kg m^2), in the model's ``M_a``.
    """

    robot: MobileManipulator
    model: mujoco.MjModel
    data: mujoco.MjData
    payload_mass: float
    qpos_idx: np.ndarray
    dof_idx: np.ndarray
    arm_act: np.ndarray
    base_act: np.ndarray
    ee_site: int
    payload_body: int
    armature: FloatArray
    _jacp: FloatArray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self._jacp = np.zeros((3, self.model.nv))

    @property
    def timestep(self) -> float:
        return float(self.model.opt.timestep)

    def set_state(self, q: Any, dq: Any = None) -> None:
        """Set the whole-body position ``q`` (and velocity ``dq``, default 0) and run kinematics."""
        q = self.robot.check_configuration(q)
        dq = np.zeros(self.robot.nq) if dq is None else as_vector(dq, "dq", self.robot.nq)
        self.data.qpos[self.qpos_idx] = q
        self.data.qvel[self.dof_idx] = dq
        mujoco.mj_forward(self.model, self.data)

    def state(self) -> tuple[FloatArray, FloatArray]:
        """Whole-body ``(q, dq)`` in planner order ``[x, y, yaw, q_a]``."""
        return self.data.qpos[self.qpos_idx].copy(), self.data.qvel[self.dof_idx].copy()

    def ee_pose(self) -> FloatArray:
        """4x4 world pose of the end-effector site (after the last ``mj_forward``/``mj_step``)."""
        T = np.eye(4)
        T[:3, :3] = self.data.site_xmat[self.ee_site].reshape(3, 3)
        T[:3, 3] = self.data.site_xpos[self.ee_site]
        return T

    def ee_jacobian(self) -> FloatArray:
        """World-frame translational Jacobian of the end effector w.r.t. the arm joints (3 x n)."""
        mujoco.mj_jacSite(self.model, self.data, self._jacp, None, self.ee_site)
        return self._jacp[:, self.dof_idx[N_BASE:]].copy()

    def inverse_dynamics(self, q_a: Any, dq_a: Any, ddq_a: Any) -> FloatArray:
        """Arm torques from ``mj_inverse`` with the base at rest.

        Equals ``robot.rnea(q_a, dq_a, ddq_a) + armature * ddq_a`` (rigid body + rotor inertia).

        Sets the state of :attr:`data` (base at the origin, at rest).
        """
        n = self.robot.n_arm
        q = np.concatenate([np.zeros(N_BASE), as_vector(q_a, "q_a", n)])
        dq = np.concatenate([np.zeros(N_BASE), as_vector(dq_a, "dq_a", n)])
        self.set_state(q, dq)
        self.data.qacc[:] = 0.0
        self.data.qacc[self.dof_idx[N_BASE:]] = as_vector(ddq_a, "ddq_a", n)
        mujoco.mj_inverse(self.model, self.data)
        return self.data.qfrc_inverse[self.dof_idx[N_BASE:]].copy()


def build_sim_model(
    robot: MobileManipulator,
    payload_mass: float = 0.0,
    *,
    payload_com: Any = (0.0, 0.0, 0.0),
    payload_radius: float = 0.05,
    meshes: bool = False,
    timestep: float = 1e-3,
    base_mass: float = BASE_MASS,
    base_inertia: tuple[float, float, float] = BASE_INERTIA,
    base_kv: tuple[float, float, float] = BASE_KV,
    armature: Any = ARM_ARMATURE,
) -> SimModel:
    """Build the MuJoCo model of ``robot`` carrying a welded payload of ``payload_mass`` kg.

    Args:
        robot: The robot (URDF, mount, tool, torque limits, gravity).
        payload_mass: Payload mass in kg (0: no payload body).
        payload_com: Payload centre in the end-effector frame (m).
        payload_radius: Radius of the payload sphere (m), sets its inertia ``2/5 m r^2``.
        meshes: Keep the URDF meshes (for rendering; no contacts either way).
        timestep: Integration step (s).
        base_mass, base_inertia, base_kv: Base body and base velocity-actuator parameters.
        armature: Reflected rotor inertia of the arm joints (kg m^2; one value or one per joint).

    Raises:
        SimulationError: when the URDF cannot be turned into a MuJoCo model.
    """
    payload_mass = as_positive(payload_mass, "mass", allow_zero=True)
    timestep = as_positive(timestep, "timestep")
    com = as_vector(payload_com, "payload_com", 3)
    rotor = np.array(np.broadcast_to(np.asarray(armature, dtype=float), (robot.n_arm,)))
    if np.any(~np.isfinite(rotor)) or np.any(rotor < 0):
        raise InvalidInputError(f"armature: expected values >= 0 kg m^2, got {rotor}")
    try:
        arm = mujoco.MjSpec.from_string(_urdf_text(robot, meshes))
    except Exception as exc:  # MuJoCo raises plain ValueError on parse/compile problems
        raise SimulationError(f"urdf: MuJoCo cannot load {robot.urdf_path}: {exc}") from exc
    _prepare_arm(arm, robot, meshes, rotor)

    spec = mujoco.MjSpec()
    spec.modelname = f"forte-{robot.name}"
    spec.option.timestep = timestep
    spec.option.gravity = [0.0, 0.0, -robot.gravity]
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.compiler.autolimits = True
    world = spec.worldbody
    world.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[5, 5, 0.1], rgba=[0.85, 0.85, 0.85, 1],
                   contype=0, conaffinity=0)
    world.add_light(pos=[0, 0, 4], dir=[0, 0, -1])
    base = world.add_body(name="base", mass=base_mass, inertia=list(base_inertia), explicitinertial=True)
    base.add_joint(name="base_x", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[1, 0, 0])
    base.add_joint(name="base_y", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[0, 1, 0])
    base.add_joint(name="base_yaw", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 0, 1])
    mount = robot.mount
    height = max(float(mount[2, 3]), 0.05)
    base.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.3, 0.25, height / 2], pos=[0, 0, height / 2],
                  rgba=[0.3, 0.3, 0.35, 1], contype=0, conaffinity=0, mass=0.0)
    frame = base.add_frame(pos=mount[:3, 3].tolist(), quat=_rot_to_quat(mount[:3, :3]).tolist())
    root = arm.worldbody.first_body()
    if root is None:
        raise SimulationError(f"urdf: {robot.urdf_path} has no link below the world")
    frame.attach_body(root, ARM_PREFIX, "")

    # End effector: the Pinocchio frame placement relative to its parent joint; the MuJoCo body
    # of that joint has the URDF child-link frame, which is Pinocchio's joint frame.
    ee = robot.model.frames[robot.ee_frame_id]
    parent_joint = robot.model.names[ee.parentJoint]
    link = spec.joint(ARM_PREFIX + parent_joint).parent
    M_ee: pin.SE3 = ee.placement
    ee_quat = _rot_to_quat(M_ee.rotation).tolist()
    link.add_site(name="ee", pos=M_ee.translation.tolist(), quat=ee_quat, size=[0.01, 0, 0],
                  rgba=[1, 0, 0, 1], group=3)
    if robot.tool is not None:
        # The tool and payload bodies sit at the end-effector frame with their centre of mass
        # given as ``ipos`` (set explicitly: MjSpec defaulted ``ipos`` to the body ``pos``).
        tool = link.add_body(name="tool", pos=M_ee.translation.tolist(), quat=ee_quat)
        tool.explicitinertial = True
        tool.ipos = list(robot.tool.com)
        tool.mass = float(robot.tool.mass)
        # Principal axes ourselves: MuJoCo 4.0 sorted ``fullinertia``'s eigenvalues without
        # rotating ``iquat`` (measured: a diagonal box inertia came out permuted).
        tool.inertia, tool.iquat = _principal(np.asarray(robot.tool.inertia, dtype=float))
    if payload_mass > 0:
        payload = link.add_body(name="payload", pos=M_ee.translation.tolist(), quat=ee_quat)
        payload.explicitinertial = True
        payload.ipos = com.tolist()
        payload.iquat = [1.0, 0.0, 0.0, 0.0]
        payload.mass = payload_mass
        payload.inertia = list(_solid_sphere(payload_mass, payload_radius))
        payload.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[payload_radius, 0, 0], pos=com.tolist(),
                         rgba=[0.9, 0.5, 0.1, 1], contype=0, conaffinity=0, mass=0.0)

    for name, limit in zip(robot.arm_joints or (), robot.torque_limits, strict=True):
        act = spec.add_actuator(
            name=f"tau_{name}", target=ARM_PREFIX + name, trntype=mujoco.mjtTrn.mjTRN_JOINT
        )
        act.set_to_motor()
        act.ctrllimited = True
        act.ctrlrange = [-float(limit), float(limit)]
    for name, kv in zip(("base_x", "base_y", "base_yaw"), base_kv, strict=True):
        act = spec.add_actuator(name=f"v_{name}", target=name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        act.set_to_velocity(kv=float(kv))
    try:
        model = spec.compile()
    except Exception as exc:
        raise SimulationError(f"simulation model: MuJoCo compile failed: {exc}") from exc
    data = mujoco.MjData(model)

    names = ("base_x", "base_y", "base_yaw", *(robot.arm_joints or ()))
    jids = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, n if i < N_BASE else ARM_PREFIX + n)
            for i, n in enumerate(names)]
    if min(jids) < 0:
        raise SimulationError(f"simulation model: joints {names} not all found")
    if model.nv != len(names):
        raise SimulationError(f"simulation model: expected {len(names)} DoF, got {model.nv}")
    acts = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, f"tau_{n}") for n in names[N_BASE:]]
    bacts = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, f"v_{n}") for n in names[:N_BASE]]
    return SimModel(
        robot=robot, model=model, data=data, payload_mass=payload_mass,
        qpos_idx=np.array([model.jnt_qposadr[j] for j in jids]),
        dof_idx=np.array([model.jnt_dofadr[j] for j in jids]),
        arm_act=np.array(acts), base_act=np.array(bacts),
        ee_site=mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, "ee"),
        payload_body=mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "payload"),
        armature=rotor,
    )


def _prepare_arm(arm: mujoco.MjSpec, robot: MobileManipulator, meshes: bool, armature: FloatArray) -> None:
    """Lock non-arm joints, zero damping/friction, set the armature, disable contacts, drop meshes."""
    rotor = dict(zip(robot.arm_joints or (), armature, strict=True))
    keep = set(rotor)
    for eq in list(arm.equalities):  # URDF mimic joints become equality constraints
        arm.delete(eq)
    for joint in list(arm.joints):
        if joint.name in keep:
            joint.damping = np.zeros(3)  # MuJoCo 4: damping polynomial coefficients
            joint.armature = float(rotor[joint.name])
            joint.frictionloss = 0.0
            continue
        value = _locked_value(robot, joint)
        body = joint.parent
        if value != 0.0:  # rigidly fix the body at the locked joint value
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
        arm.delete(joint)
    for geom in list(arm.geoms):
        if not meshes:
            arm.delete(geom)
            continue
        geom.contype = 0
        geom.conaffinity = 0
        geom.mass = 0.0
        geom.density = 0.0


def _quat_rotate(quat: Any, v: FloatArray) -> FloatArray:
    out = np.zeros(3)
    mujoco.mju_rotVecQuat(out, v, np.asarray(quat, dtype=float))
    return out


def _locked_value(robot: MobileManipulator, joint: Any) -> float:
    """The value Pinocchio's reduced model locks a joint at: neutral (0) clipped to its range."""
    lo, hi = (float(v) for v in joint.range)
    limited = joint.limited == mujoco.mjtLimited.mjLIMITED_TRUE or (
        joint.limited == mujoco.mjtLimited.mjLIMITED_AUTO and lo < hi
    )
    return float(np.clip(0.0, lo, hi)) if limited and lo < hi else 0.0


def check_mass(mass: Any) -> float:
    """A payload mass >= 0 kg (``InvalidInputError`` naming ``mass`` otherwise)."""
    if mass is None:
        raise InvalidInputError("mass: expected a number >= 0 kg, got None")
    return as_positive(mass, "mass", allow_zero=True)




# -- verdict ----------------------------------------------------------------------------------
@dataclass(frozen=True)
class Thresholds:
    """Failure criteria of a simulated execution (the first one met gives the verdict).

    Attributes:
        drop_sag: Payload drop: the end effector is this far (m) *below* the planned height
            while a payload is carried (an object that is not lifted or slips out). 0.10 m.
        drop_tilt: Payload drop: the end-effector z axis tilts this far (rad) from the planned
            one while a payload is carried (the basket spills). 0.5 rad.
        sag: End-effector sag: vertical shortfall (m) that counts when sustained. 0.03 m.
        sag_time: How long (s) the sag must last. 0.2 s.
        saturation_time: Sustained torque saturation: one joint's command exceeds its limit for
            this long (s) without interruption. 0.25 s.
        max_ee_error: Tracking loss: end-effector position error norm (m) at any instant. 0.15 m.
    """

    drop_sag: float = 0.10
    drop_tilt: float = 0.5
    sag: float = 0.03
    sag_time: float = 0.2
    saturation_time: float = 0.25
    max_ee_error: float = 0.15

    def __post_init__(self) -> None:
        for name in ("drop_sag", "drop_tilt", "sag", "sag_time", "saturation_time", "max_ee_error"):
            as_positive(getattr(self, name), f"thresholds.{name}")


@dataclass
class SimResult:
    """Outcome of :func:`simulate_plan`.

    Attributes:
        success: No failure criterion was met.
        reason: ``None`` on success, else ``"payload drop"``, ``"end-effector sag"``,
            ``"torque saturation"``, ``"tracking loss"`` or ``"unstable"``.
        failure_time: Simulated time (s) at which the criterion was met (``None`` on success).
        detail: One human-readable sentence on the failure.
        log: Recorded columns (name -> array), also written to ``sim.csv``.
        summary: Scalar statistics (max errors, saturation fractions, wall time, ...).
    """

    success: bool
    reason: str | None
    failure_time: float | None
    detail: str
    log: dict[str, FloatArray]
    summary: dict[str, Any]

    def to_json(self) -> dict[str, Any]:
        return {
            "verdict": "success" if self.success else "failure",
            "reason": self.reason,
            "failure_time": self.failure_time,
            "detail": self.detail,
            **self.summary,
        }


class _Judge:
    """Checks the :class:`Thresholds` at every control step and keeps the first failure."""

    def __init__(self, th: Thresholds, dt: float, n_arm: int, payload: bool) -> None:
        self.th, self.dt, self.payload = th, dt, payload
        self.sag_run = 0.0
        self.sat_run = np.zeros(n_arm)
        self.reason: str | None = None
        self.time: float | None = None
        self.detail = ""

    def _fail(self, t: float, reason: str, detail: str) -> None:
        if self.reason is None:
            self.reason, self.time, self.detail = reason, t, detail

    def step(self, t: float, ee_err: FloatArray, tilt: float, saturated: FloatArray) -> None:
        th = self.th
        sag = -ee_err[2]  # ee_err = p - p_d: negative z = below the plan
        self.sag_run = self.sag_run + self.dt if sag > th.sag else 0.0
        self.sat_run = np.where(saturated, self.sat_run + self.dt, 0.0)
        if self.payload and sag > th.drop_sag:
            self._fail(t, "payload drop", f"end effector {sag:.3f} m below the plan at t = {t:.3f} s")
        elif self.payload and tilt > th.drop_tilt:
            self._fail(t, "payload drop", f"end effector tilted {tilt:.2f} rad at t = {t:.3f} s")
        elif float(np.linalg.norm(ee_err)) > th.max_ee_error:
            self._fail(t, "tracking loss",
                       f"end-effector error {np.linalg.norm(ee_err):.3f} m at t = {t:.3f} s")
        elif self.sag_run >= th.sag_time - 1e-9:
            self._fail(t, "end-effector sag",
                       f"end effector more than {th.sag} m below the plan for {th.sag_time} s "
                       f"(t = {t:.3f} s)")
        elif np.any(self.sat_run >= th.saturation_time - 1e-9):
            j = int(np.argmax(self.sat_run))
            self._fail(t, "torque saturation",
                       f"joint {j + 1} saturated for {th.saturation_time} s (t = {t:.3f} s)")


# -- running ----------------------------------------------------------------------------------
class _Recorder:
    """Offscreen frames for ``--frames DIR`` (PNG) or ``--video FILE.mp4`` (ffmpeg)."""

    def __init__(self, sim: SimModel, frames_dir: Path | None, video: Path | None, fps: float,
                 size: tuple[int, int]) -> None:
        self.frames_dir, self.video, self.fps = frames_dir, video, fps
        self.frames: list[np.ndarray] = []
        if video is not None and shutil.which("ffmpeg") is None:
            raise SimulationError(f"video {video}: writing mp4 needs 'ffmpeg' on PATH; use --frames DIR")
        gl = os.environ.get("MUJOCO_GL", "<unset>")
        try:
            self.renderer = mujoco.Renderer(sim.model, height=size[1], width=size[0])
            self.camera = mujoco.MjvCamera()
            self.camera.type = mujoco.mjtCamera.mjCAMERA_FREE
            self.camera.distance, self.camera.azimuth, self.camera.elevation = 3.0, 135.0, -20.0
            self.capture(sim)
            self.frames.clear()
        except Exception as exc:  # MuJoCo/PyOpenGL raise assorted types when no context exists
            raise SimulationError(
                f"offscreen rendering could not initialise (MUJOCO_GL={gl}): {exc}. Set MUJOCO_GL=egl "
                "(GPU or Mesa EGL) or MUJOCO_GL=osmesa before Python starts, or run without "
                "--video/--frames"
            ) from exc

    def capture(self, sim: SimModel) -> None:
        self.camera.lookat[:] = sim.data.site_xpos[sim.ee_site]
        self.renderer.update_scene(sim.data, self.camera)
        self.frames.append(self.renderer.render().copy())

    def finish(self) -> list[Path]:
        from PIL import Image

        self.renderer.close()
        written: list[Path] = []
        if self.frames_dir is not None:
            self.frames_dir.mkdir(parents=True, exist_ok=True)
            for i, frame in enumerate(self.frames):
                path = self.frames_dir / f"frame_{i:05d}.png"
                Image.fromarray(frame).save(path)
                written.append(path)
        if self.video is not None and self.frames:
            h, w = self.frames[0].shape[:2]
            tmp = self.video.with_name(f".{self.video.stem}.tmp.mp4")
            cmd = ["ffmpeg", "-y", "-loglevel", "error", "-f", "rawvideo", "-pix_fmt", "rgb24",
                   "-s", f"{w}x{h}", "-r", str(self.fps), "-i", "-", "-pix_fmt", "yuv420p", str(tmp)]
            proc = subprocess.run(cmd, input=b"".join(f.tobytes() for f in self.frames),
                                  capture_output=True, check=False)
            if proc.returncode != 0:
                tmp.unlink(missing_ok=True)
                raise SimulationError(f"video {self.video}: ffmpeg failed: {proc.stderr.decode()[-300:]}")
            os.replace(tmp, self.video)
            written.append(self.video)
        return written


def run_simulation(
    sim: SimModel,
    reference: Reference,
    *,
    gains: ControlGains | None = None,
    thresholds: Thresholds | None = None,
    reaction_force: bool = False,
    record_every: int = 10,
    stop_on_failure: bool = False,
    recorder: _Recorder | None = None,
    frame_every: int = 33,
) -> SimResult:
    """Run the controllers on ``sim`` along ``reference`` (sampled at every control step).

    The simulation starts at ``reference.q[0]`` at rest; one control step per MuJoCo step
    (``reference.t`` must be ``k * timestep``). With ``reaction_force`` the environment's
    reaction ``-f_d`` is applied at the end-effector point.
    """
    robot = sim.robot
    gains = gains or ControlGains()
    th = thresholds or Thresholds()
    dt = sim.timestep
    arm = ArmImpedance(robot, gains, armature=sim.armature)
    base = BaseAdmittance(gains, dt)
    n = robot.n_arm
    steps = reference.t.size
    judge = _Judge(th, dt, n, sim.payload_mass > 0)
    ee_body = int(sim.model.site_bodyid[sim.ee_site])
    m, d = sim.model, sim.data
    sim.set_state(reference.q[0])
    rec_idx = list(range(0, steps, max(1, int(record_every))))
    if rec_idx[-1] != steps - 1:
        rec_idx.append(steps - 1)
    nrec = len(rec_idx)
    log_q_err = np.zeros((nrec, robot.nq))
    log_tau = np.zeros((nrec, n))
    log_sat = np.zeros((nrec, n))
    log_ee = np.zeros((nrec, 3))
    sat_window = np.zeros(n, dtype=bool)
    sat_steps = np.zeros(n)
    max_ratio = np.zeros(n)
    ee_err_max = 0.0
    ee_sq = 0.0
    qa_err_max = 0.0
    r = 0
    zero3 = np.zeros(3)
    start = time.perf_counter()
    steps_run = 0
    for k in range(steps):
        q, dq = sim.state()
        if not (np.all(np.isfinite(q)) and np.all(np.isfinite(dq))):
            judge._fail(k * dt, "unstable", f"non-finite state at t = {k * dt:.3f} s")
            break
        q_d = reference.q[k]
        T_d = robot.ee_pose(q_d)
        T = sim.ee_pose()
        ee_err = T[:3, 3] - T_d[:3, 3]
        tilt = float(np.arccos(np.clip(T[:3, 2] @ T_d[:3, 2], -1.0, 1.0)))
        J = sim.ee_jacobian()
        f_d = reference.f[k]
        cmd = arm.command(q[N_BASE:], dq[N_BASE:], q_d[N_BASE:], reference.dq[k, N_BASE:],
                          reference.ddq[k, N_BASE:], J, f_d)
        v_cmd = base.command(q[:N_BASE], dq[:N_BASE], q_d[:N_BASE], reference.dq[k, :N_BASE])
        d.ctrl[sim.arm_act] = cmd.tau
        d.ctrl[sim.base_act] = v_cmd
        if reaction_force:
            d.qfrc_applied[:] = 0.0
            mujoco.mj_applyFT(m, d, -f_d, zero3, T[:3, 3].copy(), ee_body, d.qfrc_applied)
        judge.step(k * dt, ee_err, tilt, cmd.saturated)
        # Bookkeeping: saturation is OR-ed over each recording window so no event is lost.
        sat_window |= cmd.saturated
        sat_steps += cmd.saturated
        max_ratio = np.maximum(max_ratio, np.abs(cmd.tau_raw) / arm.tau_max)
        e_norm = float(np.linalg.norm(ee_err))
        ee_err_max = max(ee_err_max, e_norm)
        ee_sq += e_norm**2
        qa_err_max = max(qa_err_max, float(np.abs(q_d[N_BASE:] - q[N_BASE:]).max()))
        if r < nrec and k == rec_idx[r]:
            e_q = q_d - q
            e_q[2] = (e_q[2] + np.pi) % (2 * np.pi) - np.pi
            log_q_err[r], log_tau[r], log_sat[r], log_ee[r] = e_q, cmd.tau, sat_window, ee_err
            sat_window[:] = False
            r += 1
        if recorder is not None and k % frame_every == 0:
            recorder.capture(sim)
        steps_run += 1
        if stop_on_failure and judge.reason is not None:
            break
        mujoco.mj_step(m, d)
    wall = time.perf_counter() - start
    names = trajectory_header(n)[1:]
    log: dict[str, FloatArray] = {"t": reference.t[rec_idx[:r]]}
    for i, name in enumerate(names):
        log[f"e_{name}"] = log_q_err[:r, i]
    for i in range(n):
        log[f"tau{i + 1}"] = log_tau[:r, i]
    for i in range(n):
        log[f"sat{i + 1}"] = log_sat[:r, i]
    for i, axis in enumerate("xyz"):
        log[f"ee_err_{axis}"] = log_ee[:r, i]
    log["ee_err"] = np.linalg.norm(log_ee[:r], axis=1)
    summary = {
        "duration": float(steps_run * dt),
        "timestep": dt,
        "steps": steps_run,
        "wall_time_s": wall,
        "payload_mass": sim.payload_mass,
        "max_ee_error_m": ee_err_max,
        "rms_ee_error_m": float(np.sqrt(ee_sq / max(steps_run, 1))),
        "max_arm_joint_error_rad": qa_err_max,
        "max_torque_ratio": max_ratio.tolist(),
        "saturation_fraction": (sat_steps / max(steps_run, 1)).tolist(),
        "thresholds": asdict(th),
    }
    return SimResult(judge.reason is None, judge.reason, judge.time,
                     judge.detail or "all criteria met", log, summary)


def simulate_plan(
    plan_dir: str | Path,
    mass: float | None = None,
    *,
    force_feedforward: bool | None = None,
    out_dir: str | Path | None = None,
    gains: ControlGains | None = None,
    thresholds: Thresholds | None = None,
    torque_limits: Any = None,
    hold: float = 1.0,
    timestep: float = 1e-3,
    record_every: int = 10,
    stop_on_failure: bool = False,
    frames_dir: str | Path | None = None,
    video: str | Path | None = None,
    fps: float = 30.0,
    write: bool = True,
) -> SimResult:
    """Simulate the plan in ``plan_dir`` and (with ``write``) store ``sim.csv`` and ``sim.json``.

    Args:
        plan_dir: Folder with ``trajectory.csv`` and ``plan.json``.
        mass: True payload mass in the simulation (kg); default: the plan's ``payload.mass``
            (none when null). A mass > 0 different from the plan's models a mass-estimation
            error: the controller's force feedforward still uses the plan's force. ``mass=0``
            on a plan that carries a payload means *no payload*: no payload body and, unless
            ``force_feedforward=True``, no force feedforward either (nothing to carry). On a
            plan without payload (``payload.mass`` null) the force is an interaction with the
            environment and stays on.
        force_feedforward: ``tau_F = J^T f_d`` on (True) or off (False); default (None): on,
            except for ``mass=0`` on a payload plan (see ``mass``). Off, with a plan's
            interaction force, the environment still pushes but the arm does not push back.
        out_dir: Where to write the results (default ``plan_dir``).
        gains, thresholds: Controller gains and failure criteria (defaults documented there).
        torque_limits: Override the robot's limits (Nm, per arm joint), e.g. for stress tests.
        hold: Seconds simulated after the last waypoint, holding it.
        timestep: Simulation and control period (s); 1 ms = 1 kHz.
        record_every: Log every n-th control step (saturation flags OR-ed over the window).
        stop_on_failure: Stop at the first failure instead of running to the end.
        frames_dir, video: Offscreen rendering to PNG frames / an mp4 file at ``fps``.
        write: Write ``sim.csv``/``sim.json``. They are written only after the run completes,
            each through a temporary file and a rename, so an interrupted or crashed run never
            replaces earlier results.

    Raises:
        TaskFileError: malformed plan directory; SimulationError: model or rendering problems.
    """
    plan = read_plan_dir(plan_dir)
    robot = plan.robot
    if torque_limits is not None:
        robot = robot_from_description({**robot.describe(), "torque_limits": list(np.broadcast_to(
            np.asarray(torque_limits, dtype=float), (robot.n_arm,)))})
    true_mass = plan.mass if mass is None else check_mass(mass)
    if force_feedforward is None:
        force_feedforward = not (mass is not None and true_mass == 0.0 and plan.mass is not None)
    gains = gains or ControlGains()
    if not force_feedforward:
        gains = replace(gains, force_feedforward=False)
    hold = as_positive(hold, "hold", allow_zero=True)
    render = frames_dir is not None or video is not None
    sim = build_sim_model(robot, true_mass or 0.0, meshes=render, timestep=timestep)
    dt = sim.timestep
    steps = int(round((plan.t[-1] - plan.t[0] + hold) / dt)) + 1
    times = plan.t[0] + dt * np.arange(steps)
    reference = interpolate_plan(plan.t, plan.q, times, plan.force_t, plan.force)
    recorder = None
    if render:
        recorder = _Recorder(sim, None if frames_dir is None else Path(frames_dir),
                             None if video is None else Path(video), fps, (640, 480))
    result = run_simulation(
        sim, reference, gains=gains, thresholds=thresholds,
        reaction_force=plan.mass is None and plan.force is not None and bool(np.any(plan.force)),
        record_every=record_every, stop_on_failure=stop_on_failure, recorder=recorder,
        frame_every=max(1, int(round(1.0 / (fps * dt)))),
    )
    result.summary.update({"plan_dir": str(Path(plan_dir).resolve()), "plan_method": plan.method,
                           "plan_status": plan.status, "plan_mass": plan.mass,
                           "force_feedforward": gains.force_feedforward,
                           "armature": sim.armature.tolist()})
    if recorder is not None:
        result.summary["rendered"] = [str(p) for p in recorder.finish()]
    if write:
        write_results(result, Path(plan_dir) if out_dir is None else Path(out_dir))
    return result


def write_results(result: SimResult, out_dir: Path) -> tuple[Path, Path]:
    """Atomically write ``sim.csv`` (the log) and ``sim.json`` (verdict + summary) to ``out_dir``."""
    out_dir.mkdir(parents=True, exist_ok=True)
    names = list(result.log)
    table = np.column_stack([result.log[n] for n in names]) if names else np.zeros((0, 0))
    buf = io.StringIO()
    buf.write(",".join(names) + "\n")
    np.savetxt(buf, table, delimiter=",", fmt="%.6g")
    csv_path, json_path = out_dir / "sim.csv", out_dir / "sim.json"
    atomic_write(csv_path, buf.getvalue())
    atomic_write(json_path, json.dumps(result.to_json(), indent=1) + "\n")
    return csv_path, json_path
