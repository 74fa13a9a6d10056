"""Contact-rich tasks (issue 25, items 4 and 5): forte against the baselines, executed with the contact.

The three example tasks (:data:`TASKS`: ``examples/tasks/push-box.yaml``, ``drawer.yaml`` and
``carry-with-partner.yaml``), each planned by forte and the paper's baselines (:data:`ROWS`), with
the force of its physics model (:mod:`forte.force.contact`). Every plan is judged by the verdict
(:mod:`forte.planning.verdict.verdict`: its min capacity margin ``d`` over the force, or wrench, ball) and
executed in MuJoCo with the contact modelled (:mod:`forte.execution.contact_objects`) twice: with
the task's own object, and with the object's resistance raised by the ball's radius ``r`` (the edge
of what the verdict covers): the box's friction ``mu + r / (m g)``, the drawer's friction
``F_c + r``, the carried board's mass ``m + r / g``. The verdict agrees with MuJoCo on a plan when it
is feasible exactly when that second run succeeds.
"""

from __future__ import annotations

import json
import tempfile
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from forte.execution.run import simulate_plan
from forte.experiments.common import Log, check_format, quiet, save, sim_cell, style, task_path, write_doc
from forte.experiments.wrench import unscaled_verdict
from forte.force.contact import Carry, Contact, Drawer, PushBox, contact_to_dict
from forte.io.figures import pyplot
from forte.io.outputs import GENERATOR, replace_directory
from forte.io.plandir import FORMAT_VERSION, write_plan
from forte.io.records import package_versions
from forte.planning.planner import plan
from forte.planning.tasks.tasks import load_task

#: The contact tasks (example task files), in table order.
TASKS: tuple[str, ...] = ("push-box", "drawer", "carry-with-partner")
#: The compared methods.
ROWS: tuple[str, ...] = ("forte", "manipulability", "rfp-radius", "rfp-cone", "quintic")


def stressed(contact: Contact, radius: float, gravity: float) -> Contact:
    """``contact`` with its resistance raised by the ball's radius ``r`` (module docstring)."""
    if isinstance(contact, PushBox):
        return replace(contact, friction=contact.friction + radius / (contact.mass * gravity))
    if isinstance(contact, Drawer):
        return replace(contact, friction=contact.friction + radius)
    assert isinstance(contact, Carry)
    return replace(contact, mass=contact.mass + radius / gravity)


def _simulate(directory: Path, contact: Contact | None = None, mass: float | None = None) -> dict[str, Any]:
    """Run the plan in ``directory`` (with ``contact`` written into its plan.json when given)."""
    if contact is not None:
        path = directory / "plan.json"
        doc = json.loads(path.read_text())
        doc["contact"] = contact_to_dict(contact)
        path.write_text(json.dumps(doc))
    run = simulate_plan(directory, mass, write=False)
    facts = run.summary.get("contact_task", {})
    return {"success": run.success, "reason": run.reason, "failure_time": run.failure_time,
            "max_torque_ratio": float(np.max(run.summary.get("max_torque_ratio", [0.0]))),
            "peak_hand_force_n": facts.get("peak_hand_force_N"), "travel_m": facts.get("travel_m")}


def run_task(tmp: Path, name: str, rows: tuple[str, ...], waypoints: int | None, log: Log) -> list[dict[str, Any]]:
    """Plan, judge and simulate every row of one task."""
    task = load_task(task_path(name), waypoints=waypoints)
    edge = stressed(task.contact, task.radius, task.robot.gravity)
    edge_mass = edge.mass if isinstance(edge, Carry) else None
    out = []
    for row in rows:
        res = plan(task, row)
        directory = write_plan(res, tmp / name / row, figures=False)
        sims = [_simulate(directory), _simulate(directory, edge, edge_mass)]
        f = np.linalg.norm(res.force.f, axis=1)
        facts = {"task": name, "kind": task.contact.kind, "method": row, "verdict": res.label,
                 "failed": list(res.verdict.failed), "min_d_n": float(np.min(res.metrics["d"])),
                 "max_torque_ratio": float(np.max(res.metrics["max_torque_ratio_with_force"])),
                 "peak_model_force_n": float(np.max(f)), "sims": sims,
                 "agrees": res.feasible == sims[-1]["success"]}
        unscaled = unscaled_verdict(task, res)  # alpha = 1: the full torque range, which the run has
        facts |= {"unscaled_verdict": unscaled.label, "unscaled_failed": list(unscaled.failed),
                  "agrees_unscaled": unscaled.feasible == sims[-1]["success"]}
        log(f"contact: {name}, {row}: {facts['verdict']}, min d {facts['min_d_n']:.2f} N, "
            f"sim {'ok' if sims[0]['success'] else 'fail'} / {'ok' if sims[1]['success'] else 'fail'}")
        out.append(facts)
    return out


def _figure(rows: list[dict[str, Any]], directory: Path, fmt: str) -> str:
    plt = pyplot()
    tasks = list(dict.fromkeys(r["task"] for r in rows))
    methods = list(dict.fromkeys(r["method"] for r in rows))
    fig, ax = plt.subplots(figsize=(9, 3.6))
    width = 0.8 / len(methods)
    for i, method in enumerate(methods):
        colour, label = style(method)
        for j, name in enumerate(tasks):
            r = next(x for x in rows if x["task"] == name and x["method"] == method)
            ok = r["sims"][-1]["success"]
            ax.bar(j + (i - (len(methods) - 1) / 2) * width, r["min_d_n"], width, color=colour if ok else "white",
                   edgecolor=colour, hatch=None if ok else "//", label=label if j == 0 else None)
    ax.axhline(0, color="k", lw=0.6)
    ax.set_xticks(range(len(tasks)), tasks)
    ax.set_ylabel("min capacity margin d (N)")
    ax.set_title("filled: MuJoCo run with the resistance raised by r succeeds; hatched: fails", fontsize=9)
    ax.grid(alpha=0.3, axis="y")
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.tight_layout()
    return save(fig, directory, "contact", fmt)


def summary_lines(doc: dict[str, Any], figure: str) -> list[str]:
    """The README.md of the experiment (every number from ``doc``)."""
    lines = ["# Contact-rich tasks: push, drawer, carry with a partner (issue 25)", "",
             "The example tasks `push-box`, `drawer` and `carry-with-partner` (`examples/tasks/`), their force from "
             "physics (`forte.force.contact`), planned by forte and the paper's baselines, judged by the verdict and "
             "run in MuJoCo with the contact modelled (`forte.execution.contact_objects`): with the task's object, "
             f"and with its resistance raised by the ball's radius r = {doc['radius_n']:g} N (box friction "
             "mu + r/(m g), drawer friction F_c + r, board mass m + r/g). Generated by `forte experiment contact`.", "",
             "| task | plan | verdict | min d (N) | max torque ratio | peak model force (N) | MuJoCo | peak measured "
             "hand force (N) | MuJoCo, resistance + r | verdict, alpha = 1 |", "|---" * 10 + "|"]
    for r in doc["rows"]:
        verdict = r["verdict"] + (f" ({', '.join(r['failed'])})" if r["failed"] else "")
        peak = r["sims"][0]["peak_hand_force_n"]
        lines.append(f"| {r['task']} | {r['method']} | {verdict} | {r['min_d_n']:.2f} | {r['max_torque_ratio']:.3f} | "
                     f"{r['peak_model_force_n']:.1f} | {sim_cell(r['sims'][0])} | "
                     f"{'–' if peak is None else f'{peak:.1f}'} | {sim_cell(r['sims'][1])} | {r['unscaled_verdict']} |")
    a, u = doc["agreement"], doc["agreement_unscaled"]
    ok = sum(r["sims"][0]["success"] for r in doc["rows"])
    lines += ["", f"![contact tasks]({figure})", "",
              f"Verdict vs MuJoCo (feasible exactly when the run with the resistance raised by r succeeds): "
              f"{a['agree']} of {a['plans']} plans. Runs with the task's own object that succeed: {ok} of "
              f"{len(doc['rows'])}. The same with `alpha = 1` (the ball inside the full torque range, which the run "
              f"has; the verdict keeps {1 - doc['alpha']:.0%} of it in reserve): {u['agree']} of {u['plans']}.", "",
              "The peak measured hand force includes the impact and breakaway transients at the start of the "
              "motion (the model's force is the sliding force, sampled at the plan's waypoints); the carry's "
              "force is the board's weight and the partner's, applied as forces, so nothing is measured there.",
              ""]
    return lines


def run_contact(out: str | Path, waypoints: int | None = None, log: Log = quiet, fmt: str = "png",
                tasks: tuple[str, ...] = TASKS, rows: tuple[str, ...] = ROWS, **_: Any) -> dict[str, Any]:
    """Run the experiment (module docstring) and write ``summary.json``, ``README.md`` and the figure
    (the plan directories are written to a temporary folder and not kept)."""
    out, fmt = Path(out), check_format(fmt)

    def build(tmp: Path) -> None:
        with tempfile.TemporaryDirectory() as plans:
            results = [r for name in tasks for r in run_task(Path(plans), name, tuple(rows), waypoints, log)]
        first = load_task(task_path(tasks[0]))
        doc = {"generator": GENERATOR, "format_version": FORMAT_VERSION, "experiment": "contact",
               "tasks": list(tasks), "radius_n": first.radius, "rows": results, "alpha": first.settings.alpha,
               "agreement": {"agree": sum(r["agrees"] for r in results), "plans": len(results)},
               "agreement_unscaled": {"agree": sum(r["agrees_unscaled"] for r in results), "plans": len(results)},
               "versions": package_versions()}
        figure = _figure(results, tmp, fmt)
        doc["figures"] = [figure]
        write_doc(tmp, doc, summary_lines(doc, figure))

    replace_directory(build, out)
    return json.loads((out / "summary.json").read_text())


__all__ = ["ROWS", "TASKS", "run_contact"]
