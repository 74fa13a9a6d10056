"""A plan sampled for judging: its waypoints, and the executed motion on a dense grid.

Two kinds of samples, both judged:

- the **waypoints**, with the plan's own backward-difference velocities and accelerations
  (:func:`forte.model.trajectory.backward_differences`): exactly the quantities of the paper's
  metric (``metrics.csv``);
- the **executed motion**: the clamped cubic spline through the waypoints that ``forte simulate``
  hands its controllers (:func:`forte.model.trajectory.clamped_spline`, the default reference),
  on a grid of :data:`SAMPLES_PER_INTERVAL` equal steps per interval (waypoint times included).

Why 8 steps are enough: the spline is a cubic per interval, so its accelerations are linear and
its velocities quadratic between samples and cannot swing between them; the torques, forces and
poses that follow from them vary smoothly. Measured on the shipped tasks' plans (``python
benchmarks/verdict_density.py``): the worst value of every judged quantity on this grid is within
0.0014 of its worst value on a grid 8 times finer, in units of 1 N, 1 x a limit, 1 cm or 0.05 rad.

The task force between waypoints is linear in time, as the simulation's feed-forward
(:func:`forte.execution.control.interpolate_force` does the same).
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np
import pinocchio as pin

from forte.capability.polytope import halfspaces, residual_margins
from forte.force.taskforce import TaskForce
from forte.model.robot import N_BASE, MobileManipulator
from forte.model.trajectory import StartMotion, backward_differences, clamped_spline, joint_limits
from forte.validation import FloatArray, as_array, check_times

#: Dense samples per interval between two waypoints (see the module docstring).
SAMPLES_PER_INTERVAL = 8


class MotionSamples(NamedTuple):
    """The plan's samples, in time order (see the module docstring); ``waypoint[k]`` is the index
    of the sample that carries waypoint ``k`` with the plan's own derivatives.

    Attributes:
        t, q, dq, ddq: times (K) and whole-body positions, velocities, accelerations (K x nq).
        waypoint: sample index of each waypoint (N).
        J: world-frame translational arm Jacobians (K x 3 x n).
        tau_nom: nominal torques RNEA(q_a, dq_a, ddq_a) (K x n).
        A, b: the RFP half-spaces with ``alpha = 1`` (K x 2n x 3, K x 2n).
        ee: world end-effector poses (K x 4 x 4).
        Jw: world-frame angular arm Jacobians (K x 3 x n), for a task that needs a moment
            (:func:`with_angular`); ``None`` otherwise.
    """

    t: FloatArray
    q: FloatArray
    dq: FloatArray
    ddq: FloatArray
    waypoint: np.ndarray
    J: FloatArray
    tau_nom: FloatArray
    A: FloatArray
    b: FloatArray
    ee: FloatArray
    Jw: FloatArray | None = None

    @property
    def task_jacobian(self) -> FloatArray:
        """``J`` (K x 3 x n), or ``[J; J_w]`` (K x 6 x n) once the angular Jacobians are in."""
        return self.J if self.Jw is None else np.concatenate([self.J, self.Jw], axis=1)

    def segment_of(self, i: int) -> int:
        """The waypoint at or before sample ``i``."""
        return int(np.searchsorted(self.waypoint, i, side="right") - 1)


def dense_times(t: FloatArray, per_interval: int = SAMPLES_PER_INTERVAL) -> FloatArray:
    """``per_interval`` equal steps in every interval of ``t`` (the waypoint times included)."""
    t = np.asarray(t, dtype=float)
    if t.size == 1:
        return t.copy()
    s = np.arange(per_interval) / per_interval
    return np.r_[(t[:-1, None] + s[None, :] * np.diff(t)[:, None]).ravel(), t[-1]]


def sample_motion(robot: MobileManipulator, t: Any, q: Any, per_interval: int = SAMPLES_PER_INTERVAL,
                  start: StartMotion | None = None) -> MotionSamples:
    """The plan ``(t, q)`` at its waypoints and along its executed motion (module docstring);
    ``per_interval = 0`` gives the waypoints alone. ``start``: the first waypoint's motion (a
    horizon spliced into a moving plan; the spline then leaves it with that velocity)."""
    t = check_times(t)
    q = as_array(q, "q", (t.size, robot.nq)).copy()
    q[:, 2] = np.unwrap(q[:, 2])  # as the controllers' reference: never turn the long way round
    v, a = backward_differences(q, t, "q", start)
    if per_interval > 0 and t.size > 1:
        ts = dense_times(t, per_interval)
        Qs, Vs, As = clamped_spline(t, q, ts, None if start is None else start.velocity, joint_limits(robot))
        times, Q, V, Acc = np.r_[t, ts], np.vstack([q, Qs]), np.vstack([v, Vs]), np.vstack([a, As])
    else:
        times, Q, V, Acc = t, q, v, a
    order = np.argsort(times, kind="stable")  # a waypoint before the spline sample at its time
    times, Q, V, Acc = times[order], Q[order], V[order], Acc[order]
    waypoint = np.argsort(order)[: t.size]
    J, tau, ee = arm_quantities(robot, Q, V, Acc)
    A, b = halfspaces(J, *residual_margins(tau, robot.torque_limits), alpha=1.0)
    return MotionSamples(times, Q, V, Acc, waypoint, J, tau, A, b, ee)


def arm_quantities(robot: MobileManipulator, Q: FloatArray, V: FloatArray,
                   Acc: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """World translational arm Jacobians, RNEA torques and end-effector poses at many samples:
    :meth:`~forte.model.robot.MobileManipulator.arm_jacobian`, ``rnea`` and ``ee_pose`` without
    their per-call input checks (the samples are checked once; a test compares the two)."""
    model, data, frame = robot.model, robot.data, robot.ee_frame_id
    J, tau, ee = np.empty((len(Q), 3, robot.n_arm)), np.empty((len(Q), robot.n_arm)), np.empty((len(Q), 4, 4))
    for k, (q, v, a) in enumerate(zip(Q, V, Acc, strict=True)):
        qa = np.ascontiguousarray(q[N_BASE:])
        tau[k] = pin.rnea(model, data, qa, np.ascontiguousarray(v[N_BASE:]), np.ascontiguousarray(a[N_BASE:]))
        local = pin.computeFrameJacobian(model, data, qa, frame, pin.LOCAL_WORLD_ALIGNED)[:3]
        base = robot.base_transform(q[:N_BASE])
        J[k] = base[:3, :3] @ local
        ee[k] = base @ data.oMf[frame].homogeneous  # placed by the Jacobian's forward kinematics
    return J, tau, ee


def with_angular(robot: MobileManipulator, samples: MotionSamples) -> MotionSamples:
    """``samples`` with their angular Jacobians :attr:`MotionSamples.Jw` (world frame)."""
    if samples.Jw is not None:
        return samples
    Jw = np.empty_like(samples.J)
    for k, q in enumerate(samples.q):
        local = pin.computeFrameJacobian(robot.model, robot.data, np.ascontiguousarray(q[N_BASE:]),
                                         robot.ee_frame_id, pin.LOCAL_WORLD_ALIGNED)
        Jw[k] = robot.base_transform(q[:N_BASE])[:3, :3] @ local[3:]
    return samples._replace(Jw=Jw)


class SampledForce(NamedTuple):
    """The task force ``f`` (K x 3) and ball radii ``r`` (K) at the samples (times may repeat);
    with a moment (a wrench requirement) also ``m`` (K x 3), the moment ball's radii ``r_m`` (K) and
    the metric's moment scale ``L`` (:mod:`forte.capability.wrench`)."""

    f: FloatArray
    r: FloatArray
    m: FloatArray | None = None
    r_m: FloatArray | None = None
    moment_scale: float = 0.0

    @property
    def requirement(self) -> FloatArray:
        """``f`` (K x 3) for a force alone, ``(f, m)`` (K x 6) for a wrench."""
        return self.f if self.m is None else np.hstack([self.f, self.m])


def force_at(force: TaskForce, times: FloatArray) -> SampledForce:
    """The task force (and ball radius) linear in time at ``times``, held outside its range."""
    def at(x: FloatArray) -> FloatArray:
        if force.t.size == 1:
            return np.repeat(x, times.size, axis=0)
        return np.interp(times, force.t, x) if x.ndim == 1 else \
            np.stack([np.interp(times, force.t, x[:, i]) for i in range(x.shape[1])], axis=1)

    if force.m is None:
        return SampledForce(at(force.f), at(force.r))
    return SampledForce(at(force.f), at(force.r), at(force.m), at(force.r_m), float(force.moment_scale))
