"""The compiled MuJoCo model of the robot and the index bookkeeping the controllers need.

:class:`SimModel` holds the model, its data and the ``qpos``/``qvel`` addresses of the whole-body
configuration ``[x, y, yaw, q_1..q_n]`` in planner order (a kinematic base's slide and hinge
joints, or a floor base's free joint: :mod:`forte.execution.floor_base`); :func:`index_model`
looks those addresses up in a model that :func:`forte.execution.model.build_sim_model` compiled.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import mujoco
import numpy as np

from forte.exceptions import SimulationError
from forte.execution.arm_spec import ARM_PREFIX
from forte.execution.floor_base import FloorSimModel
from forte.execution.model_parts import BASE_JOINTS
from forte.model.robot import N_BASE, MobileManipulator
from forte.model.scene import Scene
from forte.validation import FloatArray, as_vector


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


def index_model(robot: MobileManipulator, model: mujoco.MjModel, payload_mass: float,
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


__all__ = ["SimModel", "index_model"]
