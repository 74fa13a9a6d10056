"""Low-level controllers of the mobile manipulator (paper, Section 3.1) and the reference they track.

Arm (torque interface), joint impedance with the desired inertia equal to the arm inertia::

    tau_a = M_a(q_a) ddq_{a,d} + C_a(q_a, dq_a) dq_a + g(q_a) + K_a e_a + D_a de_a + tau_F,
    e_a = q_{a,d} - q_a,   de_a = dq_{a,d} - dq_a,   tau_F = J_v(q)^T f_d,
    tau_{a,i} <- sat(tau_{a,i}, -tau_{i,max}, tau_{i,max}).

``M ddq_d + C dq + g`` is Pinocchio's ``rnea(q_a, dq_a, ddq_{a,d})`` on the robot's nominal model
(tool included, payload excluded: the payload enters through ``tau_F``, as in the planner) plus
``diag(armature) ddq_{a,d}``: ``M_a`` is the rigid-body inertia plus the joints' reflected rotor
inertia (``armature``, the simulated arm's, see :mod:`forte.execution.model`).

Sampled-data stability. The law runs at 1 kHz with ``D_a de`` evaluated once per step, so besides
the continuous-time condition (``K_a, D_a > 0``) the discrete loop needs, roughly,
``dt * max eig(M_a^-1 D_a) < 2``. With Franka's wrist damping (30/25/15 Nm s/rad) and a rigid-body
``M_a`` *without* rotor inertia this fails near wrist alignments: at ``q6 -> pi`` the mode
``q5 = -q7`` only moves link 6 (0.007 kg m^2, ``dt eig = 3.3``), at ``q2 -> 0`` the mode
``q1 = -q3`` only moves link 2. :func:`sampled_loop_spectral_radius` computes the exact
spectral radius of the linearised loop; with the rotor inertia of a geared joint (0.1 kg m^2)
it stays below 1 (0.9966 along the quintic lift, 2.36 there without it).
``J_v`` is the world-frame translational Jacobian of the end effector at the *simulated* state and
``f_d`` the plan's desired task force (for a payload: ``m (a - g)``, the force the arm exerts on it).
When the plan requires a moment (a payload whose centre of mass is off the hand), the feedforward
is the full wrench's, ``tau_F = J6(q)^T (f_d, m_d)`` with ``J6 = [J_v; J_w]`` (:attr:`Reference.m`).

Base (velocity interface), admittance::

    tau_b = K_b e_b - D_b (dq_b - s dq_{b,d}),    M_b dv + B_b v = tau_b,
    v_cmd = v + s dq_{b,d},

integrated with explicit Euler at the control rate and sent to the base velocity actuators
(see :mod:`forte.execution.model`). With ``s = 0`` (``base_feedforward=False``) this is exactly the
paper's law; the default ``s = 1`` adds the planned base velocity as feedforward, which removes
the ramp-following lag ``(B_b + D_b) / K_b * v_d`` of the pure admittance (3 cm at 0.1 m/s with the
default gains). Errors are taken in the world coordinates ``q_b = [x, y, yaw]`` of the base
joints (equivalent for a holonomic base), yaw wrapped to (-pi, pi].

If the commanded base follows ``v_cmd`` exactly, the error obeys
``M_b de'' + (B_b + D_b) de' + K_b e = 0``; the defaults are critically damped per axis
(``B_b + D_b = 2 sqrt(K_b M_b)``, natural frequency 6.3 rad/s).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from forte.exceptions import InvalidInputError
from forte.execution.base_coupling import BaseCoupling
from forte.model.robot import N_BASE, MobileManipulator
from forte.model.trajectory import clamped_spline
from forte.validation import FloatArray, as_array, as_vector, check_times

#: Franka's joint-impedance example gains (Nm/rad, Nm s/rad): stiff shoulder, soft wrist.
DEFAULT_K_A = (600.0, 600.0, 600.0, 600.0, 250.0, 150.0, 50.0)
DEFAULT_D_A = (50.0, 50.0, 50.0, 50.0, 30.0, 25.0, 15.0)


@dataclass(frozen=True)
class ControlGains:
    """Controller gains (diagonal matrices given by their diagonals).

    Attributes:
        K_a, D_a: Arm joint stiffness (Nm/rad) and damping (Nm s/rad); one entry per arm joint.
            Defaults: Franka's impedance example for the 7-joint Panda,
            diag(600,600,600,600,250,150,50) and diag(50,50,50,50,30,25,15) (with
            ``M_d = M_a`` the wrist is close to critical); for other arms see
            :func:`forte.execution.gains.default_gains`.
        M_b, B_b: Base admittance virtual mass (kg, kg m^2) and damping (N s/m, Nm s/rad).
        K_b, D_b: Base stiffness (N/m, Nm/rad) and damping on the measured base velocity.
        base_feedforward: Add the planned base velocity ``dq_{b,d}`` (see module docstring).
        force_feedforward: Add ``tau_F = J_v^T f_d``; off, the arm only tracks the joints.
        base_coupling: Feed forward the arm's dynamics on the moving base (the base's velocity and
            planned acceleration in the arm's inverse dynamics, :mod:`forte.execution.base_coupling`);
            off (default): the paper's ``M_a(q_a) ddq_{a,d} + C_a + g``.
        force_along_reference: a payload's ``f_d = m (p'' - g)`` on the reference's own hand
            acceleration (:mod:`forte.execution.reference_force`); off: the plan's waypoint
            forces, linear in time (they lag the executed spline by about a step).
    """

    K_a: tuple[float, ...] = DEFAULT_K_A
    D_a: tuple[float, ...] = DEFAULT_D_A
    M_b: tuple[float, float, float] = (10.0, 10.0, 2.0)
    B_b: tuple[float, float, float] = (100.0, 100.0, 20.0)
    K_b: tuple[float, float, float] = (400.0, 400.0, 80.0)
    D_b: tuple[float, float, float] = (26.0, 26.0, 5.3)
    base_feedforward: bool = True
    force_feedforward: bool = True
    base_coupling: bool = False
    force_along_reference: bool = True

    def check(self, n_arm: int) -> None:
        """Validate sizes and signs (``InvalidInputError`` naming the gain)."""
        for name, size in (("K_a", n_arm), ("D_a", n_arm), ("M_b", 3), ("B_b", 3), ("K_b", 3), ("D_b", 3)):
            values = as_vector(getattr(self, name), f"gains.{name}", size)
            if np.any(values < 0) or (name == "M_b" and np.any(values <= 0)):
                raise InvalidInputError(f"gains.{name}: expected non-negative values (M_b > 0), got {values}")


@dataclass
class ArmCommand:
    """One arm control step: saturated torque, the unsaturated one and the saturation flags."""

    tau: FloatArray
    tau_raw: FloatArray
    saturated: FloatArray


class ArmImpedance:
    """Joint impedance control of the arm with task-force feedforward (paper Eq. for ``tau_a``)."""

    def __init__(self, robot: MobileManipulator, gains: ControlGains, armature: Any = 0.0) -> None:
        gains.check(robot.n_arm)
        self.robot = robot
        self.armature = np.array(np.broadcast_to(np.asarray(armature, dtype=float), (robot.n_arm,)))
        self.K = np.asarray(gains.K_a, dtype=float)
        self.D = np.asarray(gains.D_a, dtype=float)
        self.use_force = gains.force_feedforward
        self.coupling = BaseCoupling(robot) if gains.base_coupling and robot.base != "fixed" else None
        self.tau_max = np.asarray(robot.torque_limits, dtype=float)

    def command(
        self,
        q: FloatArray, dq: FloatArray,
        q_d: FloatArray, dq_d: FloatArray, ddq_d: FloatArray,
        J_v: FloatArray, f_d: FloatArray, base: tuple[FloatArray, FloatArray, FloatArray] | None = None,
    ) -> ArmCommand:
        """Torque for arm state ``(q, dq)``, reference ``(q_d, dq_d, ddq_d)``, Jacobian and force (or
        ``J6`` (6 x n) and the wrench ``(f_d, m_d)``); ``base``: the base's measured pose and
        velocity and planned acceleration, used with ``base_coupling``."""
        if self.coupling is not None and base is not None:
            q_b, dq_b, ddq_bd = base
            dynamics = self.coupling.torques(np.r_[q_b, q], np.r_[dq_b, dq], np.r_[ddq_bd, ddq_d])
        else:
            dynamics = self.robot.rnea(q, dq, ddq_d)
        tau = dynamics + self.armature * ddq_d + self.K * (q_d - q) + self.D * (dq_d - dq)
        if self.use_force:
            tau = tau + J_v.T @ f_d
        sat = np.abs(tau) > self.tau_max
        return ArmCommand(np.clip(tau, -self.tau_max, self.tau_max), tau, sat)


def sampled_loop_spectral_radius(M: Any, K: Any, D: Any, dt: float) -> float:
    """Spectral radius of the arm's error dynamics under the sampled impedance law.

    Linearised about the reference (``M ddq_d + C + g`` cancel the model), the joint error obeys
    ``M de'' = -K e - D de'`` with the torque held over each step ``dt`` and semi-implicit Euler
    (MuJoCo's integration of an explicit actuator force): ``de+ = de - dt M^-1 (K e + D de)``,
    ``e+ = e + dt de+``. Below 1: the 1 kHz loop is stable; above 1: errors grow by that factor
    per step. ``M`` is the full joint inertia (incl. rotor inertia), ``K``/``D`` diagonals or
    matrices.
    """
    M = np.asarray(M, dtype=float)
    n = M.shape[0]
    K = np.diag(np.asarray(K, dtype=float)) if np.ndim(K) == 1 else np.asarray(K, dtype=float)
    D = np.diag(np.asarray(D, dtype=float)) if np.ndim(D) == 1 else np.asarray(D, dtype=float)
    A_k = np.linalg.solve(M, K)
    A_d = np.linalg.solve(M, D)
    eye = np.eye(n)
    step = np.block([[eye - dt * dt * A_k, dt * (eye - dt * A_d)], [-dt * A_k, eye - dt * A_d]])
    return float(np.abs(np.linalg.eigvals(step)).max())


class BaseAdmittance:
    """Admittance ``M_b dv + B_b v = K_b e_b - D_b dq_b`` producing a base velocity command."""

    def __init__(self, gains: ControlGains, dt: float) -> None:
        gains.check(len(gains.K_a))
        self.M = np.asarray(gains.M_b, dtype=float)
        self.B = np.asarray(gains.B_b, dtype=float)
        self.K = np.asarray(gains.K_b, dtype=float)
        self.D = np.asarray(gains.D_b, dtype=float)
        self.ff = 1.0 if gains.base_feedforward else 0.0
        self.dt = float(dt)
        self.v = np.zeros(N_BASE)

    def reset(self) -> None:
        self.v = np.zeros(N_BASE)

    def command(self, q_b: FloatArray, dq_b: FloatArray, q_bd: FloatArray, dq_bd: FloatArray) -> FloatArray:
        """Advance the admittance by one step and return ``v_cmd = [v_x, v_y, omega_z]``."""
        e = q_bd - q_b
        e[2] = (e[2] + np.pi) % (2 * np.pi) - np.pi  # yaw error on the circle
        force = self.K * e - self.D * (dq_b - self.ff * dq_bd)
        self.v = self.v + self.dt * (force - self.B * self.v) / self.M
        return self.v + self.ff * dq_bd


@dataclass(frozen=True)
class Reference:
    """Whole-body reference ``q_d, dq_d, ddq_d`` (T x nq) and task force ``f_d`` (T x 3) at times ``t``,
    with the task moment ``m_d`` (T x 3, world frame, at the end effector) when the plan needs one."""

    t: FloatArray
    q: FloatArray
    dq: FloatArray
    ddq: FloatArray
    f: FloatArray
    m: FloatArray | None = None


def interpolate_plan(
    t_plan: Any, q_plan: Any, times: Any, force_t: Any = None, force: Any = None,
    limits: tuple[Any, Any] | None = None,
) -> Reference:
    """Clamped cubic spline through the plan's waypoints, sampled at ``times``.

    ``q(t)`` is C2 with zero velocity at the first and last waypoint (the plan starts and ends
    at rest); before/after the plan the first/last waypoint is held. The yaw column is unwrapped
    first so the spline never turns the long way round. The task force is interpolated
    linearly in time and held constant outside its time range (zero when none is given).
    """
    tp = check_times(t_plan, "t")
    qp = as_array(q_plan, "q", (tp.size, None)).copy()
    ts = as_array(times, "times", (None,))
    qp[:, 2] = np.unwrap(qp[:, 2])
    q, dq, ddq = clamped_spline(tp, qp, ts, limits=limits)  # a rest at a limit: clamped there
    return Reference(ts, q, dq, ddq, interpolate_force(ts, force_t, force))


def interpolate_force(times: Any, force_t: Any = None, force: Any = None) -> FloatArray:
    """The task force (N x 3 at ``force_t``) linear in time at ``times``, held constant outside
    its time range; zero when none is given."""
    ts = as_array(times, "times", (None,))
    if force is None:
        return np.zeros((ts.size, 3))
    ft = check_times(force_t, "force.t")
    fv = as_array(force, "force.f", (ft.size, 3))
    return np.stack([np.interp(ts, ft, fv[:, i]) for i in range(3)], axis=1)
