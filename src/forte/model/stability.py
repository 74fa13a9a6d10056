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
:meth:`forte.model.twin.CasadiTwin.ground_wrench`) is the term of :mod:`forte.planning.terms.tipover_terms`.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin

from forte.exceptions import InvalidInputError
from forte.model.description import N_BASE
from forte.model.robot import MobileManipulator
from forte.model.trajectory import StartMotion, backward_differences
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
    """The free-flyer's configuration (7), twist and its derivative (6 each, base frame) of planar
    base poses ``(x, y, yaw)`` with their velocities and accelerations (module docstring); rows of
    K x 3 arrays, or one pose."""
    q_b, dq_b, ddq_b = (np.atleast_2d(np.asarray(x, dtype=float)) for x in (q_b, dq_b, ddq_b))
    yaw, rate = q_b[:, 2], dq_b[:, 2]
    c, s = np.cos(yaw), np.sin(yaw)
    v = np.column_stack([c * dq_b[:, 0] + s * dq_b[:, 1], -s * dq_b[:, 0] + c * dq_b[:, 1]])  # R^T v
    a = np.column_stack([c * ddq_b[:, 0] + s * ddq_b[:, 1], -s * ddq_b[:, 0] + c * ddq_b[:, 1]])
    a += rate[:, None] * np.column_stack([v[:, 1], -v[:, 0]])  # - omega x v, omega = (0, 0, yaw')
    zeros = np.zeros((len(q_b), 3))
    config = np.column_stack([q_b[:, :2], zeros, np.sin(yaw / 2), np.cos(yaw / 2)])
    out = config, np.column_stack([v, zeros, rate]), np.column_stack([a, zeros, ddq_b[:, 2]])
    return out if len(q_b) > 1 else tuple(x[0] for x in out)  # type: ignore[return-value]


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
    config, v, a = (np.atleast_2d(x) for x in root_motion(q[:, :N_BASE], dq[:, :N_BASE], ddq[:, :N_BASE]))
    qs, vs, accs = (np.column_stack([x, y[:, N_BASE:]]) for x, y in ((config, q), (v, dq), (a, ddq)))
    out, p = np.empty((len(q), 6)), np.empty((len(q), 3))
    for k in range(len(q)):
        out[k] = pin.rnea(model, data, qs[k], vs[k], accs[k])[:6]
        if wrench is not None:
            pin.framesForwardKinematics(model, data, qs[k])
            p[k] = data.oMf[ee].translation
    if wrench is not None:
        # RNEA is linear in the external forces: the root's wrench with the payload's push on the
        # hand is the free motion's plus that push moved to the root's frame (x, y, 0, Rz(yaw))
        f, moment = w[:, :3], w[:, 3:] + np.cross(p, w[:, :3])  # about the world origin
        moment -= np.cross(np.column_stack([q[:, :2], np.zeros(len(q))]), f)  # about the base origin
        c, s = np.cos(q[:, 2]), np.sin(q[:, 2])
        for part, v in ((slice(0, 3), f), (slice(3, 6), moment)):  # R(yaw)^T v
            out[:, part] += np.column_stack([c * v[:, 0] + s * v[:, 1], -s * v[:, 0] + c * v[:, 1], v[:, 2]])
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


def trajectory_tipover_margin(robot: MobileManipulator, q: Any, t: Any, force: Any,
                              start: StartMotion | None = None) -> FloatArray:
    """The margin at each waypoint of a plan with its backward-difference velocities and
    accelerations (the paper's quantities, the ``tipover_margin`` column of metrics.csv), for a
    :class:`~forte.force.taskforce.TaskForce` (its moment when it has one); ``start``: the first
    waypoint's motion (default: at rest)."""
    q = np.asarray(q, dtype=float).copy()
    q[:, 2] = np.unwrap(q[:, 2])
    dq, ddq = backward_differences(q, t, "q", start)
    return tipover_margin(robot, q, dq, ddq, force.wrench)

