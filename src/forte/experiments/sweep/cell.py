"""Computing the cells of one plan: the function every worker runs (local process or Ray task).

:func:`run_group` is a pure, top-level function of a :class:`~forte.experiments.sweep.spec.PlanGroup`
(it pickles for ``concurrent.futures`` and ``ray.remote``): it plans once, writes the plan to a
private temporary directory, simulates each requested run from it and returns one
:class:`CellResult` per cell. It writes nothing outside that temporary directory; the driver
stores the results.
"""

from __future__ import annotations

import os
import socket
import tempfile
import time
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from forte.exceptions import ForteError
from forte.execution.run import simulate_plan
from forte.experiments.common import metrics
from forte.experiments.sweep.spec import Cell, PlanGroup, Simulation
from forte.io.plandir import write_plan
from forte.planning.planner import Plan, plan
from forte.planning.tasks.tasks import task_from_dict

#: Plan metrics copied into the table (their names there), from :func:`forte.experiments.common.metrics`.
PLAN_COLUMNS = ("min_d", "min_capacity_margin", "min_capacity_minus_force", "mean_capacity", "min_capacity",
                "mean_manipulability", "min_manipulability", "max_torque_ratio", "max_torque_ratio_with_force",
                "waypoints_with_d_negative", "first_time_below_force", "first_time_below_band")


class CellResult(NamedTuple):
    """A finished cell: its id, its table row and how long it took where (not in the table)."""

    cell_id: str
    row: dict[str, Any]
    timing: dict[str, Any]


def one_line(exc: BaseException) -> str:
    return " ".join(str(exc).split()) or type(exc).__name__


def _identity(cell: Cell, waypoints: int) -> dict[str, Any]:
    return {"cell_id": cell.id, "task": cell.task, "task_file": cell.task_file, "waypoints": waypoints,
            "method": cell.method, "mass_kg": cell.mass, "run": cell.run, "trial": cell.trial,
            "true_mass_kg": cell.true_mass}


def plan_columns(res: Plan) -> dict[str, Any]:
    """The plan's status and metrics (the deterministic ones: no solve time)."""
    m = metrics(res)
    return {"plan_status": m["status"], "verdict_failed": m["verdict_failed"], "solver_status": m["solver_status"],
            **{k: m[k] for k in PLAN_COLUMNS}}


def simulate_cell(cell: Cell, plan_dir: Path | None, sim: Simulation | None) -> dict[str, Any]:
    """The simulation columns of ``cell`` (empty for plan-only cells)."""
    if sim is None or cell.run == "plan-only":
        return {}
    if plan_dir is None:
        return {"sim_verdict": "not simulated", "sim_reason": "planning failed (no trajectory)"}
    try:
        r = simulate_plan(plan_dir, cell.true_mass, hold=sim.hold, write=False, stop_on_failure=sim.stop_on_failure)
    except ForteError as exc:
        return {"sim_verdict": "error", "error": one_line(exc)}
    return {"sim_verdict": "success" if r.success else "failure", "sim_reason": r.reason,
            "sim_failure_time_s": r.failure_time, "sim_max_ee_error_m": r.summary.get("max_ee_error_m"),
            "sim_max_torque_ratio": float(np.max(r.summary.get("max_torque_ratio", [0.0])))}


def run_group(group: PlanGroup) -> list[CellResult]:
    """Plan ``group`` once and compute each of its cells (see the module docstring).

    A plan or simulation that raises :class:`~forte.exceptions.ForteError` (an infeasible pose,
    a model problem) gives rows with status ``error`` and its message; any other exception is a
    bug and propagates.
    """
    worker = f"{socket.gethostname()}:{os.getpid()}"
    start = time.perf_counter()
    try:
        task = task_from_dict(group.task_data, Path(group.task_path), mass=group.mass, waypoints=group.waypoints)
        res = plan(task, group.method)
    except ForteError as exc:
        spent = time.perf_counter() - start
        return [CellResult(c.id, {**_identity(c, group.n), "plan_status": "error", "error": one_line(exc)},
                           {"plan_s": spent, "sim_s": 0.0, "worker": worker}) for c in group.cells]
    plan_s = time.perf_counter() - start
    head = plan_columns(res)
    out = []
    with tempfile.TemporaryDirectory(prefix="forte-sweep-") as tmp:
        plan_dir = write_plan(res, Path(tmp) / "plan", figures=False) if group.simulation and res.solved else None
        for cell in group.cells:
            t0 = time.perf_counter()
            row = {**_identity(cell, group.n), **head,
                   **simulate_cell(cell, plan_dir, group.simulation)}
            out.append(CellResult(cell.id, row, {"plan_s": plan_s, "sim_s": time.perf_counter() - t0,
                                                 "worker": worker}))
    return out
