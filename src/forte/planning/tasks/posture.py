"""Start postures that are poor, and the nearest better one with the same end-effector pose.

A trajectory starts where the robot is (``q_1 = q_init``), so a poor start cannot be optimized
away; forte reports it (a warning and a record in plan.json, never a failure) with a posture the
user can paste into ``initial_configuration``.

**Poor** (:func:`assess`), any of:

- *near a joint limit*: an arm joint within :data:`LIMIT_FRACTION` (5 %) of its range from a
  limit, ``min(q_i - lo_i, hi_i - q_i) < 0.05 (hi_i - lo_i)``;
- *near a singularity*: the smallest singular value ``sigma_min`` of the arm's 6 x n world-frame
  Jacobian (linear rows in m/rad, angular rows in rad/rad) below :data:`SINGULAR_SIGMA`. A
  straight elbow, or two wrist axes aligned, takes a direction of motion away: ``sigma_min -> 0``.
  The threshold is half the lowest of the presets' homes (Kinova 0.101; Panda 0.177, UR5 0.245,
  TIAGo 0.211) and below every shipped trajectory example's start (0.177-0.245); elbows within
  0.2-0.3 rad of straight give 0.02-0.04 (UR5, Kinova). ``examples/tasks/hold.yaml``'s
  ``initial_configuration`` (0.022, the arm stretched out) would be poor, but in hold mode the
  start only seeds the solver, so it is not assessed;
- *in self-collision*: two of the arm's URDF collision meshes touch
  (:meth:`forte.model.self_collision.ArmGeometry.contact`).

**The nearest better posture** (:func:`better_posture`): the base stays where it is; the arm is
moved by damped least squares onto the start's end-effector pose ``T`` with a null-space step that
raises ``sigma_min`` and pushes the joints away from their limits, from the start itself and from
a few restarts (the home, the joints' centres, seeded draws); of the results that reach ``T``
within 1e-6 m and 1e-6 rad and are not poor, the one nearest the start (joint-space distance).
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

from forte.model.robot import N_BASE, MobileManipulator
from forte.model.self_collision import arm_geometry
from forte.planning.tasks.ik import pose_error
from forte.validation import FloatArray

#: A joint closer to a limit than this fraction of its range is near it.
LIMIT_FRACTION = 0.05
#: An arm Jacobian whose smallest singular value is below this is near a singularity.
SINGULAR_SIGMA = 0.05
#: Restarts of :func:`better_posture` besides the start, the home and the joints' centres (seeded).
RESTARTS = 12
#: A better posture reaches the start's pose within these (m, rad).
POSE_TOL = 1e-6


class PostureReport(NamedTuple):
    """What is poor about a start posture (empty ``reasons``: nothing) and the better one.

    Attributes:
        reasons: one line each, e.g. ``joint j2s6s200_joint_3 0.02 rad from its lower limit (1 % of its range)``.
        sigma_min: the arm Jacobian's smallest singular value at the start.
        better: the nearest better whole-body configuration (the base unchanged), ``None`` when
            not poor or when none was found.
        better_sigma_min: its ``sigma_min``.
    """

    reasons: tuple[str, ...]
    sigma_min: float
    better: FloatArray | None = None
    better_sigma_min: float | None = None

    @property
    def poor(self) -> bool:
        return bool(self.reasons)

    def warning(self) -> str:
        """One line for the CLI (empty when the posture is not poor)."""
        if not self.poor:
            return ""
        fix = ("; a posture with the same end-effector pose that is not: initial_configuration: "
               f"{_rounded(self.better)}" if self.better is not None else "; no better posture found")
        return f"the start posture is poor: {'; '.join(self.reasons)}{fix}"

    def to_json(self) -> dict[str, Any]:
        return {"poor": self.poor, "reasons": list(self.reasons), "sigma_min": self.sigma_min,
                "better": None if self.better is None else _rounded(self.better),
                "better_sigma_min": self.better_sigma_min,
                "criteria": {"limit_fraction": LIMIT_FRACTION, "singular_sigma": SINGULAR_SIGMA}}


def _rounded(q: FloatArray) -> list[float]:
    return [round(float(v), 6) for v in q]


def sigma_min(robot: MobileManipulator, q: FloatArray) -> float:
    """The smallest singular value of the arm's 6 x n world-frame Jacobian at ``q``."""
    return float(np.linalg.svd(robot.whole_body_jacobian(q)[:, N_BASE:], compute_uv=False).min())


def _reasons(robot: MobileManipulator, q: FloatArray) -> tuple[tuple[str, ...], float]:
    q_a, reasons = q[N_BASE:], []
    span = robot.upper - robot.lower
    for i, name in enumerate(robot.arm_joints or [f"joint {i}" for i in range(robot.n_arm)]):
        low, high = q_a[i] - robot.lower[i], robot.upper[i] - q_a[i]
        gap = min(low, high)
        if np.isfinite(span[i]) and gap < LIMIT_FRACTION * span[i]:
            side = "lower" if low <= high else "upper"
            reasons.append(f"joint {name} {gap:.3g} from its {side} limit ({100 * gap / span[i]:.2g} % of its range)")
    s = sigma_min(robot, q)
    if s < SINGULAR_SIGMA:
        reasons.append(f"near a singularity (smallest singular value of the arm Jacobian {s:.3g} < {SINGULAR_SIGMA})")
    geometry = arm_geometry(robot)
    contact = geometry.contact(q_a) if geometry is not None else None
    if contact is not None:
        reasons.append(f"in self-collision ({contact.first} with {contact.second})")
    return tuple(reasons), s


def _goodness_gradient(robot: MobileManipulator, q: FloatArray) -> FloatArray:
    """Gradient (arm joints) of the worst normalised margin ``min(gap_i / (0.05 span_i),
    sigma_min / SINGULAR_SIGMA)`` (``gap_i``: joint ``i``'s distance to its nearer limit; a margin
    below 1 is poor): the step raises whichever criterion is worst, so the walk does not trade one
    for the other (finite differences on ``sigma_min``)."""
    q_a, span = q[N_BASE:], robot.upper - robot.lower
    low, high = q_a - robot.lower, robot.upper - q_a
    finite = np.isfinite(span)
    margins = np.where(finite, np.minimum(low, high) / (LIMIT_FRACTION * np.where(finite, span, 1.0)), np.inf)
    i = int(np.argmin(margins))
    base = sigma_min(robot, q)
    grad = np.zeros(robot.n_arm)
    if margins[i] <= base / SINGULAR_SIGMA:
        grad[i] = (1.0 if low[i] <= high[i] else -1.0) / (LIMIT_FRACTION * span[i])
        return grad
    h = 1e-6
    for j in range(robot.n_arm):
        step = q.copy()
        step[N_BASE + j] += h
        grad[j] = (sigma_min(robot, step) - base) / (h * SINGULAR_SIGMA)
    return grad


def _walk(robot: MobileManipulator, target: FloatArray, q: FloatArray, nullspace: float,
          iterations: int = 300) -> FloatArray:
    """Damped least squares onto ``target`` (the arm, and the base unless it is fixed), with a
    null-space step of size ``nullspace`` along :func:`_goodness_gradient` (dropped for the last
    third, which converges)."""
    q, first = q.copy(), N_BASE if robot.base == "fixed" else 0
    for it in range(iterations):
        e = pose_error(robot, q, target)
        J = robot.whole_body_jacobian(q)[:, first:]
        J_pinv = J.T @ np.linalg.inv(J @ J.T + 1e-6 * np.eye(6))
        step = J_pinv @ e
        if nullspace and it < 2 * iterations // 3:
            g = np.r_[np.zeros(N_BASE - first), _goodness_gradient(robot, q)]
            step += nullspace * (g - J_pinv @ (J @ g)) / max(1.0, float(np.linalg.norm(g)))
        q[first:] += step
        q[N_BASE:] = np.clip(q[N_BASE:], robot.lower + 1e-6, robot.upper - 1e-6)
        if it >= 2 * iterations // 3 and np.linalg.norm(e) < 1e-12:
            break
    return q


def better_posture(robot: MobileManipulator, q: FloatArray) -> FloatArray | None:
    """The nearest posture to ``q`` with its end-effector pose that is not poor (see the module's
    docstring), or ``None`` when no start reaches one."""
    target = robot.ee_pose(q)
    rng = np.random.default_rng(0)
    centre = (robot.lower + robot.upper) / 2
    lower, upper = np.maximum(robot.lower, centre - np.pi), np.minimum(robot.upper, centre + np.pi)
    arms = [q[N_BASE:], robot.home_arm, centre, *rng.uniform(lower, upper, (RESTARTS, robot.n_arm))]
    best, best_distance = None, np.inf
    for k, arm in enumerate(arms):
        start = np.r_[q[:N_BASE], arm]
        candidate = _walk(robot, target, start, nullspace=0.05 if k == 0 else 0.02)
        err = pose_error(robot, candidate, target)
        if np.linalg.norm(err[:3]) > POSE_TOL or np.linalg.norm(err[3:]) > POSE_TOL:
            continue
        distance = float(np.linalg.norm(candidate - q))
        if distance < best_distance and not _reasons(robot, candidate)[0]:
            best, best_distance = candidate, distance
    return best


def assess(robot: MobileManipulator, q: Any) -> PostureReport:
    """Whether the whole-body configuration ``q`` is a poor start (see the module's docstring),
    with the nearest better posture when it is."""
    q = robot.check_configuration(q, "initial_configuration")
    reasons, s = _reasons(robot, q)
    if not reasons:
        return PostureReport((), s)
    better = better_posture(robot, q)
    return PostureReport(reasons, s, better, None if better is None else sigma_min(robot, better))


#: Reports of recent starts, by robot fingerprint and configuration (the CLI and plan.json share them).
_RECENT: dict[tuple[str, tuple[float, ...]], PostureReport] = {}


def start_posture(task: Any) -> PostureReport | None:
    """:func:`assess` of a task's start (kept for the next call with the same robot and start);
    ``None`` without a task or in hold mode, where the start only seeds the solver."""
    if task is None or task.mode == "hold":
        return None
    key = (task.robot.fingerprint, tuple(map(float, task.q_init)))
    if key not in _RECENT:
        if len(_RECENT) > 16:
            _RECENT.clear()
        _RECENT[key] = assess(task.robot, task.q_init)
    return _RECENT[key]
