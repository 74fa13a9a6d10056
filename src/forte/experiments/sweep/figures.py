"""Summary figures of a sweep, drawn from its table rows (one figure per task and waypoint count).

Three panels against the payload mass, one curve per method: the plan's min capacity −
(|f| + r) (N; below 0 the capacity along f misses the band's upper edge somewhere), its mean
manipulability (m³), and the share of simulated runs with the payload (nominal and mass-error
trials) that succeeded. A task with a force profile (no payload) gets bars per method instead.
A plan that did not succeed is marked with an x: at the solver's last iterate, or on the bottom
edge of the panel when planning raised an error (no value).
"""

from __future__ import annotations

import re
from collections import defaultdict
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from forte.experiments.common import DASHES, DPI, MANIP_LABEL, MARKERS, style
from forte.io.figures import pyplot

FIGURES_DIR = "figures"
PANELS = (("min_capacity_margin", "min capacity − (|f| + r) (N)"), ("mean_manipulability", MANIP_LABEL),
          ("success_share", "simulated runs with payload that succeed"))


def _plans(rows: Sequence[dict[str, Any]]) -> dict[tuple[str, float | None], dict[str, Any]]:
    """Per (method, mass): the plan's metrics and the success share of its runs with payload."""
    out: dict[tuple[str, float | None], dict[str, Any]] = {}
    runs: dict[tuple[str, float | None], list[bool]] = defaultdict(list)
    for r in rows:
        key = (r["method"], r["mass_kg"])
        out.setdefault(key, dict(r))
        if r["run"] in ("nominal", "mass-error") and r["sim_verdict"] in ("success", "failure", "not simulated"):
            runs[key].append(r["sim_verdict"] == "success")
    for key, plan in out.items():
        plan["success_share"] = float(np.mean(runs[key])) if runs[key] else None
    return out


def _value(plan: dict[str, Any], column: str) -> float:
    v = plan.get(column)
    return np.nan if v is None else float(v)


def _mark_failed(ax: Any, bad: list[tuple[float, float]]) -> None:
    """An x at each failed plan's value; a plan without one (it raised) on the panel's bottom edge."""
    from matplotlib.transforms import blended_transform_factory

    valued = [(m, v) for m, v in bad if np.isfinite(v)]
    if valued:
        ax.plot(*zip(*valued, strict=True), "kx", ms=9, mew=1.8, zorder=4)
    raised = [m for m, v in bad if not np.isfinite(v)]
    if raised:
        edge = blended_transform_factory(ax.transData, ax.transAxes)
        ax.plot(raised, [0.0] * len(raised), "kx", ms=9, mew=1.8, zorder=4, transform=edge, clip_on=False)


def plot_task(rows: Sequence[dict[str, Any]], path: Path, title: str) -> bool:
    """The panels of one task that have data (``rows``: its table rows); False when none has."""
    plans = _plans(rows)
    methods = list(dict.fromkeys(m for m, _ in plans))
    panels = [p for p in PANELS if any(np.isfinite(_value(v, p[0])) for v in plans.values())]
    if not panels:  # every plan raised an error: nothing to draw
        return False
    plt = pyplot()
    fig, axes = plt.subplots(1, len(panels), figsize=(4.2 * len(panels), 3.6), layout="constrained", squeeze=False)
    masses = sorted({m for _, m in plans if m is not None})
    for ax, (column, label) in zip(axes[0], panels, strict=True):
        if masses:
            for i, method in enumerate(methods):
                y = [_value(plans[(method, m)], column) if (method, m) in plans else np.nan for m in masses]
                color, name = style(method)
                ax.plot(masses, y, color=color, marker=MARKERS[i % len(MARKERS)], ls=DASHES[i % len(DASHES)],
                        ms=7 - i * 0.8, lw=1.5, label=name)  # shrinking markers: coinciding points stay visible
                bad = [(m, v) for m, v in zip(masses, y, strict=True)
                       if (method, m) in plans and plans[(method, m)]["plan_status"] != "feasible"]
                _mark_failed(ax, bad)
            ax.set_xlabel("payload mass (kg)")
        else:
            y = [_value(plans[(m, None)], column) for m in methods]
            ax.bar(range(len(methods)), y, color=[style(m)[0] for m in methods], edgecolor="black", lw=0.6)
            ax.set_xticks(range(len(methods)), [style(m)[1] for m in methods], rotation=20, fontsize=8)
        if column == "min_capacity_margin":
            ax.axhline(0.0, color="k", lw=0.8, ls="--")
        if column == "success_share":
            ax.set_ylim(-0.05, 1.05)
        ax.set_ylabel(label, fontsize=9)
        ax.grid(alpha=0.3)
    if masses:
        axes[0, -1].legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=8, frameon=False)
    if any(p["plan_status"] != "feasible" for p in plans.values()):
        title += (" (x: plan not feasible (its verdict); a failed solve is its last iterate, on the bottom edge "
                  "when it raised)")
    fig.suptitle(title, fontsize=10)
    fig.savefig(path, dpi=DPI, bbox_inches="tight")
    plt.close(fig)
    return True


def write_figures(rows: Sequence[dict[str, Any]], directory: Path) -> list[str]:
    """One PNG per (task, waypoints) under ``directory/figures``; returns their paths relative to ``directory``."""
    groups: dict[tuple[str, Any], list[dict[str, Any]]] = defaultdict(list)
    for r in rows:
        groups[(r["task"], r["waypoints"])].append(r)
    folder = directory / FIGURES_DIR
    folder.mkdir(exist_ok=True)
    names = []
    for (task, n), task_rows in groups.items():
        stem = f"{task}" + (f"_N{n}" if n is not None and len({w for t, w in groups if t == task}) > 1 else "")
        path = folder / f"{re.sub(r'[^A-Za-z0-9._-]', '_', stem)}.png"
        if plot_task(task_rows, path, f"sweep: task {task}" + (f", {n} waypoints" if n else "")):
            names.append(f"{FIGURES_DIR}/{path.name}")
    return names
