"""The RFP baselines at other capability weights (Sections 5.3 and 5.4, and the paper's conclusion).

The paper warns that "changing the optimization weights can shift the overall level of the curves
produced by the RFP inscribed radius and RFP Cone methods" (Section 5.3), and concludes that forte's
balance, enough force under the heavy load and manipulability under the light one, is one "that
none of the baselines achieves on its own". With the authors' weights our baselines do not lift the
2.7 L load (the lift summary says why), so the comparison would be incomplete without asking: at a
weight where a baseline *does* have enough force for the heavy load, what does it keep of its
manipulability under the light load?

:func:`sweep_baselines` re-plans each RFP baseline at the weights of a sweep (the authors' value
first), simulates the heavy plans like the main ones (nominal + seeded mass-error trials), and
:func:`weight_claims` judges the two statements above on the result. Only the capability weight
changes; every other weight stays the authors'.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from forte import progress
from forte.experiments.claims import Check, Claim, compare, runs
from forte.experiments.common import MANIP_LABEL, Case, Log, metrics, save, sim_text, simulate_runs, style
from forte.io.figures import pyplot
from forte.io.plandir import write_plan
from forte.planning.methods.catalog import METHODS, Method
from forte.planning.planner import Plan, plan
from forte.settings import CostWeights

#: The RFP baselines whose capability weight is swept.
SWEPT: tuple[str, ...] = ("rfp-radius", "rfp-cone")
#: The swept capability weights, as multiples of the authors' (60 on trajectories, 2 in holding):
#: 1.5 decades. (At 100 x 60 IPOPT reports the lift's rfp-radius problem infeasible.)
SWEEP_FACTORS: tuple[float, ...] = (1.0, 3.0, 10.0, 30.0)


class SweepPoint(NamedTuple):
    """One baseline at one capability weight: its plans for both payloads and the heavy plan's runs."""

    method: str
    weight: float
    light: Plan
    heavy: Plan
    heavy_sim: dict[str, Any]

    @property
    def sufficient(self) -> bool:
        """Enough force for the heavy load: the plan is feasible (its verdict: capacity >= |f| + r
        and d >= 0 throughout, torques within limits, ...) and every run succeeds."""
        done = runs(self.heavy_sim, None)
        return self.heavy.feasible and bool(done) and all(r["success"] for r in done)


def with_capability_weight(method: str, weight: float, preset: str) -> Method:
    """``method`` with its capability weight set to ``weight`` on the weight set ``preset``."""
    spec = METHODS[method]
    tuning = {name: dict(changes) for name, changes in spec.tuning.items()}
    tuning[preset] = {**tuning.get(preset, {}), "capability": float(weight)}
    return replace(spec, tuning=tuning)


def sweep_weights(method: str, weights: CostWeights, factors: tuple[float, ...]) -> tuple[float, ...]:
    """The capability weight ``method`` runs with on ``weights`` (the authors' value) times each factor."""
    base = METHODS[method].resolve(weights)[0].capability
    return tuple(base * f for f in factors)


def sweep_baselines(cases: list[Case], tmp: Path, factors: tuple[float, ...], trials: int, seed: int,
                    hold: float, log: Log) -> list[SweepPoint]:
    """Plan every method of :data:`SWEPT` at its authors' weight times each factor, for both payloads.

    ``cases`` are the experiment's (light, heavy); their tasks are reused, and so are their plans and
    simulations at the authors' weight (factor 1). Other heavy plans are written to
    ``tmp/weights/METHOD-WEIGHT`` and simulated (nominal + ``trials`` seeded mass errors).
    """
    light, heavy = cases
    light_task = next(iter(light.results.values())).task
    heavy_task = next(iter(heavy.results.values())).task
    rng = np.random.default_rng(seed + 1)
    points = []
    for method in SWEPT:
        for factor, weight in zip(factors, sweep_weights(method, heavy_task.weights, factors), strict=True):
            if factor == 1.0 and method in light.results and method in heavy.sims:
                points.append(SweepPoint(method, weight, light.results[method], heavy.results[method],
                                         heavy.sims[method]))
                continue
            spec = with_capability_weight(method, weight, heavy_task.weights.preset)
            lp, hp = plan(light_task, spec), plan(heavy_task, spec)
            d = write_plan(hp, tmp / "weights" / f"{method}-{weight:g}", figures=False)
            with progress.step(f"simulating {method} at capability weight {weight:g}"):
                sim = simulate_runs(d, heavy.mass, trials, rng, hold)
            points.append(SweepPoint(method, weight, lp, hp, sim))
            log(f"  {method} at capability weight {weight:g}: 2.7 L {sim_text(sim)}")
    return points


def _by_method(points: list[SweepPoint], method: str) -> list[SweepPoint]:
    return [p for p in points if p.method == method]


def sweep_table(points: list[SweepPoint], forte_light: Plan) -> list[str]:
    """Markdown: per baseline and weight, the heavy plan's sufficiency and the light plan's manipulability."""
    mu_forte = metrics(forte_light)["mean_manipulability"]
    lines = ["| method | capability weight | 2.7 L plan verdict | 2.7 L min cap − (\\|f\\| + r) (N) "
             f"| 2.7 L mean cap (N) | 2.7 L simulation | 0.33 L mean manipulability (forte: {mu_forte:.4f}) |",
             "|---|---|---|---|---|---|---|"]
    for p in points:
        mh, ml = metrics(p.heavy), metrics(p.light)
        verdict = p.heavy.label + (f" ({p.heavy.verdict.brief()})" if p.heavy.verdict and not p.heavy.feasible else "")
        lines.append(f"| {p.method} | {p.weight:g} | {verdict} | {mh['min_capacity_margin']:.1f} | "
                     f"{mh['mean_capacity']:.1f} | {sim_text(p.heavy_sim)} | {ml['mean_manipulability']:.4f} |")
    return lines


def weight_claims(points: list[SweepPoint], forte_light: Plan, section: str) -> list[Claim]:
    """The two statements of the module docstring, judged on the sweep (one claim each, both baselines)."""
    mu_forte = metrics(forte_light)["mean_manipulability"]
    shift_checks, balance_checks, shift_text, balance_text = [], [], [], []
    for method in SWEPT:
        pts = _by_method(points, method)
        caps = [metrics(p.heavy)["mean_capacity"] for p in pts]
        shift_checks.append(compare(f"{method}'s mean capacity at weight {pts[-1].weight:g}", caps[-1], ">",
                                    f"at the authors' {pts[0].weight:g}", caps[0], " N"))
        shift_text.append(f"{method} " + " → ".join(f"{c:.1f}" for c in caps))
        enough = [p for p in pts if p.sufficient]
        both = [p for p in enough if metrics(p.light)["mean_manipulability"] >= mu_forte]
        evidence = ("never sufficient in the sweep" if not enough else "sufficient from weight "
                    f"{enough[0].weight:g}, where its 0.33 L manipulability is "
                    f"{metrics(enough[0].light)['mean_manipulability']:.4f}")
        balance_checks.append(Check(f"{method} has no weight with enough force under the 2.7 L load and "
                                    "forte's manipulability under the 0.33 L one", not both,
                                    evidence + (f"; both at weight {both[0].weight:g}" if both else "")))
        balance_text.append(f"{method}: {evidence}")
    solved_all = Check("every sweep plan solved", all(p.light.solved and p.heavy.solved for p in points),
                       ", ".join(f"{p.method}@{p.weight:g}: {p.heavy.status}" for p in points
                                 if not (p.light.solved and p.heavy.solved)) or "all solved")
    return [
        Claim(section, "changing the optimization weights shifts the level of the RFP baselines' capacity curves",
              "2.7 L mean capacity along f (N) at capability weight × " + ", ".join(
                  f"{p.weight / points[0].weight:g}" for p in _by_method(points, SWEPT[0])),
              "; ".join(shift_text), [solved_all, *shift_checks]),
        Claim(section, "no fixed weight gives an RFP baseline forte's balance: enough force for the heavy load "
              "and forte's manipulability for the light one (the paper's conclusion)",
              "per swept weight: a feasible 2.7 L plan (its verdict) that lifts in every simulated run; mean "
              "manipulability "
              "at 0.33 L vs forte's", "; ".join(balance_text) + f" (forte {mu_forte:.4f})",
              [solved_all, *balance_checks]),
    ]


def weight_summary(points: list[SweepPoint]) -> list[dict[str, Any]]:
    """The sweep for ``summary.json``."""
    return [{"method": p.method, "weight": p.weight, "heavy": metrics(p.heavy), "light": metrics(p.light),
             "heavy_simulation": p.heavy_sim, "sufficient": p.sufficient} for p in points]


def plot_weights(points: list[SweepPoint], forte_light: Plan, forte_heavy: Plan, directory: Path, fmt: str,
                 stem: str, title: str) -> str:
    """Heavy-load capacity margin and light-load manipulability against the capability weight."""
    plt = pyplot()
    fig, (ax_c, ax_m) = plt.subplots(1, 2, figsize=(10, 3.6), layout="constrained")
    for method in SWEPT:
        pts = _by_method(points, method)
        color, label = style(method)
        w = [p.weight for p in pts]
        ax_c.plot(w, [metrics(p.heavy)["min_capacity_margin"] for p in pts], "o-", color=color, label=label)
        ax_m.plot(w, [metrics(p.light)["mean_manipulability"] for p in pts], "o-", color=color, label=label)
    color, label = style("forte")
    ax_c.axhline(metrics(forte_heavy)["min_capacity_margin"], color=color, ls="--", label=f"{label} (fixed weights)")
    ax_m.axhline(metrics(forte_light)["mean_manipulability"], color=color, ls="--", label=f"{label} (fixed weights)")
    ax_c.axhline(0.0, color="black", lw=0.8)
    swept = sorted({p.weight for p in points})
    for ax in (ax_c, ax_m):
        ax.set_xscale("log")
        ax.minorticks_off()  # ticks at the swept weights only (log minor labels overlap)
        ax.set_xticks(swept, [f"{w:g}" for w in swept])
        ax.set_xlabel("RFP baseline's capability weight (authors' value = first point)")
        ax.grid(alpha=0.3)
    ax_c.set_ylabel("2.7 L: min capacity − (|f| + r) (N)")
    ax_m.set_ylabel(f"0.33 L: mean {MANIP_LABEL}")
    ax_m.legend(fontsize=8, frameon=False)
    fig.suptitle(title, fontsize=10)
    return save(fig, directory, stem, fmt)


class SweepReport(NamedTuple):
    """What a sweep adds to an experiment's summary (all empty when no sweep ran)."""

    figures: list[str]
    claims: list[Claim]
    sections: list[str]
    extra: dict[str, Any]


def weight_sweep_report(cases: list[Case], tmp: Path, factors: tuple[float, ...], trials: int, seed: int,
                        hold: float, log: Log, fmt: str, section: str, experiment: str) -> SweepReport:
    """Run the sweep (``factors`` of the authors' weight; none: skip it) and build its summary parts.

    ``section`` is the paper's section of the claims; ``experiment`` ("lift", "hold") names the
    figure, ``EXPERIMENT_weights``.
    """
    if not factors:
        return SweepReport([], [], [], {})
    points = sweep_baselines(cases, tmp, factors, trials, seed, hold, log)
    forte_light, forte_heavy = (c.results["forte"] for c in cases)
    figure = plot_weights(points, forte_light, forte_heavy, tmp, fmt, f"{experiment}_weights",
                          f"Section {section} ({experiment}): the RFP baselines at other capability weights")
    preset = next(iter(cases[1].results.values())).task.weights.preset
    text = ["## RFP baselines at other capability weights", "",
            f"Only the RFP baselines' capability weight changes: their weight on `{preset}` times "
            + ", ".join(f"{f:g}" for f in factors) + "; every other weight stays the authors'. 'Simulation' is the "
            "2.7 L plan, run like the main table's (nominal + the same number of seeded mass-error trials).", "",
            *sweep_table(points, forte_light), ""]
    return SweepReport([figure], weight_claims(points, forte_light, section), text,
                       {"baseline_weights": {"factors": list(factors), "points": weight_summary(points)}})
