"""Forward kinematics of a Pinocchio model at many configurations at once (numpy), for broad phases.

``oMi_j(q) = oMi_parent(j) M_j X_j(q)``: ``M_j`` the joint's fixed placement in its parent and
``X_j`` its motion, for the one-degree-of-freedom joints an arm is made of:

- revolute about an axis ``a`` by ``q``: rotation ``cos q I + sin q [a] + (1 - cos q) a a^T``
  (Rodrigues for a unit ``a``; ``[a]`` the cross-product matrix; Pinocchio's formula, which does
  not normalize ``a``), about x, y, z or any axis (``RevoluteUnaligned``);
- unbounded revolute (``RUB``, two entries ``(cos q, sin q)``): the same with those two;
- prismatic along ``a`` by ``q``: translation ``q a``.

Any other joint gives ``None``: the caller then goes without its broad phase. The placements agree
with Pinocchio's to rounding (~1e-15 m; tested): a broad phase that uses them keeps a margin.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from forte.exceptions import RobotModelError
from forte.model.twin import joint_axis
from forte.validation import FloatArray

_X, _Y, _Z = np.eye(3)
#: Pinocchio's unbounded revolute joints and their axes (``None``: the joint's own); revolute and
#: prismatic ones are the twin's (:func:`~forte.model.twin.joint_axis`).
_UNBOUNDED: dict[str, FloatArray | None] = {
    "JointModelRUBX": _X, "JointModelRUBY": _Y, "JointModelRUBZ": _Z, "JointModelRevoluteUnboundedUnaligned": None,
}


def _kind_and_axis(joint: Any) -> tuple[str, FloatArray] | None:
    """``("R" | "U" | "P", axis)`` of ``joint`` (revolute, unbounded revolute, prismatic), or ``None``."""
    name = joint.shortname()
    if name in _UNBOUNDED:
        axis = _UNBOUNDED[name]
        return "U", np.asarray(joint.extract().axis, dtype=float) if axis is None else axis
    try:
        axis, revolute = joint_axis(joint)
    except RobotModelError:
        return None
    return ("R" if revolute else "P"), np.asarray(axis, dtype=float)


def joint_motion(joint: Any, q: FloatArray) -> FloatArray | None:
    """The motions ``X_j`` (K x 4 x 4) of ``joint`` (a Pinocchio joint model) at its entries ``q``
    (K x nq of the joint); ``None`` for a joint of another type."""
    found = _kind_and_axis(joint)
    if found is None:
        return None
    kind, axis = found
    out = np.repeat(np.eye(4)[None], len(q), axis=0)
    if kind == "P":
        out[:, :3, 3] = q[:, :1] * axis
        return out
    c, s = (q[:, 0], q[:, 1]) if kind == "U" else (np.cos(q[:, 0]), np.sin(q[:, 0]))
    cross = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    out[:, :3, :3] = (c[:, None, None] * np.eye(3) + s[:, None, None] * cross
                      + (1.0 - c)[:, None, None] * np.outer(axis, axis))
    return out


def joint_placements(model: Any, Q: FloatArray) -> FloatArray | None:
    """``oMi`` of every joint of ``model`` (K x njoints x 4 x 4; joint 0, the universe, at the
    identity) at the K configurations ``Q`` (K x nq); ``None`` when a joint is of a type
    :func:`joint_motion` does not handle."""
    Q = np.asarray(Q, dtype=float).reshape(-1, model.nq)
    out = np.empty((len(Q), model.njoints, 4, 4))
    out[:, 0] = np.eye(4)
    for j in range(1, model.njoints):
        joint = model.joints[j]
        motion = joint_motion(joint, Q[:, joint.idx_q:joint.idx_q + joint.nq])
        if motion is None:
            return None
        out[:, j] = out[:, model.parents[j]] @ model.jointPlacements[j].homogeneous @ motion
    return out
