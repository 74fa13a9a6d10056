"""A base that can tip (issue 39): the verdict's ``tipover`` requirement against MuJoCo's floor base.

Two tasks on the tip-over example's platform (``examples/tasks/tipover.yaml``: support polygon
0.45 m x 0.40 m, the arm mounted 0.2575 m ahead of its centre, near the front edge):

- ``tipover``: carry the payload 1.2 m forward in 2.5 s and brake (the example task);
- ``lift``: the paper's lift (``examples/tasks/lift.yaml``), the base free to move.

each with growing payloads (:data:`PAYLOADS`), on a ``light`` base (the example's 40 kg besides
the arm) planned by forte with and without the ``tipover`` term, and a ``heavy`` one
(:data:`HEAVY_KG` on the same footprint) without it (:data:`CASES`). Every plan is judged by the
verdict (its ``tipover`` requirement: the whole robot's zero-moment point inside the support
polygon at every waypoint and spline sample) and run in MuJoCo with the base on the floor
(``forte simulate --base-model floor``, :mod:`forte.execution.floor_base`: it tips when its loaded
contacts shrink to an edge). The confusion table counts the verdict's "tips" (``tipover``
failed) against MuJoCo's "tipped".

**Base mode** (:data:`MODE_TASKS`): the tip-over task on the heavy base and the scene task
``around-the-crate`` (the base drives around a crate), on a differential base, planned twice: for
the differential base (the NLP's lateral rows) and for a holonomic one, whose motion is then judged
as the differential base's (``base_mode``: no sideways velocity) and run on the differential floor
base, whose wheels cannot slide it sideways. MuJoCo's outcome is whether the base stays on its
planned path (``off path``: 0.1 m, :class:`~forte.execution.base_events.BaseThresholds`).
"""

from __future__ import annotations

import json
import tempfile
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from forte.execution.control import interpolate_plan
from forte.execution.run import simulate_plan
from forte.experiments.common import Log, check_format, quiet, save, task_path, write_doc
from forte.io.figures import pyplot
from forte.io.outputs import GENERATOR, replace_directory
from forte.io.plandir import FORMAT_VERSION, write_plan
from forte.io.records import package_versions
from forte.model.base_support import BaseSupport
from forte.model.robot import robot_from_description
from forte.model.stability import tipover_margin
from forte.planning.planner import plan
from forte.planning.tasks.tasks import Task, load_task
from forte.planning.verdict.verdict import judge_plan

#: Payloads (kg) per task; ``--quick`` runs the last only (the one nearest to tipping).
PAYLOADS: dict[str, tuple[float, ...]] = {"tipover": (2.0, 3.0, 4.0), "lift": (2.7, 4.0)}
#: (base, tip-over term) of each payload: the heavy base is far from tipping, planned without the term only.
CASES: tuple[tuple[str, bool], ...] = (("light", False), ("light", True), ("heavy", False))
#: The heavy base's mass (kg, besides the arm) on the light base's footprint.
HEAVY_KG = 120.0
#: The base-mode cases (module docstring): task and payload (kg, None: the task's).
MODE_TASKS: tuple[tuple[str, float | None], ...] = (("tipover", 3.0), ("around-the-crate", None))
#: Sampling step (s) of the reference whose ZMP margin the table reports: the controller's.
STEP = 1e-3
#: The tip-over term's settings of the example task.
TERM = {"tipover": {"margin": 0.02}}


def base_task(name: str, mass: float | None, base: str, term: bool) -> Task:
    """The ``name`` task carrying ``mass`` kg on the example's light or heavy base, with or without
    the tip-over term (module docstring)."""
    light = load_task(task_path("tipover")).robot.base_support
    support = light if base == "light" else BaseSupport(light.footprint, HEAVY_KG, light.com, f"{HEAVY_KG:g} kg")
    task = load_task(task_path(name), mass=mass)
    task = replace(task, robot=robot_from_description({**task.robot.describe(), "base_support": support}))
    terms = {k: v for k, v in task.terms.items() if k != "tipover"}
    return replace(task, terms={**terms, **TERM} if term else terms)


def run_case(tmp: Path, name: str, mass: float, base: str, term: bool, log: Log) -> dict[str, Any]:
    """Plan, judge and run one case; its row of the table."""
    task = base_task(name, mass, base, term)
    res = plan(task)
    margin = np.asarray(res.metrics.get("tipover_margin", [np.nan]), dtype=float)
    directory = write_plan(res, tmp / f"{name}-{mass:g}-{base}-{'term' if term else 'none'}", figures=False)
    run = simulate_plan(directory, base_model="floor", write=False, hold=1.0)
    b = run.summary["base"]
    ref = interpolate_plan(res.t, res.q, np.arange(res.t[0], res.t[-1], STEP), res.force.t, res.force.f)
    tracked = tipover_margin(task.robot, ref.q, ref.dq, ref.ddq, ref.f)
    row = {"task": name, "payload_kg": mass, "base": base, "base_kg": task.robot.base_support.mass,
           "tipover_term": term, "verdict": res.label, "failed": list(res.verdict.failed),
           "verdict_tips": "tipover" in res.verdict.failed, "min_margin_m": float(np.nanmin(margin)),
           "reference_min_margin_m": float(tracked.min()), "reference_outside_s": float(STEP * np.sum(tracked < 0)),
           "reference_first_outside_s": float(ref.t[np.argmax(tracked < 0)]) if np.any(tracked < 0) else None,
           "mujoco_tipped": b["tipped_at"] is not None, "tipped_at_s": b["tipped_at"],
           "run": "ok" if run.success else f"{run.reason} at {run.failure_time:.2f} s",
           "max_pitch_rad": b["max_pitch_rad"], "max_roll_rad": b["max_roll_rad"],
           "lift_offs": b["lift_off_count"], "max_path_error_m": b["max_path_error_m"]}
    row["agrees"] = row["verdict_tips"] == row["mujoco_tipped"]
    log(f"{name} {mass:g} kg {base} {'with' if term else 'without'} term: verdict {res.label} "
        f"(tips: {row['verdict_tips']}, min margin {row['min_margin_m']:.3f} m), MuJoCo {row['run']}")
    return row


def mode_task(name: str, mass: float | None, drive: str) -> Task:
    """A base-mode case's task (the tip-over task on the heavy base) with the base ``drive``."""
    task = base_task(name, mass, "heavy", False) if name == "tipover" else load_task(task_path(name), mass=mass)
    return replace(task, robot=robot_from_description({**task.robot.describe(), "base": drive}))


def run_mode_case(tmp: Path, name: str, mass: float | None, planned_for: str, log: Log) -> dict[str, Any]:
    """Plan one base-mode case for ``planned_for``, judge it as a differential base's, run it on one."""
    diff = mode_task(name, mass, "differential")
    res = plan(diff if planned_for == "differential" else mode_task(name, mass, "holonomic"))
    if planned_for != "differential":  # the same motion, judged and run as the differential base's
        solver = res.solver if "status" in res.solver else None
        res = replace(res, robot=diff.robot, task=diff, verdict=judge_plan(diff, res.q, res.force, solver))
    directory = write_plan(res, tmp / f"mode-{name}-{planned_for}", figures=False)
    run = simulate_plan(directory, base_model="floor", write=False, hold=1.0)
    b = run.summary["base"]
    row = {"task": name, "payload_kg": res.payload.mass, "planned_for": planned_for, "verdict": res.label,
           "failed": list(res.verdict.failed), "verdict_sideways": "base_mode" in res.verdict.failed,
           "mujoco_off_path": run.reason == "off path", "run": "ok" if run.success else
           f"{run.reason} at {run.failure_time:.2f} s", "max_path_error_m": b["max_path_error_m"],
           "max_lateral_speed_m_s": b["max_lateral_speed_m_s"],
           "planned_lateral_m": float(np.abs(lateral_travel(res.q)).max())}
    row["agrees"] = row["verdict_sideways"] == row["mujoco_off_path"]
    log(f"base mode: {name} planned for a {planned_for} base: verdict {res.label}, MuJoCo {row['run']}")
    return row


def lateral_travel(q: Any) -> Any:
    """Sideways travel (m) of the base between consecutive waypoints, along the heading between them."""
    q = np.asarray(q, dtype=float)
    mid = 0.5 * (q[1:, 2] + q[:-1, 2])
    return -np.sin(mid) * np.diff(q[:, 0]) + np.cos(mid) * np.diff(q[:, 1])


def confusion(rows: list[dict[str, Any]]) -> dict[str, int]:
    """Counts of (verdict says tips, MuJoCo tipped)."""
    out = {"tips_tipped": 0, "tips_stood": 0, "stands_tipped": 0, "stands_stood": 0}
    for r in rows:
        out[("tips_" if r["verdict_tips"] else "stands_") + ("tipped" if r["mujoco_tipped"] else "stood")] += 1
    return out


def _figure(rows: list[dict[str, Any]], directory: Path, fmt: str) -> str:
    """The min tip-over margin of the tracked reference (the verdict's ZMP, every 1 ms) against
    MuJoCo's largest pitch, tipped runs marked."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.0, 3.6))
    for tipped, marker, label in ((False, "o", "MuJoCo: stood"), (True, "x", "MuJoCo: tipped")):
        pts = [(100 * r["reference_min_margin_m"], max(r["max_pitch_rad"], 1e-5)) for r in rows
               if r["mujoco_tipped"] == tipped]
        if pts:
            ax.scatter(*zip(*pts, strict=True), marker=marker, label=label)
    ax.axvline(0, color="k", lw=0.6)
    ax.set_yscale("log")
    ax.set_xlabel("min tip-over margin of the 1 ms reference (cm, < 0: the ZMP leaves the polygon)")
    ax.set_ylabel("MuJoCo: max |pitch| (rad)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return save(fig, directory, "base", fmt)


def summary_lines(doc: dict[str, Any], figure: str) -> list[str]:
    """The README.md of the experiment (every number from ``doc``)."""
    c = doc["confusion"]
    lines = ["# The tip-over verdict against a base on the floor (issue 39)", "",
             "The tip-over example's platform (support polygon 0.45 x 0.40 m, the arm 0.2575 m ahead of its centre) "
             f"with a light ({doc['light_kg']:g} kg) and a heavy ({doc['heavy_kg']:g} kg) base, the `tipover` and "
             "`lift` tasks with growing payloads, planned by forte with and without the tip-over term, judged by the "
             "verdict and run in MuJoCo with the base on its wheels (`forte simulate --base-model floor`). "
             "Generated by `forte experiment base`" + (" --quick." if doc["quick"] else "."), "",
             "| task | payload (kg) | base | tip-over term | verdict | min margin at waypoints (cm) | min margin, "
             "1 ms reference (cm) | ZMP outside (ms) | MuJoCo | max pitch (rad) | lift-offs | agree |",
             "|---" * 12 + "|"]
    for r in doc["rows"]:
        verdict = r["verdict"] + (f" ({', '.join(r['failed'])})" if r["failed"] else "")
        lines.append(f"| {r['task']} | {r['payload_kg']:g} | {r['base']} | {'yes' if r['tipover_term'] else 'no'} | "
                     f"{verdict} | {100 * r['min_margin_m']:.1f} | {100 * r['reference_min_margin_m']:.2f} | "
                     f"{1000 * r['reference_outside_s']:.0f} | {r['run']} | {r['max_pitch_rad']:.4f} | "
                     f"{r['lift_offs']} | {'yes' if r['agrees'] else '**no**'} |")
    lines += ["", "Confusion table (rows: the verdict's `tipover`; columns: MuJoCo):", "",
              "| | MuJoCo tipped | MuJoCo stood |", "|---|---|---|",
              f"| verdict: tips | {c['tips_tipped']} | {c['tips_stood']} |",
              f"| verdict: stands | {c['stands_tipped']} | {c['stands_stood']} |", "",
              f"![margin vs pitch]({figure})", "", *_disagreements(doc["rows"]),
              "A run tips when the contacts that carry load (normal force > 1 N) no longer span an area for 20 ms "
              "(the base stands on an edge of its polygon) or its roll or pitch passes 0.1 rad "
              "(`forte.execution.base_events`). A single contact lifting while three carry is a lift-off, "
              "counted, not a tip; a run stops 0.25 s after it tips (its pitch then about 0.01 rad and growing). "
              "Other failures of a run (torque, tracking) are shown but do not enter the table.",
              "", *_mode_lines(doc)]
    return lines


def _mode_lines(doc: dict[str, Any]) -> list[str]:
    """The base-mode table: the verdict's ``base_mode`` against the differential floor base."""
    rows = doc.get("base_mode_rows") or []
    if not rows:
        return []
    a = doc["base_mode_agreement"]
    lines = ["## Base mode on a differential base", "",
             "Planned for a differential base, or for a holonomic one and judged and run as the differential "
             "base's (its wheels cannot slide it sideways); MuJoCo: does the base stay within 0.1 m of its path.", "",
             "| task | payload (kg) | planned for | verdict | largest planned sideways step (mm) | MuJoCo | max path "
             "error (m) | max sideways speed (m/s) | agree |", "|---" * 9 + "|"]
    for r in rows:
        verdict = r["verdict"] + (f" ({', '.join(r['failed'])})" if r["failed"] else "")
        lines.append(f"| {r['task']} | {r['payload_kg']:g} | {r['planned_for']} | {verdict} | "
                     f"{1000 * r['planned_lateral_m']:.1f} | {r['run']} | {r['max_path_error_m']:.3f} | "
                     f"{r['max_lateral_speed_m_s']:.4f} | {'yes' if r['agrees'] else '**no**'} |")
    lines += ["", f"The verdict's `base_mode` and MuJoCo agree on {a['agree']} of {a['plans']} plans.", ""]
    for r in rows:
        if r["agrees"]:
            continue
        case = f"**{r['task']}, planned for a {r['planned_for']} base**"
        if r["verdict_sideways"]:
            lines += [f"{case}: the plan moves the base up to {1000 * r['planned_lateral_m']:.1f} mm sideways between "
                      "two waypoints, which the verdict's tolerance (1 mm/s at the waypoints, 1 cm/s between) "
                      f"refuses; the wheels cannot, and the base ends up to {r['max_path_error_m']:.3f} m off its "
                      "path in MuJoCo, inside the run's 0.1 m. The verdict is the stricter of the two.", ""]
        else:
            lines += [f"{case}: the verdict passes `base_mode`, yet MuJoCo's base left its path ({r['run']}, "
                      f"{r['max_path_error_m']:.3f} m).", ""]
    return lines


def _disagreements(rows: list[dict[str, Any]]) -> list[str]:
    """One paragraph per row where the verdict and MuJoCo disagree, with the numbers that say why."""
    lines = []
    for r in rows:
        if r["agrees"]:
            continue
        term = "with" if r["tipover_term"] else "without"
        case = f"{r['task']}, {r['payload_kg']:g} kg, {r['base']} base, {term} term"
        if r["verdict_tips"]:
            first = r["reference_first_outside_s"]
            lines += [f"**{case}**: the verdict fails `tipover` because the zero-moment point of the tracked reference "
                      f"leaves the polygon by {-1000 * r['reference_min_margin_m']:.1f} mm for "
                      f"{1000 * r['reference_outside_s']:.0f} ms (first at t = {first:.3f} s); MuJoCo's base pitched "
                      f"at most {r['max_pitch_rad']:.4f} rad and stood. The verdict is instantaneous: a ZMP outside "
                      "for a few milliseconds gives the base too little angular impulse to rotate off its contacts, "
                      "so there the requirement is conservative.", ""]
        else:
            lines += [f"**{case}**: the verdict keeps the ZMP inside (min "
                      f"{100 * r['reference_min_margin_m']:.2f} cm on the reference) but MuJoCo's base tipped at "
                      f"{r['tipped_at_s']:.3f} s ({r['run']}).", ""]
    return lines


def run_base(out: str | Path, waypoints: int | None = None, log: Log = quiet, fmt: str = "png", quick: bool = False,
             **_: Any) -> dict[str, Any]:
    """Run the experiment (module docstring) and write ``summary.json``, ``README.md`` and the figure
    (plan directories in a temporary folder, not kept). ``quick``: each task's heaviest payload, and the
    first base-mode task only."""
    out, fmt = Path(out), check_format(fmt)
    payloads = {k: v[-1:] if quick else v for k, v in PAYLOADS.items()}

    def build(tmp: Path) -> None:
        with tempfile.TemporaryDirectory() as plans:
            rows = [run_case(Path(plans), name, mass, base, term, log) for name, masses in payloads.items()
                    for mass in masses for base, term in CASES]
            modes = [run_mode_case(Path(plans), name, mass, drive, log)
                     for name, mass in MODE_TASKS[: 1 if quick else None] for drive in ("differential", "holonomic")]
        doc = {"generator": GENERATOR, "format_version": FORMAT_VERSION, "experiment": "base", "quick": quick,
               "light_kg": load_task(task_path("tipover")).robot.base_support.mass, "heavy_kg": HEAVY_KG,
               "payloads": payloads, "rows": rows, "confusion": confusion(rows),
               "agreement": {"agree": sum(r["agrees"] for r in rows), "plans": len(rows)},
               "base_mode_rows": modes, "base_mode_agreement": {"agree": sum(r["agrees"] for r in modes),
                                                                "plans": len(modes)},
               "versions": package_versions()}
        figure = _figure(rows, tmp, fmt)
        doc["figures"] = [figure]
        write_doc(tmp, doc, summary_lines(doc, figure))

    replace_directory(build, out)
    return json.loads((out / "summary.json").read_text())


__all__ = ["CASES", "HEAVY_KG", "PAYLOADS", "base_task", "confusion", "run_base"]
