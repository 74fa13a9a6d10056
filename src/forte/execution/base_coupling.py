"""The arm's inverse dynamics on a moving base (``controller.base_coupling``, off by default).

The paper's arm law feeds forward ``M_a(q_a) ddq_{a,d} + C_a(q_a, dq_a) + g(q_a)``: the arm's
dynamics with its mount at rest. On a mobile base the mount accelerates and turns, and the arm's
joints feel the inertial forces of that motion (the base's acceleration ``M_ab ddq_b`` and the
Coriolis and centrifugal terms of its yaw rate): the impedance law's error absorbs them. On
MotionBenchMaker's table_pick 0003 on the authors' holonomic base (``benchmarks/motionbenchmaker.py
--base holonomic``) the arm's joint error was 13 mrad against < 1 mrad on the fixed base.

With the option, the feedforward is the arm rows of the whole-body inverse dynamics

    tau_ff = [RNEA(q, v, a)]_arm,    q = (q_b, q_a),  v = (dq_b, dq_a),  a = (ddq_{b,d}, ddq_{a,d}),

on a Pinocchio model whose root is a free flyer at the base frame moved as the planar base
(:func:`forte.model.stability.root_motion`: its twist and acceleration in the base frame), the arm
appended at its mount; the measured base velocity and the planned base acceleration, as the arm
law takes the measured arm velocity and the planned arm acceleration. The arm rows do not depend
on the base's own mass (no arm joint carries the base), so no base body is modelled. With the
base at rest it is ``robot.rnea(q_a, dq_a, ddq_a)`` exactly.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from forte.model.robot import N_BASE, MobileManipulator
from forte.model.stability import root_motion
from forte.validation import FloatArray

#: The free flyer's configuration and velocity sizes (Pinocchio: xyz + quaternion, twist).
_NQ_ROOT, _NV_ROOT = 7, 6


class BaseCoupling:
    """Arm torques of the whole-body inverse dynamics (module docstring)."""

    def __init__(self, robot: MobileManipulator) -> None:
        root = pin.Model()
        joint = root.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "forte_base")
        frame = root.addFrame(pin.Frame("forte_base", joint, 0, pin.SE3.Identity(), pin.FrameType.OP_FRAME))
        # the mount is in the arm's joint placements already (forte.model.urdf_loading.reduce_to_arm)
        self.model = pin.appendModel(root, robot.model.copy(), frame, pin.SE3.Identity())
        self.model.gravity = pin.Motion(np.array([0.0, 0.0, -robot.gravity, 0.0, 0.0, 0.0]))
        self.data = self.model.createData()

    def torques(self, q: FloatArray, dq: FloatArray, ddq: FloatArray) -> FloatArray:
        """``[RNEA(q, dq, ddq)]_arm`` for whole-body ``q, dq, ddq`` (``[x, y, yaw, q_a]`` each)."""
        config, twist, accel = root_motion(q[:N_BASE], dq[:N_BASE], ddq[:N_BASE])
        tau = pin.rnea(self.model, self.data, np.r_[config, q[N_BASE:]], np.r_[twist, dq[N_BASE:]],
                       np.r_[accel, ddq[N_BASE:]])
        return np.array(tau[_NV_ROOT:])
