"""Section 5.3: lifting with 0.33 L and 2.7 L payloads, five methods, simulated execution.

Every plan is simulated once with the nominal mass and ``trials`` times with a seeded payload-mass
error (uniform in +-10 %). The claims follow the rules of :mod:`forte.experiments.common`: a
simulation claim holds only if it holds in every run, and "fails under the load" also needs the
plan to succeed without payload.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from forte.experiments.baseline_weights import SWEEP_FACTORS, weight_sweep_report
from forte.experiments.claims import Check, Claim, compare, every_run, runs, solved, some_run_fails, unloaded_succeeds
from forte.experiments.common import (
    MANIP_DEF,
    MANIP_LABEL,
    MASS_ERROR,
    Case,
    Log,
    band,
    check_format,
    manipulability_leads,
    method_line,
    metrics,
    paper_methods,
    plan_payloads,
    quiet,
    save,
    sim_text,
    simulate_cases,
    unloaded_runs,
    unloaded_text,
    verdict_tag,
    write_summary,
)
from forte.io.figures import pyplot
from forte.io.outputs import replace_directory
from forte.planning.planner import Plan, plan
from forte.settings import WEIGHT_SETS


def plot_lift(cases: list[Case], directory: Path, fmt: str) -> str:
    """2 x 2 like the paper: capacity along f (top) and manipulability (bottom); 0.33 L left, 2.7 L right."""
    plt = pyplot()
    fig, axes = plt.subplots(2, 2, figsize=(10, 6), sharex=True, sharey="row", layout="constrained")
    for col, case in enumerate(cases):
        ax_c, ax_m = axes[0, col], axes[1, col]
        band(ax_c, next(iter(case.results.values())))
        for i, (method, res) in enumerate(case.results.items()):
            tag = verdict_tag(res)
            method_line(ax_c, res.t, res.metrics["directional_capacity"], method, i, tag)
            method_line(ax_m, res.t, res.metrics["manipulability"], method, i)
        ax_c.set_title(f"{case.label} beverage (payload {case.mass:g} kg)", fontsize=10)
        ax_m.set_xlabel("time t (s)")
        for ax in (ax_c, ax_m):
            ax.grid(alpha=0.3)
    axes[0, 0].set_ylabel("RFP capacity along f (N)")
    axes[1, 0].set_ylabel(MANIP_LABEL)
    axes[0, -1].legend(*axes[0, 0].get_legend_handles_labels(), loc="upper left", bbox_to_anchor=(1.02, 1.0),
                       fontsize=8, frameon=False)
    fig.suptitle("Section 5.3, lifting: force capability along the upward task force f and manipulability",
                 fontsize=10)
    fig.text(0.0, -0.01, "capacity = distance from the origin to the residual force polytope (α = 1) along f;\n"
             + MANIP_DEF + ". Curves are the plans (planning is deterministic).", fontsize=7, ha="left", va="top")
    return save(fig, directory, "lift", fmt)


def run_lift(out: str | Path, trials: int = 3, waypoints: int | None = None, seed: int = 0,
             log: Log = quiet, fmt: str = "png",
             weight_factors: tuple[float, ...] = SWEEP_FACTORS, weights: str | None = None,
             torque_limits: str = "paper") -> dict[str, Any]:
    """Plan, simulate (nominal + ``trials`` seeded mass errors) and summarize Section 5.3 in ``out``.

    ``fmt`` is the figure format (png, pdf or svg).
    ``weight_factors``: the RFP baselines' capability weight in the sweep of
    :mod:`forte.experiments.baseline_weights`, as multiples of the authors' (empty: no sweep).
    ``weights``: a weight set replacing the task file's (default: the task file's,
    ``forte-trajectory``); the summary names the set it used.
    ``torque_limits``: ``paper`` (60/12 Nm, the default) or ``urdf`` (the URDF's efforts, 87/12 Nm,
    a what-if), in planning and in every simulated run; the summary names them.
    """
    out, fmt = Path(out), check_format(fmt)
    cases = plan_payloads("lift", paper_methods("lift"), waypoints, log, weights, torque_limits)

    def build(tmp: Path) -> None:
        simulate_cases(tmp, cases, trials, seed, log, hold=1.0)
        unloaded = unloaded_runs(tmp, cases[1], 1.0, log)
        exact = authors_weight_check(cases[1], log)
        sweep = weight_sweep_report(cases, tmp, weight_factors, trials, seed, 1.0, log, fmt, "5.3", "lift")
        figures = [plot_lift(cases, tmp, fmt), *sweep.figures]
        ref = next(iter(cases[0].results.values()))
        write_summary(tmp, "Section 5.3: lifting trajectory", [
            f"Task `examples/tasks/lift.yaml`, {ref.task.n} waypoints over {ref.t[-1]:.0f} s; payload 0.35 kg "
            f"(0.33 L) and 2.7 kg (2.7 L). Each plan is simulated in MuJoCo with the nominal mass, then {trials} "
            f"time(s) with a seeded payload-mass error uniform in ±{MASS_ERROR:.0%} (seed {seed}); a claim on the "
            "simulation counts only if it holds in every run.",
            "Capacity columns: RFP capacity along the planned force f; `min cap − |f|` < 0 means the nominal "
            "force is outside the residual force polytope."],
            cases, [*lift_claims(cases, unloaded), *sweep.claims], figures,
            {"waypoints": ref.task.n, "trials": trials, "seed": seed, "mass_error": MASS_ERROR,
             "unloaded_2p7_plans": unloaded, "authors_weights_2p7": exact, "format": fmt},
            [*lift_notes(cases, unloaded), _weights_note(cases[1], exact)], sweep.sections, sweep.extra)

    replace_directory(build, out)
    return json.loads((out / "summary.json").read_text())


def stays_below(res: Plan) -> Check:
    """After the capacity first drops below |f| it stays below at every later waypoint."""
    below = res.metrics["directional_capacity"] < res.force.magnitude
    what = f"{res.method}'s capacity stays below |f| once it drops below"
    idx = np.flatnonzero(below)
    if not len(idx):
        return Check(what, False, "never below |f|")
    after = below[idx[0]:]
    return Check(what, bool(np.all(after)), f"below at {int(after.sum())}/{len(after)} waypoints from "
                 f"t = {res.t[idx[0]]:.2f} s")


def _sufficient_and_lifts(heavy: Case, mh: dict[str, dict[str, Any]], method: str) -> Claim:
    return Claim("5.3", f"2.7 L: {method} completes the lift with sufficient force capability",
                 "min capacity − (|f| + r) (N); simulation",
                 f"{mh[method]['min_capacity_margin']:.1f}; {sim_text(heavy.sims.get(method))}",
                 [solved(heavy.results, method),
                  compare(f"{method}'s min capacity − (|f| + r)", mh[method]["min_capacity_margin"], ">=", "0",
                          0.0, " N"),
                  every_run(heavy, method)],
                 why=f"{method} ignores the force's magnitude (" + ("a ball centred at the origin" if method ==
                 "rfp-radius" else "rays around the force's direction") + "), so its plan is the same at both "
                 "payloads; with the authors' weights its " + _shortfall(mh[method]))


def _shortfall(m: dict[str, Any]) -> str:
    """Where an RFP baseline's 2.7 L plan falls short: |f| itself, |f| + r, or neither (its verdict)."""
    if m["min_capacity_minus_force"] < 0:
        return (f"capacity along f reaches {m['min_capacity']:.1f} N at the weakest waypoint, "
                f"{-m['min_capacity_minus_force']:.1f} N short of |f| there; forte, whose J1 asks for the load, "
                "keeps it (the weight sweep below shows where a larger weight gets it there)")
    if m["min_capacity_margin"] < 0:
        return (f"capacity along f stays above |f| but falls {-m['min_capacity_margin']:.1f} N short of |f| + r "
                "at the weakest waypoint")
    return (f"capacity along f stays {m['min_capacity_margin']:.1f} N above |f| + r (min d = {m['min_d']:.1f} N, "
            f"with the metric's alpha); its plan is {m['status']}" + (f": {m['verdict_failed']}" if
                                                                       m["verdict_failed"] else ""))


def _heavy_claims(heavy: Case, unloaded: dict[str, dict[str, Any]]) -> list[Claim]:
    mh = {m: metrics(r) for m, r in heavy.results.items()}
    sim = {m: sim_text(heavy.sims.get(m)) for m in heavy.results}
    res = heavy.results
    return [
        Claim("5.3", "2.7 L: forte's capacity stays above the upper edge of the |f| ± r band throughout",
              "min capacity − (|f| + r) (N)", f"{mh['forte']['min_capacity_margin']:.1f}",
              [solved(res, "forte"), compare("forte's min capacity − (|f| + r)", mh["forte"]["min_capacity_margin"],
                                             ">=", "0", 0.0, " N")]),
        Claim("5.3", "2.7 L: forte lifts the payload (the paper reports failed lifts only for manipulability-only "
              "and quintic)", "simulation, every run", sim["forte"], [every_run(heavy, "forte")]),
        Claim("5.3", "2.7 L: manipulability-only drops below the required force (paper: around 8 s)",
              "min capacity − |f| (N); first time below", f"{mh['manipulability']['min_capacity_minus_force']:.1f}; "
              f"{_time(mh['manipulability']['first_time_below_force'])}",
              [solved(res, "manipulability"), compare("manipulability-only's min capacity − |f|",
                                                      mh["manipulability"]["min_capacity_minus_force"], "<", "0",
                                                      0.0, " N")]),
        Claim("5.3", "2.7 L: manipulability-only fails to lift in some trials (paper: 1 of 3)",
              "simulation with the payload (any run); without it", f"{sim['manipulability']}; without payload: "
              f"{unloaded_text({k: v for k, v in unloaded.items() if k == 'manipulability'})}",
              [some_run_fails(heavy, "manipulability"), unloaded_succeeds(unloaded, "manipulability")]),
        Claim("5.3", "2.7 L: quintic (no optimization) is below the required force from ~2.5 s on",
              "min capacity − |f| (N); first time below", f"{mh['quintic']['min_capacity_minus_force']:.1f}; "
              f"{_time(mh['quintic']['first_time_below_force'])}",
              [solved(res, "quintic"),
               compare("quintic's min capacity − |f|", mh["quintic"]["min_capacity_minus_force"], "<", "0", 0.0, " N"),
               stays_below(res["quintic"])]),
        Claim("5.3", "2.7 L: quintic fails to lift (~2.5 s)", "simulation with the payload (every run); without it",
              f"{sim['quintic']}; without payload: "
              f"{unloaded_text({k: v for k, v in unloaded.items() if k == 'quintic'})}",
              [every_run(heavy, "quintic", success=False), unloaded_succeeds(unloaded, "quintic")]),
        *[_sufficient_and_lifts(heavy, mh, m) for m in ("rfp-radius", "rfp-cone")],
    ]


def _light_claims(light: Case) -> list[Claim]:
    ml = {m: metrics(r) for m, r in light.results.items()}
    res = light.results
    ratio = ml["forte"]["mean_manipulability"] / ml["manipulability"]["mean_manipulability"]
    return [
        *[Claim("5.3", f"0.33 L: {m} keeps a larger force capacity than needed (more than forte)",
                "mean capacity (N)", f"{m} {ml[m]['mean_capacity']:.1f} vs forte {ml['forte']['mean_capacity']:.1f}",
                [solved(res, m, "forte"), compare(f"{m}'s mean capacity", ml[m]["mean_capacity"], ">", "forte's",
                                                  ml["forte"]["mean_capacity"], " N")]) for m in ("rfp-radius",
                                                                                                  "rfp-cone")],
        Claim("5.3", "0.33 L: forte's manipulability is comparable to manipulability-only (>= 0.9x) while "
              "satisfying the force requirement", "mean manipulability; min capacity − (|f| + r)",
              f"{ml['forte']['mean_manipulability']:.4f} vs {ml['manipulability']['mean_manipulability']:.4f} "
              f"({ratio:.2f}x); {ml['forte']['min_capacity_margin']:.1f} N",
              [solved(res, "forte", "manipulability"),
               compare("forte / manipulability-only mean manipulability", ratio, ">=", "0.9", 0.9, digits=2),
               compare("forte's min capacity − (|f| + r)", ml["forte"]["min_capacity_margin"], ">=", "0", 0.0,
                       " N")]),
        *[Claim("5.3", f"0.33 L: {m} spends redundancy on force (lower manipulability than forte)",
                "mean manipulability", f"{m} {ml[m]['mean_manipulability']:.4f} vs forte "
                f"{ml['forte']['mean_manipulability']:.4f}",
                [solved(res, m, "forte"), compare(f"{m}'s mean manipulability", ml[m]["mean_manipulability"], "<",
                                                  "forte's", ml["forte"]["mean_manipulability"], digits=4)])
          for m in ("rfp-radius", "rfp-cone")],
    ]


def _adaptive_claims(light: Case, heavy: Case) -> list[Claim]:
    """forte against itself across the payloads, and against the others under the heavy one."""
    ml = {m: metrics(r) for m, r in light.results.items()}
    mh = {m: metrics(r) for m, r in heavy.results.items()}
    return [
        manipulability_leads("5.3", "2.7 L: manipulability-only improves the kinematic flexibility (the highest "
                             "manipulability)", heavy),
        Claim("5.3", "forte adapts to the task force: more force capacity for the 2.7 L load, more manipulability "
              "for the 0.33 L one", "mean capacity (N); mean manipulability, 2.7 L vs 0.33 L",
              f"{mh['forte']['mean_capacity']:.1f} vs {ml['forte']['mean_capacity']:.1f}; "
              f"{mh['forte']['mean_manipulability']:.4f} vs {ml['forte']['mean_manipulability']:.4f}",
              [solved(heavy.results, "forte"), solved(light.results, "forte"),
               compare("forte's mean capacity at 2.7 L", mh["forte"]["mean_capacity"], ">", "at 0.33 L",
                       ml["forte"]["mean_capacity"], " N"),
               compare("forte's mean manipulability at 0.33 L", ml["forte"]["mean_manipulability"], ">",
                       "at 2.7 L", mh["forte"]["mean_manipulability"], digits=4)]),
        Claim("5.3, 6", "2.7 L: forte matches the dedicated force-maximizing baselines (>= 0.8x their capacity)",
              "mean capacity (N)", f"forte {mh['forte']['mean_capacity']:.1f} vs rfp-radius "
              f"{mh['rfp-radius']['mean_capacity']:.1f}, rfp-cone {mh['rfp-cone']['mean_capacity']:.1f}",
              [solved(heavy.results, "forte", "rfp-radius", "rfp-cone"),
               *[compare("forte's mean capacity", mh["forte"]["mean_capacity"], ">=", f"0.8 x {m}'s",
                         0.8 * mh[m]["mean_capacity"], " N") for m in ("rfp-radius", "rfp-cone")]]),
    ]


def lift_claims(cases: list[Case], unloaded: dict[str, dict[str, Any]]) -> list[Claim]:
    """The claims of Section 5.3 (``cases``: 0.33 L then 2.7 L; ``unloaded``: 2.7 L plans without payload)."""
    light, heavy = cases
    return [*_heavy_claims(heavy, unloaded), *_light_claims(light), *_adaptive_claims(light, heavy)]


def _time(value: float | None) -> str:
    return "never" if value is None else f"{value:.2f} s"


def authors_weight_check(heavy: Case, log: Log) -> dict[str, Any]:
    """forte at 2.7 L with the authors' exact trajectory weights (capability 1), planning only."""
    task = next(iter(heavy.results.values())).task
    exact = plan(task.with_weights(WEIGHT_SETS["authors-trajectory"]), "forte")
    log(f"lift {heavy.label}: forte with the weight set authors-trajectory")
    m = metrics(exact)
    return {"weight_set": "authors-trajectory", "status": m["status"], "min_d": m["min_d"],
            "min_capacity_margin": m["min_capacity_margin"], "mean_manipulability": m["mean_manipulability"]}


def _weights_note(heavy: Case, exact: dict[str, Any]) -> str:
    ours = metrics(heavy.results["forte"])
    used = heavy.results["forte"].task.weights
    return (f"Weight set: forte uses `{used.preset}` (capability weight {used.capability:g}); the baselines "
            "keep the authors' weights. With the authors' exact set (`authors-trajectory`, capability 1) "
            f"forte's 2.7 L plan has min d = {exact['min_d']:.1f} N and min cap − (|f| + r) = "
            f"{exact['min_capacity_margin']:.1f} N (ours: {ours['min_d']:.1f} N and "
            f"{ours['min_capacity_margin']:.1f} N)" + (": on our model of the robot weight 1 lets the regularization "
            "win under the heavy load." if exact["min_d"] < 0 else ": weight 1 keeps the ball inside here."))


def lift_notes(cases: list[Case], unloaded: dict[str, dict[str, Any]]) -> list[str]:
    """Our observations (not claims of the paper), each with its numbers."""
    light, heavy = cases
    every = [(c, m) for c in cases for m in c.results if runs(c.sims.get(m), c.mass)]
    failed = [f"{c.label} {m}" for c, m in every if not all(r["success"] for r in runs(c.sims[m], c.mass))]
    quintic, forte = (runs(heavy.sims.get(m), heavy.mass) for m in ("quintic", "forte"))
    t_end = next(iter(heavy.results.values())).t[-1]
    mh = {m: metrics(r) for m, r in heavy.results.items()}
    return [
        f"Plans with at least one failed run: {', '.join(failed) or 'none'} (of {len(every)} simulated plans). "
        f"The 2.7 L plans executed with no payload: {unloaded_text(unloaded)}. A failure without payload comes from "
        "tracking the planned motion (controller gains, torque limits, dynamics), not from the payload's force.",
        "The issue's test (quintic fails and forte succeeds at 2.7 L): quintic "
        f"{sum(not r['success'] for r in quintic)}/{len(quintic)} runs failed, forte "
        f"{sum(r['success'] for r in forte)}/{len(forte)} runs ok.",
        f"The times in the paper's claims (around 8 s, ~2.5 s) are not judged: our lift lasts {t_end:.0f} s with "
        "its own waypoint timing. First time below |f| (ours): "
        + ", ".join(f"{m} {_time(v['first_time_below_force'])}" for m, v in mh.items()) + ".",
        "Mean manipulability at 0.33 L: " + ", ".join(f"{m} {metrics(r)['mean_manipulability']:.4f}"
                                                    for m, r in light.results.items()) + ".",
    ]
