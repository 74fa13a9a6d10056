"""The exact per-waypoint metrics of a plan: the columns of ``metrics.csv``."""

from __future__ import annotations

import numpy as np

from forte.capability.metrics import capability_margin, yoshikawa
from forte.capability.polytope import directional_capacity, inscribed_radius, trajectory_rfp
from forte.capability.wrench import wrench_metrics
from forte.force.taskforce import TaskForce
from forte.model.clearance import clearances
from forte.model.robot import MobileManipulator
from forte.model.scene import Scene
from forte.model.stability import trajectory_tipover_margin
from forte.model.trajectory import StartMotion
from forte.settings import CapabilityParameters
from forte.validation import FloatArray


def evaluate(robot: MobileManipulator, q: FloatArray, t: FloatArray, force: TaskForce,
             params: CapabilityParameters | float = CapabilityParameters(),
             scene: Scene | None = None, start: StartMotion | None = None) -> dict[str, FloatArray]:
    """Exact per-waypoint metrics of a plan (the columns of metrics.csv).

    ``d`` uses the metric's ``alpha``; the directional capacity (along the desired force) and
    the inscribed radius are those of the paper's RFP ``P_r,k`` itself (``alpha = 1``);
    ``clearance`` is the robot's exact signed distance (m) to the nearest body of ``scene`` or its
    floor (:mod:`forte.model.clearance`), ``inf`` without either (no scene given, or ``floor: none``
    and no bodies). With a moment (a wrench requirement)
    ``d``, the capacity and the torque follow it, plus ``mx, my, mz`` (:func:`~forte.capability.wrench.wrench_metrics`).
    A robot that states its base support gets ``tipover_margin`` (m, the ZMP's distance to the
    support polygon's edge, positive inside; :func:`~forte.model.stability.trajectory_tipover_margin`).
    ``start``: the first waypoint's motion (default: at rest, as every plan of a task file).
    """
    alpha = params.alpha if isinstance(params, CapabilityParameters) else float(params)
    rfp = trajectory_rfp(robot, q, t, alpha=1.0, start=start)
    capacity = directional_capacity(rfp.A, rfp.b, force.direction)
    return {
        "t": np.asarray(t, dtype=float),
        "fx": force.f[:, 0], "fy": force.f[:, 1], "fz": force.f[:, 2],
        "radius": force.r,
        "d": capability_margin(rfp.A, alpha * rfp.b, force.f, force.r),  # b scales with alpha
        "directional_capacity": capacity,
        "capacity_margin": capacity - (force.magnitude + force.r),
        "inscribed_radius": inscribed_radius(rfp.A, rfp.b),
        "manipulability": yoshikawa(rfp.J),
        "max_torque_ratio": np.max(np.abs(rfp.tau_nom) / robot.torque_limits, axis=1),
        # nominal torque plus the torque that applies the desired force, tau_nom + J^T f
        "max_torque_ratio_with_force": np.max(
            np.abs(rfp.tau_nom + np.einsum("kij,ki->kj", rfp.J, force.f)) / robot.torque_limits, axis=1),
        "clearance": clearances(robot, scene, q).distance if scene is not None and scene.solid
        else np.full(len(rfp.J), np.inf),
    } | (wrench_metrics(robot, q, t, force, alpha, start) if force.has_moment else {}) | (
        {} if robot.base_support is None else {"tipover_margin": trajectory_tipover_margin(robot, q, t, force,
                                                                                            start)})
