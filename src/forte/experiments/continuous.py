"""Section 5.2: the 12 s trajectory with a time-varying task force, four methods.

Planning is deterministic, so the "trials" of this experiment repeat the planning itself (the
paper runs each method six times and reports negligible variation). Every claim is judged on
every planning trial and counts as reproduced only if it holds in all of them
(:func:`forte.experiments.common.across_trials`).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from forte.experiments.claims import Claim, across_trials, compare, solved
from forte.experiments.common import (
    MANIP_DEF,
    MANIP_LABEL,
    Case,
    Log,
    band,
    check_format,
    mean_std,
    method_line,
    paper_methods,
    plan_methods,
    quiet,
    save,
    sim_text,
    simulate_runs,
    task_path,
    verdict_tag,
    write_summary,
)
from forte.io.figures import pyplot
from forte.io.outputs import replace_directory
from forte.io.plandir import write_plan
from forte.planning.planner import Plan
from forte.planning.tasks.tasks import load_task

LABEL = "force profile (Section 5.2)"


def plot_continuous(results: dict[str, Plan], directory: Path, fmt: str) -> str:
    """Capacity along f (top) and manipulability (bottom) vs time; legend outside the axes."""
    plt = pyplot()
    fig, (ax_c, ax_m) = plt.subplots(2, 1, figsize=(8, 5.6), sharex=True, layout="constrained")
    band(ax_c, next(iter(results.values())))
    for i, (method, res) in enumerate(results.items()):
        tag = verdict_tag(res)
        method_line(ax_c, res.t, res.metrics["directional_capacity"], method, i, tag)
        method_line(ax_m, res.t, res.metrics["manipulability"], method, i)
    ax_c.set_ylabel("RFP capacity along f (N)")
    ax_m.set_ylabel(MANIP_LABEL)
    ax_m.set_xlabel("time t (s)")
    for ax in (ax_c, ax_m):
        ax.grid(alpha=0.3)
    ax_c.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=8, frameon=False)
    fig.suptitle("Section 5.2, continuous trajectory: force capability and manipulability per method", fontsize=10)
    fig.text(0.0, -0.01, "capacity = distance from the origin to the residual force polytope (α = 1) along f;\n"
             f"{MANIP_DEF}.", fontsize=7, ha="left", va="top")
    return save(fig, directory, "continuous", fmt)


def _plan_trials(task: Any, trials: int, log: Log) -> list[dict[str, Plan]]:
    return [plan_methods(task, paper_methods("continuous"), log, f"trial {k + 1}:") for k in range(max(trials, 1))]


def _variation(per_trial: list[dict[str, Plan]]) -> dict[str, dict[str, Any]]:
    """Per method: solve time mean/std and the largest capacity spread over the planning trials."""
    out = {}
    for method in per_trial[0]:
        caps = np.array([r[method].metrics["directional_capacity"] for r in per_trial])
        out[method] = {"solve_time_s_mean_std": mean_std([float(r[method].solver.get("solve_time_s", 0.0))
                                                          for r in per_trial]),
                       "max_capacity_spread_N": float(np.max(np.ptp(caps, axis=0)))}
    return out


#: Planning trials per method in Section 5.2 (the paper's Table: "6 per method").
PAPER_TRIALS = 6


def run_continuous(out: str | Path, trials: int = PAPER_TRIALS, waypoints: int | None = None, log: Log = quiet,
                   simulate: bool = True, fmt: str = "png") -> dict[str, Any]:
    """Plan (``trials`` times, the paper's 6 by default), simulate once and summarize Section 5.2 in ``out``.

    With ``simulate`` the plans of the last planning trial are executed
    once in MuJoCo with the force profile applied as an external reaction at the end effector.
    ``fmt`` is the figure format (png, pdf or svg).
    """
    out, fmt = Path(out), check_format(fmt)
    task = load_task(task_path("continuous"), waypoints=waypoints)
    log(f"continuous: {task.n} waypoints, {len(paper_methods('continuous'))} methods, "
        f"{max(trials, 1)} planning trial(s)")
    per_trial = _plan_trials(task, trials, log)
    case = Case(LABEL, None, per_trial[-1])
    variation = _variation(per_trial)

    def build(tmp: Path) -> None:
        for method, res in case.results.items():
            d = write_plan(res, tmp / method, figures=False)
            if simulate:
                case.sims[method] = simulate_runs(d, None, 0, np.random.default_rng(0), hold=1.0)
                log(f"  simulated {method}: {sim_text(case.sims[method])}")
        figure = plot_continuous(case.results, tmp, fmt)
        claims = across_trials([continuous_claims(r) for r in per_trial])
        notes = continuous_notes(per_trial[-1]) + [
            "Spread over the planning trials (max over waypoints of max − min capacity, N): "
            + ", ".join(f"{m} {v['max_capacity_spread_N']:.2g}" for m, v in variation.items()) + "."]
        ref = case.results[paper_methods("continuous")[0]]
        write_summary(tmp, "Section 5.2: continuous trajectory with a time-varying task force", [
            f"Task `examples/tasks/continuous.yaml`, {task.n} waypoints over {ref.t[-1]:.0f} s; force profile given "
            f"directly (peak |f| = {ref.force.magnitude.max():.0f} N, r = {ref.force.r[0]:.0f} N). Planning is "
            f"deterministic; {max(trials, 1)} planning trial(s) per method, and a claim counts only if it holds in "
            "every trial." + (" The last trial's plans are simulated once with the force applied as an external "
                              "reaction (no payload)." if simulate else "")],
            [case], claims, [figure], {"waypoints": task.n, "trials": trials, "variation": variation,
                                       "format": fmt}, notes)

    replace_directory(build, out)
    return json.loads((out / "summary.json").read_text())


def _intervals(res: Plan) -> tuple[np.ndarray, np.ndarray]:
    """The paper's high-demand interval (|f| at least half its peak) and its complement."""
    mag = res.force.magnitude
    high = mag >= 0.5 * mag.max()
    return high, ~high


def continuous_claims(results: dict[str, Plan]) -> list[Claim]:
    """The claims of Section 5.2 on the plans of one planning trial."""
    ours = results["forte"]
    high, low = _intervals(ours)
    t_high = ours.t[high]
    others = [m for m in results if m != "forte"]
    cap = {m: float(np.mean(r.metrics["directional_capacity"][high])) for m, r in results.items()}
    mu_high = {m: float(np.mean(r.metrics["manipulability"][high])) for m, r in results.items()}
    mu_low = {m: float(np.mean(r.metrics["manipulability"][low])) for m, r in results.items()}
    best = max(others, key=lambda m: cap[m])
    ratio = mu_low["forte"] / mu_low["manipulability"]
    return [
        Claim("5.2", f"in the high-demand interval (~5-8 s; ours {t_high.min():.1f}-{t_high.max():.1f} s) forte "
              "raises the capacity along f above the other methods", "mean capacity in the interval (N)",
              f"forte {cap['forte']:.1f} vs best other ({best}) {cap[best]:.1f}",
              [solved(results, *results), compare("forte's mean capacity", cap["forte"], ">",
                                                  f"{best}'s", cap[best], " N")]),
        Claim("5.2", "forte lets manipulability decrease when the demand is high",
              "mean manipulability in the interval", f"forte {mu_high['forte']:.4f} vs manipulability-only "
              f"{mu_high['manipulability']:.4f}",
              [solved(results, "forte", "manipulability"),
               compare("forte's mean manipulability", mu_high["forte"], "<", "manipulability-only's",
                       mu_high["manipulability"], digits=4)]),
        Claim("5.2", "when the demand is low forte's manipulability recovers close to manipulability-only",
              "mean manipulability outside the interval, ratio forte / manip.-only (>= 0.9)",
              f"{mu_low['forte']:.4f} / {mu_low['manipulability']:.4f} = {ratio:.2f}",
              [solved(results, "forte", "manipulability"),
               compare("the ratio forte / manipulability-only", ratio, ">=", "0.9", 0.9, digits=2)]),
    ]


def continuous_notes(results: dict[str, Plan]) -> list[str]:
    """Our observations on the plans (not claims of the paper), with their numbers."""
    ours = results["forte"]
    mag, r = ours.force.magnitude, ours.force.r
    cap = {m: res.metrics["directional_capacity"] for m, res in results.items()}
    k = int(np.argmax(mag))
    best = max(results, key=lambda m: float(cap[m][k]))
    covered = "covers" if cap[best][k] >= mag[k] + r[k] else "does not cover"
    margins = ", ".join(f"{m} {np.min(res.metrics['capacity_margin']):.1f}" for m, res in results.items())
    return [
        "Solver status per method: " + ", ".join(f"{m} {res.status}" for m, res in results.items())
        + ". The plan column is each plan's verdict (forte.planning.verdict.verdict); a plan marked solver-failed "
          "is the solver's last iterate and its claims fail. Verdicts: "
        + "; ".join(f"{m} {res.label}" + (f" ({res.verdict.brief()})" if not res.feasible else "")
                    for m, res in results.items()) + ".",
        f"Min capacity − (|f| + r) along the trajectory (N): {margins}.",
        f"Peak demand |f| + r = {mag[k] + r[k]:.0f} N at t = {ours.t[k]:.1f} s; the best planned capacity there is "
        f"{cap[best][k]:.0f} N ({best}{'' if results[best].solved else ', last iterate of a failed solve'}), "
        f"which {covered} it.",
    ]
