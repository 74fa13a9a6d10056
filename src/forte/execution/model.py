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

from typing import Any

import mujoco
import numpy as np

from forte.exceptions import InvalidInputError, SimulationError
from forte.execution.arm_spec import ARM_PREFIX, load_arm_spec
from forte.execution.bodies import _rot_to_quat, combined_tool
from forte.execution.contact import add_scene, enable_robot_contacts
from forte.execution.floor_base import add_floor_actuators, add_floor_base, uses_floor
from forte.execution.model_parts import (
    BASE_JOINTS,
    BASE_KV,
    FIXED_BASE_ARMATURE,
    add_actuators,
    add_base,
    add_base_box,
    add_end_effector,
    world_spec,
)
from forte.execution.sim_model import SimModel, index_model
from forte.model.description import BASE_INERTIA, BASE_MASS, PAYLOAD_RADIUS
from forte.model.robot import MobileManipulator
from forte.model.scene import Scene
from forte.validation import FloatArray, as_positive, as_vector

# The base mass and inertia (BASE_MASS, BASE_INERTIA) are the model layer's (forte.model.description):
# the exported URDF carries the same; the base's joints and gains are the spec's parts' (model_parts).
#: Reflected rotor inertia of each arm joint (kg m^2), MuJoCo Menagerie's Panda value.
ARM_ARMATURE = 0.1


def armature_vector(armature: Any, n_arm: int) -> FloatArray:
    """Rotor inertia per arm joint (one value broadcast, or ``n_arm`` values), each >= 0 kg m^2."""
    rotor = np.array(np.broadcast_to(np.asarray(armature, dtype=float), (n_arm,)))
    if np.any(~np.isfinite(rotor)) or np.any(rotor < 0):
        raise InvalidInputError(f"armature: expected values >= 0 kg m^2, got {rotor}")
    return rotor


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
    return index_model(robot, _compile(spec), payload_mass, rotor, scene, objects=decorate is not None,
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
    spec = world_spec(robot, timestep)
    floor = uses_floor(robot, base_model)
    base = add_floor_base(spec, robot) if floor else add_base(spec, robot, base_mass, base_inertia)
    if floor:
        add_base_box(base, robot)
    frame = base.add_frame(pos=robot.mount[:3, 3].tolist(), quat=_rot_to_quat(robot.mount[:3, :3]).tolist())
    root = arm.worldbody.first_body()
    if root is None:
        raise SimulationError(f"urdf: {robot.urdf_path} has no link below the world")
    frame.attach_body(root, ARM_PREFIX, "")
    add_end_effector(spec, robot, payload_mass, com, payload_radius, payload_inertia)
    add_actuators(spec, robot, None if floor else base_kv)
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

__all__ = ["ARM_ARMATURE", "BASE_JOINTS", "BASE_KV", "FIXED_BASE_ARMATURE", "SimModel", "armature_vector",
           "build_sim_model", "build_sim_spec", "combined_tool", "whole_body_mjcf"]
