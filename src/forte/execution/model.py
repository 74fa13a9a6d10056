"""MuJoCo simulation model of the mobile manipulator, built at run time with ``MjSpec``.

The model is built from the *same* URDF as the Pinocchio model of :class:`forte.model.robot.MobileManipulator`
so that both agree on the arm dynamics (checked by ``mj_inverse`` vs ``robot.rnea`` in the tests,
agreement ~1e-12 Nm):

* ``world -> base`` body with joints ``base_x`` (slide x), ``base_y`` (slide y), ``base_yaw``
  (hinge z), so ``qpos[:3] = q_b = [x, y, yaw]`` exactly as in the planner;
* the arm's root link attached to the base through a frame equal to ``robot.mount``;
* the arm as prepared by :func:`forte.execution.arm_spec.load_arm_spec`: joints that Pinocchio
  locks (the Panda's fingers) fixed at their locked value, no joint damping or friction loss
  (the URDF has damping 0.003 that Pinocchio's ``rnea`` does not model), joint range limits
  active (a real arm has them), geometry only with ``meshes=True`` (for rendering) or a
  ``scene``; self-contacts always off (between collision meshes they would add huge forces);
* every arm joint gets the reflected motor (rotor) inertia ``armature`` (default
  :data:`ARM_ARMATURE`, 0.1 kg m^2 per joint as in MuJoCo Menagerie's Panda). The URDF's
  rigid-body model has none, but a geared, torque-controlled arm does, and it matters for the
  1 kHz controller: without it the inertia of the wrist mode ``q5 = -q7`` drops to
  0.007 kg m^2 when ``q6 -> pi`` (axes 5 and 7 nearly parallel), and the sampled damping
  ``D_a`` of the impedance law is unstable there (``dt * eig(M^-1 D_a) > 2``, see
  :func:`forte.execution.control.sampled_loop_spectral_radius`). The controller's inertia includes the
  same armature (``M_a(q) + diag(armature)``), so ``mj_inverse = rnea + armature * ddq``;
* the end-effector tool load (``robot.tool``: same mass, centre of mass and inertia) as a body
  on the link that carries the end-effector frame, and a site ``ee`` at the end-effector frame;
* a payload body of configurable mass rigidly attached at the end effector (welded: a sphere
  of radius ``payload_radius`` centred at ``payload_com`` in the end-effector frame, inertia
  ``2/5 m r^2`` or ``payload_inertia``; :func:`forte.execution.bodies.carried_body`). The weld
  never breaks, so a *payload drop* is judged from the motion (see :class:`forte.execution.judge.Thresholds`);
* torque actuators ``tau_<joint>`` on the arm joints with ``ctrlrange = +-robot.torque_limits``
  (MuJoCo clips the control, so the arm can never exceed its limits); velocity actuators
  ``v_base_x/y/yaw`` with gain ``kv`` on the base joints (the base is velocity-controlled,
  paper Section 3.1): force ``kv (v_cmd - qdot)``, integrated implicitly (``implicitfast``).

* with ``base_model="floor"`` the base is a free body on wheels and casters instead
  (:mod:`forte.execution.floor_base`): it can tip and slip; the slide joints above are
  ``base_model="kinematic"``, the default.

* with a ``scene`` (:class:`forte.model.scene.Scene`, possibly empty): the scene's static
  bodies, and contacts on between the robot (the arm's URDF collision geometry, the base box,
  the payload sphere; all massless) and the scene, and between the arm (its links that move
  relative to the base) and the payload and the floor at the scene's floor height (none with
  ``floor: none``; :mod:`forte.execution.contact`). Without one (None) the robot touches nothing.

Gravity is ``[0, 0, -robot.gravity]``; the time step defaults to 1 ms (1 kHz control).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import mujoco
import numpy as np
import pinocchio as pin

from forte.exceptions import InvalidInputError, SimulationError
from forte.execution.arm_spec import ARM_PREFIX, load_arm_spec
from forte.execution.bodies import _principal, _rot_to_quat, _solid_sphere, combined_tool
from forte.execution.contact import add_scene, enable_robot_contacts
from forte.execution.floor_base import FloorSimModel, add_floor_actuators, add_floor_base, uses_floor
from forte.model.description import (
    BASE_BOX_HALF_XY,
    BASE_BOX_MIN_HEIGHT,
    BASE_INERTIA,
    BASE_MASS,
    PAYLOAD_RADIUS,
    has_base_box,
)
from forte.model.robot import N_BASE, MobileManipulator
from forte.model.scene import Scene
from forte.validation import FloatArray, as_positive, as_vector

# The base mass and inertia (BASE_MASS, BASE_INERTIA) are the model layer's (forte.model.description):
# the exported URDF carries the same.
#: Velocity-actuator gains of the base joints: slides (N s/m) and yaw (N m s/rad). With the base
#: mass above, the velocity loop has a time constant of ~ m / kv = 30 ms.
BASE_KV = (2000.0, 2000.0, 400.0)
#: Reflected rotor inertia of each arm joint (kg m^2), MuJoCo Menagerie's Panda value.
ARM_ARMATURE = 0.1
#: Reflected inertia (kg, kg m^2) of each base joint of a ``base: fixed`` robot: the base is welded
#: in effect (the arm's reactions move it by nanometres), while ``qpos[:3]`` keeps its meaning.
FIXED_BASE_ARMATURE = 1e9
#: Names of the base joints in the MuJoCo model, in planner order ``[x, y, yaw]``.
BASE_JOINTS = ("base_x", "base_y", "base_yaw")


def armature_vector(armature: Any, n_arm: int) -> FloatArray:
    """Rotor inertia per arm joint (one value broadcast, or ``n_arm`` values), each >= 0 kg m^2."""
    rotor = np.array(np.broadcast_to(np.asarray(armature, dtype=float), (n_arm,)))
    if np.any(~np.isfinite(rotor)) or np.any(rotor < 0):
        raise InvalidInputError(f"armature: expected values >= 0 kg m^2, got {rotor}")
    return rotor


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
        scene: The scene built in (None: contacts off, the robot touches nothing).
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
    scene: Scene | None = None
    floor: FloorSimModel | None = None  # a base on the floor (forte.execution.floor_base); None: kinematic
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
        if self.floor is not None:
            self.data.qpos[self.qpos_idx[N_BASE:]] = q[N_BASE:]
            self.data.qvel[:] = 0.0
            self.data.qvel[self.dof_idx[N_BASE:]] = dq[N_BASE:]
            self.floor.set_base(self.data, q[:N_BASE], dq[:N_BASE])
        else:
            self.data.qpos[self.qpos_idx] = q
            self.data.qvel[self.dof_idx] = dq
        mujoco.mj_forward(self.model, self.data)

    def state(self) -> tuple[FloatArray, FloatArray]:
        """Whole-body ``(q, dq)`` in planner order ``[x, y, yaw, q_a]``."""
        if self.floor is not None:
            q_b, dq_b = self.floor.base_state(self.data)
            return (np.r_[q_b, self.data.qpos[self.qpos_idx[N_BASE:]]],
                    np.r_[dq_b, self.data.qvel[self.dof_idx[N_BASE:]]])
        return self.data.qpos[self.qpos_idx].copy(), self.data.qvel[self.dof_idx].copy()

    def ee_pose(self) -> FloatArray:
        """4x4 world pose of the end-effector site (after the last ``mj_forward``/``mj_step``)."""
        T = np.eye(4)
        T[:3, :3] = self.data.site_xmat[self.ee_site].reshape(3, 3)
        T[:3, 3] = self.data.site_xpos[self.ee_site]
        return T

    def ee_jacobian(self, angular: bool = False) -> FloatArray:
        """World-frame translational Jacobian of the end effector w.r.t. the arm joints (3 x n);
        with ``angular``, ``[J_v; J_w]`` (6 x n), the wrench's (``tau = J^T (f, m)``)."""
        jacr = np.zeros_like(self._jacp) if angular else None
        mujoco.mj_jacSite(self.model, self.data, self._jacp, jacr, self.ee_site)
        J = self._jacp if jacr is None else np.vstack([self._jacp, jacr])
        return J[:, self.dof_idx[N_BASE:]].copy()

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
    payload_radius: float = PAYLOAD_RADIUS,
    payload_inertia: Any = None,
    meshes: bool = False,
    timestep: float = 1e-3,
    base_mass: float = BASE_MASS,
    base_inertia: tuple[float, float, float] = BASE_INERTIA,
    base_kv: tuple[float, float, float] = BASE_KV,
    armature: Any = ARM_ARMATURE,
    scene: Scene | None = None,
    decorate: Any = None,
    base_model: str = "kinematic",
) -> SimModel:
    """Build the MuJoCo model of ``robot`` carrying a welded payload of ``payload_mass`` kg.

    Args:
        robot: The robot (URDF, mount, tool, torque limits, gravity).
        payload_mass: Payload mass in kg (0: no payload body).
        payload_com: Payload centre in the end-effector frame (m).
        payload_radius: Radius of the payload sphere (m), sets its inertia ``2/5 m r^2``.
        payload_inertia: The payload's inertia about ``payload_com`` (3 x 3, end-effector axes,
            kg m^2) instead of the sphere's (:func:`forte.execution.bodies.carried_body`).
        meshes: Keep the URDF meshes (for rendering; no contacts either way).
        timestep: Integration step (s).
        base_mass: Mass of the base body (kg).
        base_inertia: Principal inertia of the base body (kg m^2).
        base_kv: Gains of the base's velocity actuators: slides (N s/m) and yaw (N m s/rad).
        armature: Reflected rotor inertia of the arm joints (kg m^2; one value or one per joint).
        scene: Static bodies and contacts on (the floor too, even for an empty scene); None:
            no contact at all.
        decorate: Called with the ``MjSpec`` before it is compiled (a contact task's object,
            :mod:`forte.execution.contact_objects`).
        base_model: ``"kinematic"`` (slide joints and a yaw hinge) or ``"floor"`` (a free body on
            wheels and casters, :mod:`forte.execution.floor_base`; a fixed base stays kinematic).

    Raises:
        SimulationError: when the URDF or the scene cannot be turned into a MuJoCo model.
    """
    payload_mass = as_positive(payload_mass, "mass", allow_zero=True)
    rotor = armature_vector(armature, robot.n_arm)
    spec = build_sim_spec(robot, payload_mass, payload_com=payload_com, payload_radius=payload_radius,
                          payload_inertia=payload_inertia, meshes=meshes, timestep=timestep, base_mass=base_mass,
                          base_inertia=base_inertia, base_kv=base_kv, armature=rotor, scene=scene,
                          base_model=base_model)
    if decorate is not None:
        decorate(spec)
    return _index_model(robot, _compile(spec), payload_mass, rotor, scene, objects=decorate is not None,
                        floor=uses_floor(robot, base_model))


def build_sim_spec(
    robot: MobileManipulator,
    payload_mass: float = 0.0,
    *,
    payload_com: Any = (0.0, 0.0, 0.0),
    payload_radius: float = PAYLOAD_RADIUS,
    payload_inertia: Any = None,
    meshes: bool = False,
    timestep: float = 1e-3,
    base_mass: float = BASE_MASS,
    base_inertia: tuple[float, float, float] = BASE_INERTIA,
    base_kv: tuple[float, float, float] = BASE_KV,
    armature: Any = ARM_ARMATURE,
    scene: Scene | None = None,
    base_model: str = "kinematic",
) -> mujoco.MjSpec:
    """The ``MjSpec`` that :func:`build_sim_model` compiles (same arguments)."""
    payload_mass = as_positive(payload_mass, "mass", allow_zero=True)
    timestep = as_positive(timestep, "timestep")
    com = as_vector(payload_com, "payload_com", 3)
    rotor = armature_vector(armature, robot.n_arm)
    arm = load_arm_spec(robot, meshes or scene is not None, rotor)
    spec = _world_spec(robot, timestep)
    floor = uses_floor(robot, base_model)
    base = add_floor_base(spec, robot) if floor else _add_base(spec, robot, base_mass, base_inertia)
    if floor:
        _add_base_box(base, robot)
    frame = base.add_frame(pos=robot.mount[:3, 3].tolist(), quat=_rot_to_quat(robot.mount[:3, :3]).tolist())
    root = arm.worldbody.first_body()
    if root is None:
        raise SimulationError(f"urdf: {robot.urdf_path} has no link below the world")
    frame.attach_body(root, ARM_PREFIX, "")
    _add_end_effector(spec, robot, payload_mass, com, payload_radius, payload_inertia)
    _add_actuators(spec, robot, None if floor else base_kv)
    if floor:
        add_floor_actuators(spec, robot)
    if scene is not None:
        add_scene(spec, scene)
        enable_robot_contacts(spec, base, scene.floor)
    return spec


def _compile(spec: mujoco.MjSpec) -> mujoco.MjModel:
    try:
        return spec.compile()
    except Exception as exc:
        raise SimulationError(f"simulation model: MuJoCo compile failed: {exc}") from exc


def whole_body_mjcf(robot: MobileManipulator, payload_mass: float = 0.0, meshes: bool = True,
                    scene: Scene | None = None) -> str:
    """The simulation model of ``robot`` (base joints ``base_x``, ``base_y``, ``base_yaw``, the arm
    under :data:`ARM_PREFIX`, torque motors and base velocity actuators) as MJCF text; with a
    ``scene``, its static bodies ``scene/<name>`` and the contacts of ``forte simulate``.

    Mesh files are referenced by absolute path, so the file loads from anywhere on this machine.
    """
    spec = build_sim_spec(robot, payload_mass, meshes=meshes, scene=scene)
    _compile(spec)  # to_xml needs a compiled spec
    return spec.to_xml()


def _world_spec(robot: MobileManipulator, timestep: float) -> mujoco.MjSpec:
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


def _add_base(spec: mujoco.MjSpec, robot: MobileManipulator, mass: float,
              inertia: tuple[float, float, float]) -> Any:
    """The base body with its slide x, slide y and yaw hinge joints and a box up to the mount."""
    base = spec.worldbody.add_body(name="base", mass=mass, inertia=list(inertia), explicitinertial=True)
    # a fixed base is welded: its joints keep their qpos slots but carry an immovable inertia
    weld = {"armature": FIXED_BASE_ARMATURE} if robot.base == "fixed" else {}
    base.add_joint(name="base_x", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[1, 0, 0], **weld)
    base.add_joint(name="base_y", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[0, 1, 0], **weld)
    base.add_joint(name="base_yaw", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 0, 1], **weld)
    _add_base_box(base, robot)
    return base


def _add_base_box(base: Any, robot: MobileManipulator) -> None:
    """The base box up to the mount (none for a bare arm: its root link is its base, as in the
    clearance check)."""
    height = max(float(robot.mount[2, 3]), BASE_BOX_MIN_HEIGHT)
    if not has_base_box(robot):
        return
    base.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[*BASE_BOX_HALF_XY, height / 2], pos=[0, 0, height / 2],
                  rgba=[0.3, 0.3, 0.35, 1], contype=0, conaffinity=0, mass=0.0)


def _add_end_effector(spec: mujoco.MjSpec, robot: MobileManipulator, payload_mass: float,
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


def _add_actuators(spec: mujoco.MjSpec, robot: MobileManipulator, base_kv: tuple[float, float, float] | None) -> None:
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


def _index_model(robot: MobileManipulator, model: mujoco.MjModel, payload_mass: float,
                 rotor: FloatArray, scene: Scene | None, objects: bool = False, floor: bool = False) -> SimModel:
    """Look up the joint, actuator, site and body ids of a compiled model."""
    arm_names = robot.arm_joints or ()
    jids = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, ARM_PREFIX + n) for n in arm_names]
    base = FloorSimModel.index(robot, model) if floor else None
    if base is None:
        jids = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, n) for n in BASE_JOINTS] + jids
        qpos_b, dof_b = [], []
    else:  # the free joint's x, y slots; its world yaw rate is read from the angular velocity (floor_base)
        qpos_b, dof_b = [base.free_q, base.free_q + 1, base.free_q + 2], [base.free_v, base.free_v + 1, base.free_v + 5]
    if jids and min(jids) < 0:
        raise SimulationError(f"simulation model: joints {(*BASE_JOINTS, *arm_names)} not all found")
    expected = N_BASE + len(arm_names) + (3 + len(base.wheel_dofs) if base is not None else 0)
    if model.nv != expected and not (objects and model.nv > expected):  # objects: their own DoF
        raise SimulationError(f"simulation model: expected {expected} DoF, got {model.nv}")
    acts = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, f"tau_{n}") for n in arm_names]
    bacts = [] if base is not None else [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, f"v_{n}")
                                         for n in BASE_JOINTS]
    return SimModel(
        robot=robot, model=model, data=mujoco.MjData(model), payload_mass=payload_mass,
        qpos_idx=np.array(qpos_b + [model.jnt_qposadr[j] for j in jids], dtype=int),
        dof_idx=np.array(dof_b + [model.jnt_dofadr[j] for j in jids], dtype=int),
        arm_act=np.array(acts), base_act=np.array(bacts, dtype=int),
        ee_site=mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, "ee"),
        payload_body=mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "payload"),
        armature=rotor, scene=scene, floor=base,
    )


__all__ = ["ARM_ARMATURE", "BASE_JOINTS", "BASE_KV", "SimModel", "armature_vector", "build_sim_model",
           "build_sim_spec", "combined_tool", "whole_body_mjcf"]
