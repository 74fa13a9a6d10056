"""Tip-over margin of the mobile base: the whole robot's zero-moment point against its support polygon.

**Ground wrench.** The floor holds the robot with the wrench ``(F, N_O)`` (force, moment about the
base frame's origin ``O`` on the floor), which by Newton-Euler for every body of the robot is

    F   = sum_b m_b (a_b - g) + f
    N_O = sum_b [ c_b x m_b (a_b - g) + dL_b/dt ] + m + p_ee x f

with ``a_b`` the acceleration of body ``b``'s centre of mass ``c_b``, ``L_b`` its angular momentum
about it, and ``w = (f, m)`` the task wrench the hand applies to the payload at the end effector
``p_ee`` (the payload pushes back with ``-w``, so the floor carries ``w`` besides the robot). The
bodies are the base (:class:`~forte.model.base_support.BaseSupport`: its mass at its centre of
mass), the arm URDF's links rigid with it (Pinocchio's universe body of the arm model, moved by the
mount) and the arm's links. :func:`ground_wrench` computes it with Pinocchio's RNEA on a model of
the whole robot with a free-flyer root at the base frame: the root joint's generalized force is
exactly ``(F, N_O)`` in the base frame, the task wrench entering as the external force ``-w`` on
the end effector's body. The base moves in the plane (x, y, yaw; no roll, pitch or heave): the
root's twist is ``v = (R^T p', (0, 0, yaw'))`` and its derivative ``a = (R^T p'' - omega x R^T p',
(0, 0, yaw''))`` (``R = Rz(yaw)``, ``p`` the base position).

**Zero-moment point.** The point of the floor about which the floor's moment has no horizontal
component (``N_p = N_O - p x F``, ``p_z = 0``):

    zmp = (-N_O,y / F_z,  N_O,x / F_z)      (base frame, m)

At rest it is the static centre of pressure, the ground projection of the centre of mass of the
robot and payload (a test checks it by hand). **Margin:** the signed distance from the ZMP to the
support polygon's edge (:meth:`~forte.model.base_support.BaseSupport.margin`, m, positive inside);
the base tips when it is negative. With ``F_z <= 0`` (the floor pulls) the margin is ``-inf``.

The NLP's smooth version (the same Newton-Euler sums in CasADi,
:meth:`forte.model.twin.CasadiTwin.ground_wrench`) is the term of :mod:`forte.planning.tipover_terms`.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin

from forte.exceptions import InvalidInputError
from forte.model.description import N_BASE
from forte.model.robot import MobileManipulator
from forte.model.trajectory import backward_differences
from forte.validation import FloatArray, as_array

_MODELS: dict[str, tuple[pin.Model, int]] = {}


def _support(robot: MobileManipulator) -> Any:
    if robot.base_support is None:
        raise InvalidInputError("base_footprint: the robot states no base support polygon (robot.base_footprint)")
    return robot.base_support


def whole_body_model(robot: MobileManipulator) -> tuple[pin.Model, int]:
    """Pinocchio model of the whole robot with a free-flyer root at the base frame (the base body,
    then the arm with its universe body moved by the mount), and the end effector's frame id."""
    key = robot.fingerprint
    if key not in _MODELS:
        support = _support(robot)
        arm = robot.model.copy()
        mount = pin.SE3(robot.mount[:3, :3].copy(), robot.mount[:3, 3].copy())
        arm.inertias[0] = mount.act(arm.inertias[0])  # appendModel adds it to the root, unmoved
        root = pin.Model()
        joint = root.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "forte_base")
        root.appendBodyToJoint(joint, pin.Inertia(support.mass, np.array(support.com), np.zeros((3, 3))),
                               pin.SE3.Identity())
        frame = root.addFrame(pin.Frame("forte_base", joint, 0, pin.SE3.Identity(), pin.FrameType.OP_FRAME))
        model = pin.appendModel(root, arm, frame, pin.SE3.Identity())
        model.gravity = pin.Motion(np.array([0.0, 0.0, -robot.gravity, 0.0, 0.0, 0.0]))
        _MODELS[key] = (model, model.getFrameId(robot.model.frames[robot.ee_frame_id].name))
    return _MODELS[key]


def root_motion(q_b: FloatArray, dq_b: FloatArray, ddq_b: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """The free-flyer's configuration (7), twist and its derivative (6 each, base frame) of a planar
    base pose ``(x, y, yaw)`` with its velocity and acceleration (module docstring)."""
    c, s = np.cos(q_b[2]), np.sin(q_b[2])
    Rt = np.array([[c, s], [-s, c]])
    v = Rt @ dq_b[:2]
    a = Rt @ ddq_b[:2] - dq_b[2] * np.array([-v[1], v[0]])  # - omega x v, omega = (0, 0, yaw')
    config = np.array([q_b[0], q_b[1], 0.0, 0.0, 0.0, np.sin(q_b[2] / 2), np.cos(q_b[2] / 2)])
    return config, np.r_[v, 0.0, 0.0, 0.0, dq_b[2]], np.r_[a, 0.0, 0.0, 0.0, ddq_b[2]]


def ground_wrench(robot: MobileManipulator, q: Any, dq: Any, ddq: Any, wrench: Any = None) -> FloatArray:
    """``(F, N_O)`` (K x 6, base frame, about the base origin on the floor) at whole-body states
    ``q, dq, ddq`` (K x nq) with the task wrench ``wrench`` (K x 6 world ``(f, m)`` at the end
    effector, or K x 3 forces; ``None``: none); module docstring."""
    q = np.atleast_2d(np.asarray(q, dtype=float))
    dq, ddq = (as_array(x, name, q.shape) for x, name in ((dq, "dq"), (ddq, "ddq")))
    w = np.zeros((len(q), 6))
    if wrench is not None:
        given = np.atleast_2d(np.asarray(wrench, dtype=float))
        w[:, : given.shape[1]] = given
    model, ee = whole_body_model(robot)
    data = model.createData()
    joint = model.frames[ee].parentJoint
    out = np.empty((len(q), 6))
    for k in range(len(q)):
        config, v, a = root_motion(q[k, :N_BASE], dq[k, :N_BASE], ddq[k, :N_BASE])
        qk = np.r_[config, q[k, N_BASE:]]
        pin.framesForwardKinematics(model, data, qk)
        p = data.oMf[ee].translation
        at_origin = pin.Force(w[k, :3], w[k, 3:] + np.cross(p, w[k, :3]))  # world frame, about its origin
        fext = [pin.Force.Zero() for _ in range(model.njoints)]
        fext[joint] = -data.oMi[joint].actInv(at_origin)  # the payload's push on the hand, joint frame
        tau = pin.rnea(model, data, qk, np.r_[v, dq[k, N_BASE:]], np.r_[a, ddq[k, N_BASE:]], fext)
        out[k] = tau[:6]
    return out


def zero_moment_point(ground: Any) -> FloatArray:
    """``(-N_y / F_z, N_x / F_z)`` (K x 2, base frame, m) of ground wrenches (K x 6); NaN where
    ``F_z <= 0``."""
    g = np.atleast_2d(np.asarray(ground, dtype=float))
    fz = np.where(g[:, 2] > 0, g[:, 2], np.nan)
    return np.column_stack([-g[:, 4] / fz, g[:, 3] / fz])


def tipover_margin(robot: MobileManipulator, q: Any, dq: Any, ddq: Any, wrench: Any = None) -> FloatArray:
    """The signed distance (m, > 0 inside) of the ZMP to the support polygon's edge at each state
    (``-inf`` where the floor would have to pull)."""
    zmp = zero_moment_point(ground_wrench(robot, q, dq, ddq, wrench))
    margin = _support(robot).margin(np.nan_to_num(zmp))
    return np.where(np.isnan(zmp[:, 0]), -np.inf, margin)


def trajectory_tipover_margin(robot: MobileManipulator, q: Any, t: Any, force: Any) -> FloatArray:
    """The margin at each waypoint of a plan with its backward-difference velocities and
    accelerations (the paper's quantities, the ``tipover_margin`` column of metrics.csv), for a
    :class:`~forte.force.taskforce.TaskForce` (its moment when it has one)."""
    q = np.asarray(q, dtype=float).copy()
    q[:, 2] = np.unwrap(q[:, 2])
    dq, ddq = backward_differences(q, t, "q")
    return tipover_margin(robot, q, dq, ddq, force.wrench)

