"""Online payload identification from measured joint torques (recursive least squares).

With the payload a point mass ``m`` at the end-effector frame, the arm's joint torques are

    tau_meas = RNEA(q, dq, ddq) + armature * ddq + J_t(q)^T m (a_ee - g),

where ``RNEA`` is the model without payload (robot and tool), ``J_t`` the world-frame
translational Jacobian, ``a_ee = J_t ddq + dJ_t dq`` the end-effector acceleration and
``g = [0, 0, -9.81]``. The residual ``r = tau_meas - RNEA(...) - armature * ddq`` is therefore
linear in the one unknown: ``r = phi m`` with the regressor ``phi = J_t^T (a_ee - g)`` (n).

:class:`PayloadIdentifier` estimates ``m`` by recursive least squares with exponential
forgetting ``lambda`` (default 0.995 per sample: a memory of ~200 samples, 0.2 s at 1 kHz):

    S_k = lambda S_{k-1} + phi^T phi,   m_k = m_{k-1} + phi^T (r - phi m_{k-1}) / S_k,

and reports a confidence: the standard error ``sigma_m = sqrt(s2 / S_k)`` with ``s2`` the
forgetting-weighted mean squared residual per joint. :meth:`PayloadIdentifier.radius` turns it
into a force-ball radius for re-planning: ``r = max(r_min, |a - g| * k_sigma * sigma_m)``.

A translating base (acceleration ``a_b``, world frame) shifts both sides like a change of
gravity: the arm feels ``g - a_b``, so ``RNEA`` is evaluated with that gravity and
``phi = J_t^T (a_ee + a_b - g)``. Assumptions (documented departures from a full inertial
identification): the payload's rotational inertia and centre-of-mass offset are neglected, and
so are the base's yaw rate and yaw acceleration (they enter as noise).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import mujoco
import numpy as np

from forte.exceptions import InvalidInputError
from forte.model.robot import N_BASE, MobileManipulator
from forte.validation import FloatArray, as_vector


@dataclass
class PayloadIdentifier:
    """Recursive least-squares estimate of the payload mass (see the module docstring).

    Args:
        robot: The robot model without the payload (its tool load included).
        armature: Reflected rotor inertia per arm joint (kg m^2), as in the simulation model.
        forgetting: ``lambda`` in (0, 1].
        prior_mass: Initial estimate (kg), e.g. the VLM's.
        prior_weight: ``S_0``, how many "unit regressors" the prior is worth.
    """

    robot: MobileManipulator
    armature: FloatArray | float = 0.0
    forgetting: float = 0.995
    prior_mass: float = 0.0
    prior_weight: float = 1e-3
    mass: float = field(init=False)
    information: float = field(init=False)
    _residual_power: float = field(init=False, default=0.0)
    _weight: float = field(init=False, default=0.0)
    samples: int = field(init=False, default=0)

    def __post_init__(self) -> None:
        if not 0.0 < self.forgetting <= 1.0:
            raise InvalidInputError(f"forgetting: expected 0 < lambda <= 1, got {self.forgetting}")
        self.armature = np.broadcast_to(np.asarray(self.armature, dtype=float), (self.robot.n_arm,)).copy()
        self.mass = float(self.prior_mass)
        self.information = float(self.prior_weight)

    def regressor(self, q: FloatArray, dq_a: FloatArray, ddq_a: FloatArray, base_acc: FloatArray | None = None
                  ) -> FloatArray:
        """``phi = J_t^T (a_ee + a_b - g)`` at whole-body ``q`` with arm velocity and acceleration."""
        J = self.robot.arm_jacobian(q)
        a_ee = J @ ddq_a + self._jacobian_rate(q, dq_a) @ dq_a
        return J.T @ (a_ee + _base_translation(base_acc) - np.array([0.0, 0.0, -self.robot.gravity]))

    def update(self, q: FloatArray, dq_a: FloatArray, ddq_a: FloatArray, tau_measured: FloatArray,
               base_acc: FloatArray | None = None) -> float:
        """Add one sample (whole-body ``q``; arm ``dq``, ``ddq``, measured torque; base ``(a_x, a_y,
        yaw'')`` in the world frame, default at rest); returns ``m``."""
        q = self.robot.check_configuration(q)
        n = self.robot.n_arm
        dq_a, ddq_a = as_vector(dq_a, "dq_a", n), as_vector(ddq_a, "ddq_a", n)
        model = self._rnea(q, dq_a, ddq_a, _base_translation(base_acc)) + self.armature * ddq_a
        residual = as_vector(tau_measured, "tau_measured", n) - model
        return self.add(residual, self.regressor(q, dq_a, ddq_a, base_acc))

    def add(self, residual: FloatArray, phi: FloatArray) -> float:
        """Add one sample given its torque residual ``r`` and regressor ``phi`` (``r = phi m``)."""
        n = self.robot.n_arm
        lam = self.forgetting
        self.information = lam * self.information + float(phi @ phi)
        error = residual - phi * self.mass
        self.mass += float(phi @ error) / self.information
        self._residual_power = lam * self._residual_power + float(error @ error) / n
        self._weight = lam * self._weight + 1.0
        self.samples += 1
        return self.mass

    @property
    def sigma(self) -> float:
        """Standard error of the estimate (kg)."""
        if self._weight == 0.0:
            return float("inf")
        return float(np.sqrt(self._residual_power / self._weight / self.information))

    def radius(self, acceleration: FloatArray, r_min: float = 10.0, k_sigma: float = 3.0) -> FloatArray:
        """Force-ball radii ``max(r_min, |a_k - g| k_sigma sigma_m)`` for end-effector accelerations (N x 3)."""
        acc = np.atleast_2d(np.asarray(acceleration, dtype=float))
        scale = np.linalg.norm(acc - np.array([0.0, 0.0, -self.robot.gravity]), axis=1)
        return np.maximum(r_min, scale * k_sigma * self.sigma)

    def _rnea(self, q: FloatArray, dq_a: FloatArray, ddq_a: FloatArray, a_b: FloatArray) -> FloatArray:
        """Arm RNEA with the gravity the arm feels on an accelerating base, ``g - a_b``."""
        if not np.any(a_b):
            return self.robot.rnea(q[N_BASE:], dq_a, ddq_a)
        model = self.robot.model
        saved = model.gravity.linear.copy()
        c, s = np.cos(q[2]), np.sin(q[2])
        felt = np.array([0.0, 0.0, -self.robot.gravity]) - a_b
        model.gravity.linear = np.array([c * felt[0] + s * felt[1], -s * felt[0] + c * felt[1], felt[2]])
        try:
            return self.robot.rnea(q[N_BASE:], dq_a, ddq_a)
        finally:
            model.gravity.linear = saved

    def _jacobian_rate(self, q: FloatArray, dq_a: FloatArray, h: float = 1e-6) -> FloatArray:
        """``dJ_t/dt`` along ``dq`` by a central difference of the Jacobian."""
        step = np.concatenate([np.zeros(N_BASE), dq_a]) * h
        return (self.robot.arm_jacobian(q + step) - self.robot.arm_jacobian(q - step)) / (2 * h)


def _base_translation(base_acc: FloatArray | None) -> FloatArray:
    """World-frame translational base acceleration ``(a_x, a_y, 0)`` (yaw acceleration dropped)."""
    if base_acc is None:
        return np.zeros(3)
    a = np.asarray(base_acc, dtype=float)
    return np.array([a[0], a[1], 0.0])


class WholeBodyTorqueModel:
    """Residual and regressor from a MuJoCo model of the robot *without* the payload.

    ``mj_inverse`` of the whole body (base joints included) gives the arm torques the robot and
    its tool need for the measured ``qpos, qvel, qacc``, with every base effect (translation,
    yaw rate and yaw acceleration) exact; the end-effector acceleration is
    ``a_ee = J qacc + dJ/dt qvel`` (MuJoCo's site Jacobian and its time derivative). Then
    ``r = tau_measured - tau_model`` and ``phi = J_a^T (a_ee - g)``, ``J_a`` the arm columns.
    """

    def __init__(self, sim: Any) -> None:
        from forte.execution.model import build_sim_model

        self.sim = build_sim_model(sim.robot, 0.0, armature=sim.armature, timestep=sim.timestep)
        self.sim.model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONSTRAINT  # limits: not the payload's
        nv = self.sim.model.nv
        self._jac, self._jac_dot = np.zeros((3, nv)), np.zeros((3, nv))
        self._gravity = np.array([0.0, 0.0, -sim.robot.gravity])

    def __call__(self, qpos: FloatArray, qvel: FloatArray, qacc: FloatArray, tau_measured: FloatArray
                 ) -> tuple[FloatArray, FloatArray]:
        """``(r, phi)`` for the full MuJoCo state vectors and the measured arm torques."""
        m, d = self.sim.model, self.sim.data
        arm = self.sim.dof_idx[N_BASE:]
        d.qpos[:], d.qvel[:], d.qacc[:] = qpos, qvel, qacc
        mujoco.mj_inverse(m, d)
        mujoco.mj_jacSite(m, d, self._jac, None, self.sim.ee_site)
        mujoco.mj_jacDot(m, d, self._jac_dot, None, d.site_xpos[self.sim.ee_site], m.site_bodyid[self.sim.ee_site])
        a_ee = self._jac @ qacc + self._jac_dot @ qvel
        phi = self._jac[:, arm].T @ (a_ee - self._gravity)
        return np.asarray(tau_measured, dtype=float) - d.qfrc_inverse[arm], phi
