"""Wrench requirement: the moment a payload with an offset centre of mass needs (issue 25, item 1).

A payload of mass ``m`` whose centre of mass sits at ``c`` (end-effector frame, m) and whose
rotational inertia about it is ``I`` (end-effector axes, kg m^2, optional) is carried by the
hand with the wrench ``w_k = (f_k, m_k)`` at the end effector (world frame)::

    f_k = m (p''_k - g)                                   (the paper's force, unchanged)
    m_k = c_k x f_k  +  I_k alpha_k  +  omega_k x (I_k omega_k)
    c_k = R_k c,     I_k = R_k I R_k^T

with ``R_k`` the task's end-effector orientation, ``p''_k`` the paper's backward-difference
acceleration of the path and ``omega_k``, ``alpha_k`` the path's angular velocity and
acceleration by the same backward differences, starting at rest::

    omega_1 = 0,   omega_k = log(R_k R_{k-1}^T)^vee / dt_k,   alpha_k = (omega_k - omega_{k-1}) / dt_k

(``alpha_1 = 0``). This is Newton-Euler for the payload about its centre of mass: the hand's
moment about the end effector balances ``(p_ee - p_com) x f = -c_k x f`` and the payload's rate of
angular momentum. Without an inertia the rotational terms are left out (a point mass). As in the
paper's ``f_k``, the force uses the end effector's acceleration; the centre of mass's own extra
acceleration ``alpha_k x c_k + omega_k x (omega_k x c_k)`` is neglected (at 0.2 m and the shipped
paths' turning rates it is below 1 % of ``g``).

Only the payload's share of the force has a lever arm: the robot's ``tool_force_mass`` (the
authors' end-effector load) sits at the end effector, so with a total force
``f_k = (m + m_tool)(p'' - g)`` the moment is ``c_k x (m / (m + m_tool)) f_k``.

**Uncertainty in wrench space.** A force ball of radius ``r_k`` (the paper's) and the moment ball
of radius ``r_m,k = |c| r_k`` that the same force uncertainty makes when it acts at the centre of
mass (``|c x df| <= |c| |df|``): ``U_k = {(f_k + df, m_k + dm) : |df| <= r_k, |dm| <= |c| r_k}``.
Why this product of balls rather than its exact image ``{(df, c x df)}`` (a flat 3-D disc in
R^6) or an ellipsoid from a mass and centre-of-mass covariance: the paper's ``r_k`` is not only a
mass error (it also absorbs the acceleration estimate and the grip), so its moment is not tied to
one lever direction; the product is the smallest product of balls that contains the image; its
support function ``r |a_f| + r_m |a_m|`` is separable, which keeps the metric closed-form and its
surrogate smooth; and at ``c = 0`` it is the paper's force ball exactly. It is conservative by at
most ``(|a_f| + |c| |a_m|) / |a_f + a_m x c|`` per facet (1 for a facet the force alone binds).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np
import pinocchio as pin

from forte.force.payload import Payload
from forte.force.taskforce import TaskForce
from forte.validation import FloatArray, as_array, check_times


def angular_rates(t: Any, rotations: Any) -> tuple[FloatArray, FloatArray]:
    """``(omega, alpha)`` (N x 3 each, world frame) of orientations ``R_k`` (N x 3 x 3) at times
    ``t`` by backward differences, starting at rest (module docstring)."""
    times = check_times(t)
    R = as_array(rotations, "rotations", (times.size, 3, 3))
    omega = np.zeros((times.size, 3))
    for k in range(1, times.size):
        omega[k] = pin.log3(R[k] @ R[k - 1].T) / (times[k] - times[k - 1])
    alpha = np.zeros_like(omega)
    if times.size > 1:
        alpha[1:] = np.diff(omega, axis=0) / np.diff(times)[:, None]
    return omega, alpha


def payload_moment(t: Any, rotations: Any, payload_force: Any, com: Any,
                   inertia: Any = None) -> FloatArray:
    """``m_k = c_k x f_k + I_k alpha_k + omega_k x I_k omega_k`` (N x 3, world frame, N m).

    Args:
        t: sample times (N).
        rotations: the end effector's world orientations ``R_k`` (N x 3 x 3).
        payload_force: the payload's share of the force ``f_k`` (N x 3, world frame, N).
        com: ``c`` in the end-effector frame (m).
        inertia: ``I`` about the centre of mass, end-effector axes (3 x 3, kg m^2); ``None``: a point mass.

    Examples:
        A 2 kg payload held still 0.2 m ahead of the hand (x), the hand's axes the world's: the
        hand holds 2 g up and the moment of that force about the hand (N m):

        >>> import numpy as np
        >>> m = payload_moment([0.0], np.eye(3)[None], [[0.0, 0.0, 19.62]], [0.2, 0.0, 0.0])
        >>> np.round(m, 3).tolist()
        [[0.0, -3.924, 0.0]]
    """
    times = check_times(t)
    R = as_array(rotations, "rotations", (times.size, 3, 3))
    f = as_array(payload_force, "payload_force", (times.size, 3))
    c_world = R @ as_array(com, "com", (3,))
    moment = np.cross(c_world, f)
    if inertia is not None:
        omega, alpha = angular_rates(times, R)
        I_world = R @ as_array(inertia, "inertia", (3, 3)) @ np.swapaxes(R, 1, 2)
        spin = np.einsum("kij,kj->ki", I_world, omega)
        moment = moment + np.einsum("kij,kj->ki", I_world, alpha) + np.cross(omega, spin)
    return moment


def with_payload_moment(force: TaskForce, payload: Payload, rotations: Any, payload_share: Any) -> TaskForce:
    """``force`` with the wrench requirement of ``payload`` (``force`` itself when the payload needs
    no moment): ``m_k`` of :func:`payload_moment` for the payload's share of the force
    ``payload_share`` (N x 3), the moment ball ``r_m = |c| r`` and the moment scale ``L``."""
    if not payload.has_moment:
        return force
    com = np.zeros(3) if payload.com is None else np.asarray(payload.com)
    moment = payload_moment(force.t, rotations, payload_share, com, payload.inertia)
    return replace(force, m=moment, lever=payload.lever, moment_scale=payload.length_scale)
