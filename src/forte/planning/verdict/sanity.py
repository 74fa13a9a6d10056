"""Physical sanity checks around a solve: refuse a certainly impossible task force before it,
and record the waypoints where the plan's force ball leaves the RFP after it (plan.json's
``capacity`` block; the plan's verdict, :mod:`forte.planning.verdict.verdict`, judges it).

**The rule before the solve** (:func:`check_force_capacity`): the task force ``f_k`` of every
waypoint is compared with the largest *static* directional capacity along ``f_k / |f_k|``
(alpha = 1, the arm's and tool's own gravity included, torque limits of the task's robot) found
over a fixed sample of configurations: the task's initial, teaching and home configurations and
:data:`SAMPLES` random ones (arm joints uniform within their limits, any yaw; seeded, so the check
is deterministic). The task is refused as infeasible only when ``|f_k|`` exceeds
:data:`FACTOR` times that capacity: the factor leaves room for configurations between the samples
and for arm accelerations that could relieve the joints, so what is refused is far beyond the
robot (``mass: 1500`` typed for 1.5 kg gives about 100 times the capacity), never a borderline task.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from forte.capability.polytope import halfspaces, residual_margins
from forte.exceptions import InfeasibleTaskError
from forte.validation import FloatArray

#: Random configurations sampled (besides the task's own).
SAMPLES = 256
#: A force is refused only beyond this multiple of the best sampled capacity.
FACTOR = 2.0


def sample_configurations(robot: Any, extra: list[Any], samples: int = SAMPLES, seed: int = 0) -> FloatArray:
    """The task's configurations plus ``samples`` random ones within the joint limits."""
    rng = np.random.default_rng(seed)
    lo, hi = np.maximum(robot.lower, -np.pi), np.minimum(robot.upper, np.pi)
    arm = rng.uniform(lo, hi, size=(samples, robot.n_arm))
    base = np.column_stack([np.zeros((samples, 2)), rng.uniform(-np.pi, np.pi, samples)])
    own = [np.asarray(q, dtype=float) for q in extra if q is not None]
    return np.vstack([*own, np.hstack([base, arm])]) if own else np.hstack([base, arm])


def best_static_capacity(robot: Any, directions: FloatArray, configurations: FloatArray) -> FloatArray:
    """For each unit direction (K x 3): the largest static capacity over the configurations (K)."""
    configurations = np.asarray(configurations, dtype=float)
    zeros = np.zeros((len(configurations), robot.n_arm))
    tau = robot.rnea_along(configurations[:, 3:], zeros, zeros)  # static: gravity alone
    plus, minus = residual_margins(tau, robot.torque_limits)
    A_arr, b_arr = halfspaces(robot.arm_jacobians(configurations), plus, minus, alpha=1.0)  # S x m x 3, S x m
    A_arr = np.ascontiguousarray(A_arr)  # the layout one configuration at a time gives: einsum's sums depend on it
    best = np.full(len(directions), -np.inf)
    for start in range(0, len(directions), 256):
        u = directions[start:start + 256]
        proj = np.einsum("smj,kj->skm", A_arr, u)
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(proj > 1e-12, b_arr[:, None, :] / np.where(proj > 1e-12, proj, 1.0), np.inf)
        best[start:start + 256] = ratio.min(axis=-1).max(axis=0)
    return best


def check_force_capacity(task: Any) -> None:
    """Raise :class:`InfeasibleTaskError` (with the numbers) when no configuration can exert the
    task force (the rule in the module docstring); do nothing when it might be feasible."""
    tf = task.force()
    magnitude = np.linalg.norm(tf.f, axis=1)
    live = np.flatnonzero(magnitude > 1e-9)
    if live.size == 0:
        return
    robot = task.robot
    configs = sample_configurations(robot, [task.q_init, task.teaching, robot.home()])
    capacity = best_static_capacity(robot, tf.f[live] / magnitude[live, None], configs)
    ratio = magnitude[live] / np.maximum(capacity, 1e-12)
    worst = int(np.argmax(ratio))
    if magnitude[live][worst] > FACTOR * max(capacity[worst], 0.0):
        k = int(live[worst])
        mass = task.payload.mass if task.force_profile is None else None
        tool = float(getattr(robot, "tool_force_mass", 0.0))  # in the required force with the payload
        load = f" (+ {tool:g} kg end-effector load)" if tool > 0 else ""
        what = f"payload.mass = {mass:g} kg{load} gives" if mass is not None else "the force profile gives"
        raise InfeasibleTaskError(
            f"{task.source or 'task'}: infeasible task: {what} |f| = {magnitude[k]:.1f} N at waypoint {k} "
            f"(t = {tf.t[k]:g} s), but no sampled configuration of robot {robot.name} exerts more than "
            f"{capacity[worst]:.1f} N in that direction (static, torque limits); refused beyond "
            f"{FACTOR:g}x. Is the mass in kg?")


def negative_margins(metrics: dict[str, Any]) -> dict[str, Any]:
    """Where the exact margin d is negative: waypoints, values, the worst (for plan.json and the CLI)."""
    d = np.asarray(metrics["d"], dtype=float)
    bad = np.flatnonzero(d < 0)
    worst = int(np.argmin(d)) if d.size else 0
    return {"sufficient": bool(bad.size == 0), "negative_margin_waypoints": bad.tolist(),
            "negative_margins_n": d[bad].tolist(), "worst_waypoint": worst,
            "worst_margin_n": float(d[worst]) if d.size else None}
