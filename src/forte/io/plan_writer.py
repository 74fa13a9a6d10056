"""Writing a plan directory (:mod:`forte.io.plandir` says what it holds): :func:`write_plan` for a
planned :class:`~forte.planning.planner.Plan`, :func:`write_plan_dir` for waypoints given by hand
(judged like a plan), both through :func:`fill_plan_dir` into a temporary sibling renamed into
place; :func:`plan_document` is everything plan.json records."""

from __future__ import annotations

import csv
import json
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np

from forte.force.contact import contact_to_dict
from forte.force.payload import Payload
from forte.force.taskforce import TaskForce, payload_force
from forte.io.outputs import GENERATOR, atomic_write, output_lock, replace_directory
from forte.io.plan_format import (
    FORMAT_VERSION,
    GOOD_STATUSES,
    LAST_ITERATE_FILE,
    METRIC_COLUMNS,
    METRICS_FILE,
    MOMENT_COLUMNS,
    PLAN_FILE,
    STABILITY_COLUMNS,
    TRAJECTORY_FILE,
)
from forte.io.records import jsonable, package_versions
from forte.io.robot_file import store_robot
from forte.model.robot import MobileManipulator
from forte.model.scene import Scene
from forte.model.trajectory import trajectory_header
from forte.planning.planner import Plan
from forte.planning.tasks.posture import start_posture
from forte.planning.tasks.weights_section import settings_record, weights_record
from forte.planning.verdict.verdict import judge
from forte.settings import CapabilityParameters
from forte.validation import as_array, check_times


def write_csv(path: Path, header: list[str], rows: np.ndarray) -> None:
    """A CSV of floats written with full precision (``repr``)."""
    with path.open("w", newline="", encoding="utf-8") as fh:
        writer = csv.writer(fh)
        writer.writerow(header)
        for row in rows:
            writer.writerow([repr(float(v)) for v in row])


def holds_success(directory: Path) -> bool:
    """True when ``directory`` holds a feasible plan (or a successful one of format 1-2)."""
    try:
        return json.loads((directory / PLAN_FILE).read_text()).get("status") in GOOD_STATUSES
    except (OSError, ValueError, AttributeError):
        return False


def write_plan(plan: Plan, out: Path, figures: bool = True) -> Path:
    """Write a plan directory atomically; returns where it went (``out`` or ``out.failed``).

    A plan that is not feasible (infeasible, or a failed solve) never replaces a directory that
    holds a feasible one: it goes to ``DIR.failed``.
    """
    out = Path(out)
    with output_lock(out):
        target = out.with_name(out.name + ".failed") if not plan.feasible and holds_success(out) else out
        replace_directory(lambda d: fill_plan_dir(plan, d, figures), target)
    return target


def fill_plan_dir(plan: Plan, directory: Path, figures: bool = True) -> None:
    """Write the files of ``plan`` into the (new, empty) ``directory``."""
    name = TRAJECTORY_FILE if plan.solved else LAST_ITERATE_FILE
    write_csv(directory / name, trajectory_header(plan.robot.n_arm), np.column_stack([plan.t, plan.q]))
    if plan.metrics:
        columns = METRIC_COLUMNS + tuple(c for c in MOMENT_COLUMNS + STABILITY_COLUMNS if c in plan.metrics)
        write_csv(directory / METRICS_FILE, list(columns), np.column_stack([plan.metrics[c] for c in columns]))
    doc = plan_document(plan)
    doc["robot"] = store_robot(plan.robot, directory)
    atomic_write(directory / PLAN_FILE, json.dumps(doc, indent=2) + "\n")
    if figures and plan.metrics:
        from forte.io.figure_worker import draw_plan_figures  # matplotlib only when figures are drawn

        draw_plan_figures(plan, directory)


def write_plan_dir(plan_dir: str | Path, robot: MobileManipulator, t: Any, q: Any, *, mass: float | None = None,
                   force: Any = None, radius: Any = 10.0, method: str = "manual", status: str = "success",
                   extra: dict[str, Any] | None = None, scene: Scene | None = None) -> Path:
    """Write a plan directory for waypoints ``q`` (N x nq) at times ``t`` given by hand (among
    the bodies of ``scene``, recorded in plan.json).

    ``force`` (N x 3, world frame) defaults to ``(m + m_tool) (a - g)`` of the end-effector
    waypoints (``m_tool``: the robot's ``tool_force_mass``) when ``mass`` is given
    (:func:`forte.force.taskforce.payload_force`), else to zero. The plan is judged like a
    planned one (:func:`forte.planning.verdict.verdict.judge`, the default ``alpha`` and kinematic
    limits), except tracking: there is no task path to follow.
    """
    times = check_times(t, "t")
    Q = as_array(q, "q", (times.size, robot.nq))
    if force is None and mass:
        positions = np.array([robot.ee_position(qk) for qk in Q])
        # the required force carries the robot's own end-effector load too, as a planned task's does
        tf = payload_force(times, positions, mass + robot.tool_force_mass, radius=radius, gravity=robot.gravity)
    else:
        f = np.zeros((times.size, 3)) if force is None else as_array(force, "force", (times.size, 3))
        tf = TaskForce(times, f, np.array(np.broadcast_to(np.asarray(radius, dtype=float), (times.size,))))
    payload = Payload(mass=float(mass), source="given") if mass else Payload(source="none")
    scene = Scene() if scene is None else scene  # the floor at least: every world has one
    verdict = judge(robot, times, Q, tf, CapabilityParameters().alpha, scene=scene)
    plan = Plan(method=method, robot=robot, t=times, q=Q, force=tf, payload=payload,
                solved=status == "success", status=status, solver=dict(extra or {}), verdict=verdict,
                scene=scene)
    replace_directory(lambda d: fill_plan_dir(plan, d, figures=False), Path(plan_dir))
    return Path(plan_dir)


# -- plan.json --------------------------------------------------------------------------------
def plan_summary(plan: Plan) -> dict[str, float]:
    """The quantities the paper discusses, for one plan."""
    m = plan.metrics
    return {
        "min_d": float(np.min(m["d"])),
        "min_capacity_margin": float(np.min(m["capacity_margin"])),
        "mean_manipulability": float(np.mean(m["manipulability"])),
        "min_manipulability": float(np.min(m["manipulability"])),
        "max_torque_ratio": float(np.max(m["max_torque_ratio"])),
        "max_torque_ratio_with_force": float(np.max(m["max_torque_ratio_with_force"])),
        "waypoints_with_d_negative": int(np.sum(m["d"] < 0)),
    }


def plan_document(plan: Plan) -> dict[str, Any]:
    """Everything ``plan.json`` records (schema version :data:`FORMAT_VERSION`)."""
    task = plan.task
    doc: dict[str, Any] = {"generator": GENERATOR, "format_version": FORMAT_VERSION}
    if task is not None:
        doc["task"] = {"name": task.name, "file": str(task.source) if task.source else None, "mode": task.mode,
                       "waypoints": task.n, "duration_s": float(task.t[-1] - task.t[0]), "definition": task.raw}
    doc |= {"method": plan.method, "status": plan.label, "solver_status": plan.status, "solver": plan.solver}
    if plan.verdict is not None:
        doc["verdict"] = plan.verdict.to_json()
    if task is not None:
        doc |= {"weights": weights_record(task.weights, task.settings), "term_settings": settings_record(task.settings),
                "solver_options": asdict(task.solver),
                "kinematic_limits": asdict(task.limits)}
    doc |= {"robot": plan.robot.describe(), "payload": plan.payload.to_dict()}
    if plan.scene:
        doc["scene"] = plan.scene.describe()
    doc["floor"] = plan.scene.floor  # the floor's height (m), None: no floor (forte simulate builds it)
    if plan.verdict is not None and plan.verdict.clearance is not None:
        doc["clearance"] = plan.verdict.clearance  # the closest approach over the judged samples
    if plan.contact is not None:  # a contact task (forte.force.contact): forte simulate builds the object
        doc["contact"] = contact_to_dict(plan.contact)
    if plan.force is not None:
        given = task is not None and task.force_profile is not None
        # the task's force_model (paper | authors) or contact kind; None for a given profile or a plan made by hand
        model = plan.contact.kind if plan.contact is not None else getattr(task, "force_model", None)
        doc["force"] = {"t": plan.force.t, "f": plan.force.f, "r": plan.force.r, "given_profile": given,
                        "model": None if task is None or given else model}
        if plan.force.has_moment:  # the wrench requirement: moment (N m), r_m = lever r, scale L (m)
            doc["force"] |= {"m": plan.force.m, "lever_m": plan.force.lever, "moment_scale": plan.force.moment_scale}
    if task is not None:
        doc["q_init"] = task.q_init
        doc["controller"] = task.controller
        if (posture := start_posture(task)) is not None:  # poor (near a limit, singular, self-colliding) or not
            doc["start_posture"] = posture.to_json()
    if plan.metrics:
        from forte.planning.verdict.sanity import negative_margins

        doc["summary"] = plan_summary(plan)
        doc["capacity"] = negative_margins(plan.metrics)  # where the force ball leaves the RFP (d < 0)
    doc["versions"] = package_versions()
    return jsonable(doc)


__all__ = ["fill_plan_dir", "holds_success", "plan_document", "plan_summary", "write_csv", "write_plan",
           "write_plan_dir"]
