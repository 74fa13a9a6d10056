"""Base controllers of a base on the floor (:mod:`forte.execution.floor_base`): what the actuators get.

**Differential base** (two driven wheels, no lateral actuator): the unicycle tracking law of
Kanayama et al. (1990) on the planned base motion. With the tracking error in the base frame

    (e_x, e_y) = R(yaw)^T (p_d - p),    e_yaw = yaw_d - yaw  (wrapped),

the planned forward speed ``v_d = (cos yaw_d, sin yaw_d) . p_d'`` and yaw rate ``w_d``:

    v = v_d cos(e_yaw) + k_x e_x,       w = w_d + v_d k_y e_y + k_yaw sin(e_yaw),

and each wheel ``i`` at ``(x_i, y_i)`` on the axle ``x_i = 0`` turns at ``(v - w y_i) / r`` (rolling
without slip: the base's velocity at the wheel's contact point is ``v - w y_i`` along the base's x).
A lateral error is corrected only by turning while moving (``v_d k_y e_y``), as a unicycle must.

**Holonomic base** (idealised omni wheels, :mod:`forte.execution.floor_base`): the admittance of
:class:`~forte.execution.control.BaseAdmittance` gives the world velocity command ``v_cmd``; the push
on the base (forces along its x and y, torque about its z, at the base origin on the floor) is

    (F_x, F_y) = kv_xy R^T (v_cmd,xy - v),      tau_z = kv_yaw (v_cmd,yaw - w),

the kinematic base's velocity actuators' law applied as wheel traction instead of on slide joints.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from forte.execution.floor_base import HOLONOMIC_KV, WHEEL_RADIUS, FloorSimModel
from forte.validation import FloatArray


@dataclass(frozen=True)
class KanayamaGains:
    """Gains of the differential base's tracking law: ``k_x`` (1/s), ``k_y`` (1/m^2), ``k_yaw`` (1/s)."""

    k_x: float = 3.0
    k_y: float = 20.0
    k_yaw: float = 3.0


def wrap(angle: float) -> float:
    """``angle`` wrapped to [-pi, pi)."""
    return float((angle + np.pi) % (2 * np.pi) - np.pi)


def unicycle_command(q_b: FloatArray, q_bd: FloatArray, dq_bd: FloatArray,
                     gains: KanayamaGains = KanayamaGains()) -> tuple[float, float]:
    """Forward speed ``v`` (m/s) and yaw rate ``w`` (rad/s) of the Kanayama law (module docstring)."""
    c, s = np.cos(q_b[2]), np.sin(q_b[2])
    dx, dy = q_bd[0] - q_b[0], q_bd[1] - q_b[1]
    e_x, e_y = c * dx + s * dy, -s * dx + c * dy
    e_yaw = wrap(q_bd[2] - q_b[2])
    v_d = np.cos(q_bd[2]) * dq_bd[0] + np.sin(q_bd[2]) * dq_bd[1]
    v = v_d * np.cos(e_yaw) + gains.k_x * e_x
    w = dq_bd[2] + v_d * gains.k_y * e_y + gains.k_yaw * np.sin(e_yaw)
    return float(v), float(w)


def wheel_speeds(floor: FloorSimModel, v: float, w: float) -> FloatArray:
    """Wheel angular velocities (rad/s) for base speed ``v`` and yaw rate ``w``: ``(v - w y_i) / r``."""
    ys = np.array([c.point[1] for c in floor.contacts if c.wheel])
    return (v - w * ys) / WHEEL_RADIUS


def holonomic_push(q_b: FloatArray, dq_b: FloatArray, v_cmd: FloatArray) -> FloatArray:
    """``(F_x, F_y, tau_z)`` in the base frame (module docstring)."""
    c, s = np.cos(q_b[2]), np.sin(q_b[2])
    ex, ey = v_cmd[0] - dq_b[0], v_cmd[1] - dq_b[1]
    return np.array([HOLONOMIC_KV[0] * (c * ex + s * ey), HOLONOMIC_KV[1] * (-s * ex + c * ey),
                     HOLONOMIC_KV[2] * (v_cmd[2] - dq_b[2])])


class FloorDrive:
    """The controls of a floor base's actuators for one step (wheels or push, module docstring)."""

    def __init__(self, floor: FloorSimModel, gains: KanayamaGains = KanayamaGains()) -> None:
        self.floor, self.gains = floor, gains

    def command(self, q_b: FloatArray, dq_b: FloatArray, q_bd: FloatArray, dq_bd: FloatArray,
                v_cmd: FloatArray) -> FloatArray:
        """Actuator controls: wheel speeds (differential) or the push (holonomic, from ``v_cmd``)."""
        if self.floor.drive == "differential":
            return wheel_speeds(self.floor, *unicycle_command(q_b, q_bd, dq_bd, self.gains))
        return holonomic_push(q_b, dq_b, v_cmd)
