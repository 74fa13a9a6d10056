"""Reports: the comparison of several plans (summary.md, summary.csv, comparison.json, its figure).

The plan directory itself (file names, plan.json, the one writer and reader) belongs to
:mod:`forte.io.plandir`; JSON-safe values and package versions to :mod:`forte.io.records`;
figures to :mod:`forte.io.figures`.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path
from typing import Any

from forte.io.outputs import GENERATOR, atomic_write
from forte.io.plandir import COMPARISON_FILE, FORMAT_VERSION, plan_summary
from forte.io.records import jsonable
from forte.planning.planner import Plan


def comparison_rows(results: list[Plan]) -> list[dict[str, Any]]:
    rows = []
    for res in results:
        row: dict[str, Any] = {"method": res.method, "status": res.label,
                               "reason": res.verdict.brief() if res.verdict is not None else ""}
        row.update(plan_summary(res))
        row["solve_time_s"] = res.solver.get("solve_time_s", 0.0)
        row["iterations"] = res.solver.get("iterations", 0)
        rows.append(row)
    return rows


def write_comparison(results: list[Plan], directory: Path, figures: bool = True) -> None:
    """summary.md, summary.csv and the comparison figure (comparison.png, or .pdf/.svg) for every method."""
    rows = comparison_rows(results)
    keys = list(rows[0])
    with (directory / "summary.csv").open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=keys)
        writer.writeheader()
        writer.writerows(rows)
    task = results[0].task
    load = "given force profile" if task.force_profile is not None else f"payload {task.payload.mass} kg"
    lines = [f"# {task.name}: comparison ({task.mode}, {task.n} waypoints, {load})", "",
             "| method | verdict | why | min d (N) | min capacity − (\\|f\\| + r) (N) | mean manipulability | "
             "max torque ratio (nominal / with force) | solve (s) |",
             "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['method']} | {r['status']} | {r['reason']} | {r['min_d']:.2f} | "
                     f"{r['min_capacity_margin']:.2f} | "
                     f"{r['mean_manipulability']:.4f} | {r['max_torque_ratio']:.2f} / "
                     f"{r['max_torque_ratio_with_force']:.2f} | {r['solve_time_s']:.2f} |")
    (directory / "summary.md").write_text("\n".join(lines) + "\n")
    atomic_write(directory / COMPARISON_FILE, json.dumps(jsonable(
        {"generator": GENERATOR, "format_version": FORMAT_VERSION, "task": task.name, "methods": rows}), indent=2))
    if figures:
        from forte.io.figures import figure_path, plot_comparison

        plot_comparison(results, figure_path(directory, "comparison"))
