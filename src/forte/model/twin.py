"""Differentiable twin of :class:`~forte.model.robot.MobileManipulator` as CasADi expressions.

The PyPI build of Pinocchio has no CasADi bindings, so the forward kinematics, the world-frame
translational Jacobian and the recursive Newton-Euler algorithm are rebuilt here from the
Pinocchio model's own data (``jointPlacements``, ``parents``, ``inertias``, joint axes). They
agree with Pinocchio numerics to ~1e-12 (see ``tests/test_twin.py``); the optimizer takes every
derivative from them by automatic differentiation, never by finite differences.

Conventions: each joint frame ``i`` has pose ``(R_i, p_i)`` in its parent's frame,
``R_i = R_placement Rot(axis, q_i)`` (revolute) or ``p_i = p_placement + R_placement axis q_i``
(prismatic). RNEA runs in local joint frames with the gravity trick ``a_0 = -g``.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np
import pinocchio as pin

from forte.exceptions import RobotModelError
from forte.model.robot import N_BASE, MobileManipulator

Expr = ca.SX


def body_force(m: float, c: Expr, Ic: Expr, v: Expr, w: Expr, a: Expr, al: Expr) -> tuple[Expr, Expr]:
    """Spatial force ``(f, n)`` (about the frame's origin) of a rigid body of mass ``m``, centre of
    mass ``c`` and rotational inertia ``Ic`` about it, moving with the spatial twist ``(v, w)`` and
    spatial acceleration ``(a, al)`` (Featherstone's convention): ``f = m (a + al x c) + w x h_v``,
    ``n = Ic al + c x m (a + al x c) + w x L + v x h_v`` with ``h_v = m (v + w x c)``, ``L = Ic w + c x h_v``."""
    h = m * (a + ca.cross(al, c))
    hv = m * (v + ca.cross(w, c))
    L = Ic @ w + ca.cross(c, hv)
    return h + ca.cross(w, hv), Ic @ al + ca.cross(c, h) + ca.cross(w, L) + ca.cross(v, hv)


@dataclass(frozen=True)
class _Joint:
    parent: int  # index in the twin's joint list, -1 for the root
    rotation: np.ndarray  # placement in the parent joint frame
    translation: np.ndarray
    axis: np.ndarray
    revolute: bool
    mass: float
    com: np.ndarray
    inertia_com: np.ndarray  # rotational inertia about the centre of mass


_AXES = {"X": np.array([1.0, 0.0, 0.0]), "Y": np.array([0.0, 1.0, 0.0]),
         "Z": np.array([0.0, 0.0, 1.0])}


def is_prismatic(joint: pin.JointModel) -> bool:
    """Whether ``joint`` (revolute or prismatic, as the twin supports) slides along its axis."""
    return not joint_axis(joint)[1]


def joint_axis(joint: pin.JointModel) -> tuple[np.ndarray, bool]:
    """The axis of a revolute or prismatic ``joint`` (aligned or not; an unaligned one's as
    Pinocchio stores it) and whether it is revolute; :class:`RobotModelError` for another type."""
    name = joint.shortname()
    for prefix, revolute in (("JointModelR", True), ("JointModelP", False)):
        if name.startswith(prefix):
            suffix = name[len(prefix):]
            if suffix in _AXES:
                return _AXES[suffix], revolute
            if suffix in ("evoluteUnaligned", "rismaticUnaligned"):
                return np.array(joint.extract().axis, dtype=float), revolute
    raise RobotModelError(
        f"joint type {name} is not supported by the CasADi twin (revolute or prismatic only)"
    )


def _axis_rotation(axis: np.ndarray, angle: Expr) -> Expr:
    """Rodrigues' formula for a constant unit axis."""
    k = ca.DM(axis)
    K = ca.skew(k)
    return ca.DM.eye(3) + ca.sin(angle) * K + (1 - ca.cos(angle)) * (K @ K)


def rot_z(yaw: Expr) -> Expr:
    c, s = ca.cos(yaw), ca.sin(yaw)
    return ca.vertcat(ca.horzcat(c, -s, 0), ca.horzcat(s, c, 0), ca.horzcat(0, 0, 1))


class CasadiTwin:
    """Symbolic kinematics and dynamics of a :class:`MobileManipulator`.

    Every method takes CasADi expressions (SX or MX) and returns expressions, so the same code
    builds the optimizer's cost and constraints and, through :meth:`functions`, numeric
    ``casadi.Function`` objects for tests.
    """

    def __init__(self, robot: MobileManipulator) -> None:
        self.robot = robot
        model = robot.model
        self.n_arm = robot.n_arm
        joints: list[_Joint] = []
        for j in range(1, model.njoints):
            axis, revolute = joint_axis(model.joints[j])
            placement = model.jointPlacements[j]
            inertia = model.inertias[j]
            joints.append(
                _Joint(
                    parent=model.parents[j] - 1,
                    rotation=np.array(placement.rotation),
                    translation=np.array(placement.translation),
                    axis=axis,
                    revolute=revolute,
                    mass=float(inertia.mass),
                    com=np.array(inertia.lever),
                    inertia_com=np.array(inertia.inertia),
                )
            )
        self._joints = joints
        frame = model.frames[robot.ee_frame_id]
        self._ee_joint = frame.parentJoint - 1
        self._ee_rotation = np.array(frame.placement.rotation)
        self._ee_translation = np.array(frame.placement.translation)
        self.gravity = float(robot.gravity)

    # -- per-joint transforms -----------------------------------------------------------
    def _local(self, j: int, q: Expr) -> tuple[Expr, Expr]:
        joint = self._joints[j]
        R0 = ca.DM(joint.rotation)
        p0 = ca.DM(joint.translation)
        if joint.revolute:
            return R0 @ _axis_rotation(joint.axis, q), p0
        return R0, p0 + R0 @ ca.DM(joint.axis) * q

    def _arm_poses(self, q_a: Expr) -> list[tuple[Expr, Expr]]:
        poses: list[tuple[Expr, Expr]] = []
        for j, joint in enumerate(self._joints):
            R, p = self._local(j, q_a[j])
            if joint.parent < 0:
                poses.append((R, p))
            else:
                Rp, pp = poses[joint.parent]
                poses.append((Rp @ R, pp + Rp @ p))
        return poses

    # -- kinematics (base frame) --------------------------------------------------------
    def arm_ee_pose(self, q_a: Expr) -> tuple[Expr, Expr]:
        """End-effector rotation and position in the base frame."""
        R, p = self._arm_poses(q_a)[self._ee_joint]
        return R @ ca.DM(self._ee_rotation), p + R @ ca.DM(self._ee_translation)

    def arm_jacobian_base(self, q_a: Expr) -> Expr:
        """Translational Jacobian (3 x n_arm) in the base frame."""
        poses = self._arm_poses(q_a)
        _, p_ee = self.arm_ee_pose(q_a)
        support = self._support(self._ee_joint)
        columns = []
        for j in range(self.n_arm):
            if j not in support:
                columns.append(ca.DM.zeros(3, 1))
                continue
            R, p = poses[j]
            z = R @ ca.DM(self._joints[j].axis)
            columns.append(ca.cross(z, p_ee - p) if self._joints[j].revolute else z)
        return ca.horzcat(*columns)

    def arm_angular_jacobian_base(self, q_a: Expr) -> Expr:
        """Angular Jacobian (3 x n_arm) of the end effector in the base frame: the joint axis of
        each revolute joint that moves it, zero for prismatic joints and joints off its chain."""
        poses = self._arm_poses(q_a)
        support = self._support(self._ee_joint)
        columns = []
        for j in range(self.n_arm):
            if j not in support or not self._joints[j].revolute:
                columns.append(ca.DM.zeros(3, 1))
                continue
            columns.append(poses[j][0] @ ca.DM(self._joints[j].axis))
        return ca.horzcat(*columns)

    def _support(self, j: int) -> set[int]:
        chain: set[int] = set()
        while j >= 0:
            chain.add(j)
            j = self._joints[j].parent
        return chain

    # -- kinematics (world frame) -------------------------------------------------------
    def ee_pose(self, q: Expr) -> tuple[Expr, Expr]:
        """World-frame end-effector rotation (3x3) and position (3)."""
        R, p = self.arm_ee_pose(q[N_BASE:])
        Rb = rot_z(q[2])
        return Rb @ R, Rb @ p + ca.vertcat(q[0], q[1], 0)

    def arm_jacobian(self, q: Expr) -> Expr:
        """World-frame translational arm Jacobian ``J_t(q)`` (3 x n_arm), base held fixed."""
        return rot_z(q[2]) @ self.arm_jacobian_base(q[N_BASE:])

    def arm_wrench_jacobian(self, q: Expr) -> Expr:
        """World-frame 6 x n_arm Jacobian ``[J_v; J_w]`` of the end effector (linear rows first,
        as Pinocchio's ``LOCAL_WORLD_ALIGNED``), base held fixed: ``tau = J^T (f, m)``."""
        Rb = rot_z(q[2])
        return ca.vertcat(Rb @ self.arm_jacobian_base(q[N_BASE:]), Rb @ self.arm_angular_jacobian_base(q[N_BASE:]))

    # -- dynamics -----------------------------------------------------------------------
    def rnea(self, q_a: Expr, dq_a: Expr, ddq_a: Expr) -> Expr:
        """Arm joint torques of the recursive Newton-Euler algorithm (base held fixed)."""
        zero = ca.DM.zeros(3, 1)
        return self._newton_euler(q_a, dq_a, ddq_a, (zero, zero, ca.DM([0.0, 0.0, self.gravity]), zero))[0]

    def _newton_euler(self, q_a: Expr, dq_a: Expr, ddq_a: Expr,
                      root: tuple[Expr, Expr, Expr, Expr]) -> tuple[Expr, Expr, Expr]:
        """RNEA with the base frame moving with the spatial twist ``(v, w)`` and acceleration
        ``(a, al)`` of ``root`` (base frame; gravity by the trick ``a += (0, 0, g)``): the arm's
        joint torques and the spatial force ``(f, n)`` the base exerts on the arm (base frame,
        about its origin)."""
        n = self.n_arm
        vel: list[tuple[Expr, Expr]] = []
        acc: list[tuple[Expr, Expr]] = []
        forces: list[list[Expr]] = []
        locals_ = [self._local(j, q_a[j]) for j in range(n)]
        for j, joint in enumerate(self._joints):
            R, p = locals_[j]
            Rt = R.T
            v_par, w_par = (root[0], root[1]) if joint.parent < 0 else vel[joint.parent]
            a_par, al_par = (root[2], root[3]) if joint.parent < 0 else acc[joint.parent]
            axis = ca.DM(joint.axis)
            w = Rt @ w_par
            v = Rt @ (v_par + ca.cross(w_par, p))
            al = Rt @ al_par
            a = Rt @ (a_par + ca.cross(al_par, p))
            if joint.revolute:
                sw = axis * dq_a[j]
                w = w + sw
                al = al + axis * ddq_a[j] + ca.cross(w, sw)
                a = a + ca.cross(v, sw)
            else:
                sv = axis * dq_a[j]
                v = v + sv
                a = a + axis * ddq_a[j] + ca.cross(w, sv)
            vel.append((v, w))
            acc.append((a, al))
            forces.append(list(body_force(joint.mass, ca.DM(joint.com), ca.DM(joint.inertia_com), v, w, a, al)))
        tau: list[Expr] = [None] * n
        root_f, root_n = ca.DM.zeros(3, 1), ca.DM.zeros(3, 1)
        for j in reversed(range(n)):
            joint = self._joints[j]
            f, tq = forces[j]
            axis = ca.DM(joint.axis)
            tau[j] = ca.dot(axis, tq) if joint.revolute else ca.dot(axis, f)
            R, p = locals_[j]
            fr, nr = R @ f, R @ tq + ca.cross(p, R @ f)
            if joint.parent >= 0:
                forces[joint.parent][0] = forces[joint.parent][0] + fr
                forces[joint.parent][1] = forces[joint.parent][1] + nr
            else:
                root_f, root_n = root_f + fr, root_n + nr
        return ca.vertcat(*tau), root_f, root_n

    def ground_wrench(self, q2: Expr, q1: Expr, q0: Expr, dt1: Expr, dt0: Expr, f: Expr, m: Expr) -> Expr:
        """The floor's wrench ``(F, N_O)`` (6, base frame, about its origin on the floor) at ``q0``
        with the paper's backward differences over the window ``q2, q1, q0`` (whole body), the task
        wrench ``(f, m)`` (world frame) at the end effector: the Newton-Euler sums of
        :mod:`forte.model.stability` (the base's support body, the arm's universe body moved by the
        mount, the arm's links). Needs ``robot.base_support``."""
        support, universe = self.robot.base_support, self.robot.model.inertias[0]
        dq0, dq1 = (q0 - q1) / dt0, (q1 - q2) / dt1
        ddq = (dq0 - dq1) / dt0
        Rt = rot_z(q0[2]).T
        w0 = ca.vertcat(0, 0, dq0[2])
        v0 = Rt @ ca.vertcat(dq0[0], dq0[1], 0)
        a0 = Rt @ ca.vertcat(ddq[0], ddq[1], 0) - ca.cross(w0, v0) + ca.DM([0.0, 0.0, self.gravity])
        root = (v0, w0, a0, ca.vertcat(0, 0, ddq[2]))
        _, F, N = self._newton_euler(q0[N_BASE:], dq0[N_BASE:], ddq[N_BASE:], root)
        mount = self.robot.mount
        bodies = [(support.mass, np.array(support.com), np.zeros((3, 3))),
                  (universe.mass, mount[:3, :3] @ universe.lever + mount[:3, 3],
                   mount[:3, :3] @ universe.inertia @ mount[:3, :3].T)]
        for mass, com, inertia in bodies:
            fb, nb = body_force(mass, ca.DM(com), ca.DM(inertia), v0, w0, a0, root[3])
            F, N = F + fb, N + nb
        _, p_ee = self.arm_ee_pose(q0[N_BASE:])
        f_b, m_b = Rt @ f, Rt @ m
        return ca.vertcat(F + f_b, N + m_b + ca.cross(p_ee, f_b))

    # -- numeric wrappers ---------------------------------------------------------------
    def functions(self) -> dict[str, ca.Function]:
        """``casadi.Function`` objects: ``ee_pose``, ``arm_jacobian``, ``arm_wrench_jacobian``, ``rnea``."""
        q = ca.SX.sym("q", N_BASE + self.n_arm)
        qa, dqa, ddqa = (ca.SX.sym(s, self.n_arm) for s in ("q_a", "dq_a", "ddq_a"))
        R, p = self.ee_pose(q)
        return {
            "ee_pose": ca.Function("ee_pose", [q], [R, p]),
            "arm_jacobian": ca.Function("arm_jacobian", [q], [self.arm_jacobian(q)]),
            "arm_wrench_jacobian": ca.Function("arm_wrench_jacobian", [q], [self.arm_wrench_jacobian(q)]),
            "rnea": ca.Function("rnea", [qa, dqa, ddqa], [self.rnea(qa, dqa, ddqa)]),
        }
