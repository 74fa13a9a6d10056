"""Rigid bodies of the simulation model: quaternions, principal axes, and what the hand carries.

:func:`carried_body` is the one body welded to the end effector in ``forte simulate``: the payload
(mass ``m_p`` at its centre of mass ``c_p``, end-effector frame, with its inertia ``I_p`` about it,
or a solid sphere of radius ``r`` when none is given) and the robot's end-effector load that the
plan's force includes (``tool_force_mass`` ``m_t``, a point at the end effector), as one body:

    m = m_p + m_t,    c = m_p c_p / m,
    I = I_p + m_p (|r_p|^2 E - r_p r_p^T) + m_t (|c|^2 E - c c^T),   r_p = c_p - c

(parallel-axis theorem). A payload at the hand without an inertia keeps the earlier model: one
sphere of the whole carried mass at the end effector.
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np

from forte.model.description import PAYLOAD_RADIUS
from forte.model.robot import ToolLoad
from forte.validation import FloatArray, as_positive


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


def carried_body(payload_mass: float, com: Any = None, inertia: Any = None, tool_mass: float = 0.0,
                 radius: float = PAYLOAD_RADIUS) -> tuple[float, FloatArray, FloatArray | None]:
    """``(m, c, I)`` of the body the hand carries (module docstring); ``I`` is ``None`` for the
    earlier model (a sphere of ``m`` at the end effector: no offset, no inertia given)."""
    m_p = as_positive(payload_mass, "payload mass", allow_zero=True)
    total = m_p + tool_mass
    if (com is None or not np.any(com)) and inertia is None or total == 0.0:
        return total, np.zeros(3), None
    c_p = np.zeros(3) if com is None else np.asarray(com, dtype=float)
    I_p = np.diag(_solid_sphere(m_p, radius)) if inertia is None else np.asarray(inertia, dtype=float)
    c = m_p * c_p / total
    r_p = c_p - c
    I = I_p + m_p * (r_p @ r_p * np.eye(3) - np.outer(r_p, r_p)) + tool_mass * (c @ c * np.eye(3) - np.outer(c, c))
    return total, c, 0.5 * (I + I.T)
