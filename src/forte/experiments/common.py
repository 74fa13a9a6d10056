"""What the experiments of Sections 5.2-5.4 share: methods, cases, trials, summaries, plots.

The claims and how they are judged are in :mod:`forte.experiments.claims`.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from forte import progress
from forte.execution.run import simulate_plan
from forte.experiments.claims import Case, Claim, claims_section, compare, fmt_num, solved
from forte.io.figures import pyplot
from forte.io.outputs import GENERATOR
from forte.io.plandir import FORMAT_VERSION, TRAJECTORY_FILE, plan_summary, write_plan
from forte.io.records import jsonable, package_versions
from forte.model.description import torque_limit_set
from forte.model.presets import torque_limit_name, with_torque_limits
from forte.planning.methods.catalog import METHODS, method_names
from forte.planning.planner import Plan, plan
from forte.planning.tasks.tasks import Task, load_task
from forte.settings import weight_set

TASKS_DIR = Path(__file__).resolve().parents[3] / "examples" / "tasks"
#: Payloads of Sections 5.3/5.4: label -> mass in kg (a 0.33 L can in the basket ~ 0.35 kg).
PAYLOADS: dict[str, float] = {"0.33 L": 0.35, "2.7 L": 2.7}
#: Largest relative payload-mass error of the simulated trials (uniform in +-MASS_ERROR).
MASS_ERROR = 0.10
#: Figure file formats of ``forte experiment --format``.
FORMATS = ("png", "pdf", "svg")
DPI = 150

Log = Callable[[str], None]
#: How the summaries describe each torque-limit set.
LIMIT_TEXT: dict[str, str] = {"paper": "the paper's", "urdf": "the URDF's efforts, a what-if; the paper uses 60/12"}

def paper_methods(experiment: str) -> tuple[str, ...]:
    """The methods the paper compares in ``experiment`` ("continuous", "lift" or "hold"), in order.

    From the method registry: every method marked ``in_paper`` for the experiment's mode (the
    continuous experiment compares the optimized ones only, as in Section 5.2).
    """
    mode = "hold" if experiment == "hold" else "trajectory"
    names = [n for n in method_names(mode) if METHODS[n].in_paper]
    return tuple(n for n in names if experiment != "continuous" or METHODS[n].optimized)


def style(method: str) -> tuple[str, str]:
    """``(colour, label)`` of a method in every figure (from the method registry)."""
    spec = METHODS.get(method)
    return (spec.style.color, spec.style.label) if spec else ("black", method)


def quiet(_: str) -> None:
    """Default logger: say nothing."""


# -- cases, planning and simulation ----------------------------------------------------------
def task_path(name: str) -> Path:
    """``examples/tasks/NAME.yaml`` of the source tree (or of the working directory)."""
    path = TASKS_DIR / f"{name}.yaml"
    if not path.exists():  # installed without the examples: look relative to the working directory
        path = Path("examples") / "tasks" / f"{name}.yaml"
    return path


def plan_methods(task: Any, methods: tuple[str, ...], log: Log, tag: str) -> dict[str, Plan]:
    """Plan ``task`` with every method, logging one line each."""
    out = {}
    for method in methods:
        start = time.perf_counter()
        res = plan(task, method)
        s = plan_summary(res)
        log(f"  {tag} {method}: {res.status} in {time.perf_counter() - start:.1f} s; min d = {s['min_d']:.1f} N, "
            f"mean manipulability = {s['mean_manipulability']:.4f}")
        out[method] = res
    return out


def plan_payloads(name: str, methods: tuple[str, ...], waypoints: int | None, log: Log,
                  weights: str | None = None, torque_limits: str = "paper") -> list[Case]:
    """Plan every method for both payloads of :data:`PAYLOADS` (the build step simulates them).

    ``weights``: a :data:`~forte.settings.WEIGHT_SETS` name replacing the task file's weight set
    (each method still applies its own tuning for that set).
    ``torque_limits``: a :data:`~forte.model.description.TORQUE_LIMIT_SETS` name (see
    :func:`with_limit_set`).
    """
    torque_limit_set(torque_limits)  # a bad name fails before any planning
    cases = []
    for label, mass in PAYLOADS.items():
        task = with_limit_set(load_task(task_path(name), mass=mass, waypoints=waypoints), torque_limits)
        if weights is not None:
            task = task.with_weights(weight_set(weights))
        log(f"{name} {label} ({mass} kg): {task.n} waypoint(s)")
        cases.append(Case(label, mass, plan_methods(task, methods, log, label)))
    return cases


def with_limit_set(task: Task, name: str) -> Task:
    """``task`` with the torque limits of the named set (``paper``: 60/12 Nm; ``urdf``: its robot's
    URDF efforts).

    The limits are the robot's, so they hold in planning and, through the plan directory's robot
    description, in every MuJoCo run of the plan (``simulate_plan`` reads them from ``plan.json``).
    """
    limits = torque_limit_set(name)
    robot = task.robot
    target = np.asarray(robot.model.effortLimit if limits is None else limits, dtype=float)
    if robot.torque_limits.shape == target.shape and np.array_equal(robot.torque_limits, target):
        return task
    return replace(task, robot=with_torque_limits(robot, None if limits is None else target))


def metrics(res: Plan) -> dict[str, Any]:
    """Planning quantities the paper discusses (per plan)."""
    cap, mag, r = res.metrics["directional_capacity"], res.force.magnitude, res.force.r
    return {
        "status": res.label,
        "verdict_failed": ", ".join(res.verdict.failed) if res.verdict is not None else "",
        "solver_status": res.status,
        "solve_time_s": float(res.solver.get("solve_time_s", 0.0)),
        **plan_summary(res),
        "min_capacity_minus_force": float(np.min(cap - mag)),  # < 0: the nominal force lies outside the RFP
        "mean_capacity": float(np.mean(cap)),
        "min_capacity": float(np.min(cap)),
        "min_inscribed_radius": float(np.min(res.metrics.get("inscribed_radius", np.nan))),
        "first_time_below_force": first_time(res.t, cap < mag),
        "first_time_below_band": first_time(res.t, cap < mag + r),
    }


def manipulability_leads(section: str, claim: str, heavy: Case) -> Claim:
    """``claim``: manipulability-only has the highest (mean) manipulability of ``heavy``'s methods."""
    mu = {m: metrics(r)["mean_manipulability"] for m, r in heavy.results.items()}
    other = max((m for m in mu if m != "manipulability"), key=mu.__getitem__)
    return Claim(section, claim, "mean manipulability", f"manipulability-only {mu['manipulability']:.4f} vs the next "
                 f"({other}) {mu[other]:.4f}",
                 [solved(heavy.results, *mu), compare("manipulability-only's mean manipulability", mu["manipulability"],
                                                      ">", f"{other}'s", mu[other], digits=4)])


def first_time(t: np.ndarray, mask: np.ndarray) -> float | None:
    """The first time stamp where ``mask`` holds (None if never)."""
    idx = np.flatnonzero(mask)
    return float(t[idx[0]]) if len(idx) else None


def mean_std(values: list[float]) -> tuple[float | None, float | None]:
    return (float(np.mean(values)), float(np.std(values))) if values else (None, None)


def simulate_runs(plan_dir: Path, mass: float | None, trials: int, rng: np.random.Generator,
                  hold: float) -> dict[str, Any]:
    """Nominal simulation (written to the plan dir) plus ``trials`` runs with a payload-mass error."""
    if not (plan_dir / TRAJECTORY_FILE).exists():
        return {"verdict": "not simulated", "reason": "planning failed (no trajectory)", "failure_time": None}
    nominal = simulate_plan(plan_dir, mass, hold=hold)
    out: dict[str, Any] = {"verdict": "success" if nominal.success else "failure", "reason": nominal.reason,
                           "failure_time": nominal.failure_time, "detail": nominal.detail,
                           "max_ee_error_m": nominal.summary.get("max_ee_error_m"),
                           "max_torque_ratio": float(np.max(nominal.summary.get("max_torque_ratio", [0.0])))}
    if mass is None or trials < 1:
        return out
    done = []
    for _ in range(trials):
        true_mass = float(mass * (1.0 + rng.uniform(-MASS_ERROR, MASS_ERROR)))
        res = simulate_plan(plan_dir, true_mass, hold=hold, write=False)
        done.append({"mass": true_mass, "success": res.success, "reason": res.reason,
                     "failure_time": res.failure_time, "max_ee_error_m": res.summary.get("max_ee_error_m")})
    out["trials"] = {
        "runs": done,
        "successes": int(sum(r["success"] for r in done)),
        "count": len(done),
        "failure_time_mean_std": mean_std([r["failure_time"] for r in done if r["failure_time"] is not None]),
        "max_ee_error_mean_std": mean_std([r["max_ee_error_m"] for r in done if r["max_ee_error_m"] is not None]),
    }
    return out


def simulate_cases(tmp: Path, cases: list[Case], trials: int, seed: int, log: Log, hold: float) -> None:
    """Write every plan to ``tmp/MASSkg/METHOD`` and simulate it (nominal + seeded trials)."""
    rng = np.random.default_rng(seed)
    for case in cases:
        for method, res in case.results.items():
            d = write_plan(res, tmp / f"{case.mass}kg" / method, figures=False)
            with progress.step(f"simulating {method} at {case.mass} kg (nominal + {trials} trials)"):
                case.sims[method] = simulate_runs(d, case.mass, trials, rng, hold)
            log(f"  simulated {case.label} {method}: {sim_text(case.sims[method])}")


def unloaded_runs(tmp: Path, case: Case, hold: float, log: Log) -> dict[str, dict[str, Any]]:
    """The plans of ``case`` executed with no payload (see :func:`unloaded_succeeds`)."""
    out = {}
    for method in case.results:
        d = tmp / f"{case.mass}kg" / method
        if (d / TRAJECTORY_FILE).exists():
            r = simulate_plan(d, 0.0, hold=hold, write=False)
            out[method] = {"label": "no payload", "mass": 0.0, "success": r.success, "reason": r.reason,
                           "failure_time": r.failure_time}
    log(f"  {case.label} plans without payload: {unloaded_text(out)}")
    return out


def unloaded_text(unloaded: dict[str, dict[str, Any]]) -> str:
    """``METHOD success`` or ``METHOD failure (REASON at TIME s)`` per plan run without payload."""
    return "; ".join(f"{m} success" if r["success"] else
                     f"{m} failure ({r['reason']} at {fmt_num(r['failure_time'])} s)"
                     for m, r in unloaded.items()) or "none simulated"


# -- text ------------------------------------------------------------------------------------
def sim_text(sim: dict[str, Any] | None) -> str:
    """One line on a plan's simulation: the nominal verdict and how many mass-error trials held."""
    if not sim:
        return "-"
    if sim["verdict"] == "not simulated":
        return f"not simulated ({sim.get('reason')})"
    text = f"nominal {sim['verdict']}"
    if sim.get("reason") and sim["verdict"] != "success":
        at = sim.get("failure_time")
        text += f" ({sim['reason']}" + (")" if at is None else f" at {fmt_num(at)} s)")
    tr = sim.get("trials")
    if tr:
        text += f"; mass-error trials {tr['successes']}/{tr['count']} ok"
        mean, std = tr["failure_time_mean_std"]
        if mean is not None:
            text += f", fail at {mean:.2f} ± {std:.2f} s"
    return text


def _table(case: Case) -> list[str]:
    lines = ["| method | plan verdict | min d (N) | min cap − (\\|f\\| + r) (N) | min cap − \\|f\\| (N) | "
             "mean cap (N) | mean manipulability | simulation |", "|---|---|---|---|---|---|---|---|"]
    for method, res in case.results.items():
        m = metrics(res)
        lines.append(f"| {method} | {m['status']} | {m['min_d']:.1f} | {m['min_capacity_margin']:.1f} | "
                     f"{m['min_capacity_minus_force']:.1f} | {m['mean_capacity']:.1f} | "
                     f"{m['mean_manipulability']:.4f} | {sim_text(case.sims.get(method))} |")
    return lines


def write_summary(directory: Path, title: str, intro: list[str], cases: list[Case], claims: list[Claim],
                  figures: list[str], settings: dict[str, Any], notes: list[str],
                  sections: list[str] | None = None, extra: dict[str, Any] | None = None) -> dict[str, Any]:
    """``summary.json`` and ``summary.md``: per-case tables, the paper's claims, our notes, figures.

    ``sections`` are markdown lines placed after the per-case tables; ``extra`` adds keys to the JSON.
    The intro ends with the weight set and the torque limits the plans used (also
    ``settings.weight_set``, ``settings.torque_limit_set`` and ``settings.torque_limits``).
    """
    first = next((r for c in cases for r in c.results.values()), None)
    if first is not None:
        weights, alpha, robot = first.task.weights, first.task.settings.alpha, first.task.robot
        limits, name = robot.torque_limits, torque_limit_name(robot)
        settings = {**settings, "weight_set": weights.preset, "torque_limit_set": name,
                    "torque_limits": limits.tolist()}
        intro = [*intro, f"Weight set: `{weights.preset}` (alpha {alpha:g}); each baseline applies its "
                 "own changes to it (`forte.planning.methods.catalog`).",
                 f"Torque limits: `{name}`, {'/'.join(f'{v:g}' for v in limits)} Nm ({LIMIT_TEXT.get(name, 'given')})"
                 ", in planning and in every MuJoCo run."]
    doc = {
        "generator": GENERATOR, "format_version": FORMAT_VERSION,
        "experiment": title,
        "settings": settings,
        "cases": {c.label: {"mass": c.mass,
                            "methods": {k: {"plan": metrics(r), "simulation": c.sims.get(k)}
                                        for k, r in c.results.items()}} for c in cases},
        "claims": [c.to_json() for c in claims],
        "notes": notes,
        "figures": figures,
        "versions": package_versions(),
        **(extra or {}),
    }
    (directory / "summary.json").write_text(json.dumps(jsonable(doc), indent=1) + "\n")
    lines = [f"# {title}", "", *intro, ""]
    for case in cases:
        lines += [f"## {case.label}", "", *_table(case), ""]
    lines += [*(sections or [])]
    lines += claims_section(claims)
    if notes:
        lines += ["## Notes (our observations, not claims of the paper)", "", *[f"- {n}" for n in notes], ""]
    lines += ["## Figures", "", *[f"![{f}]({f})" for f in figures], ""]
    (directory / "summary.md").write_text("\n".join(lines))
    return doc


def sim_cell(sim: dict[str, Any]) -> str:
    """A simulated run in a summary table: ``ok`` or its failure and when."""
    return "ok" if sim["success"] else f"{sim['reason']} at {sim['failure_time']:.2f} s"


def write_doc(directory: Path, doc: dict[str, Any], lines: list[str], page: str = "README.md") -> None:
    """An experiment's ``summary.json`` (``doc``) and its page of text (``lines``)."""
    (directory / "summary.json").write_text(json.dumps(jsonable(doc), indent=1) + "\n")
    (directory / page).write_text("\n".join(lines))


# -- plotting helpers ------------------------------------------------------------------------
def check_format(fmt: str) -> str:
    if fmt not in FORMATS:
        raise ValueError(f"figure format: expected one of {', '.join(FORMATS)}, got {fmt!r}")
    return fmt


def save(fig: Any, directory: Path, stem: str, fmt: str) -> str:
    """Save ``fig`` as ``directory/STEM.FMT``, close it and return the file name."""
    name = f"{stem}.{check_format(fmt)}"
    fig.savefig(directory / name, dpi=DPI, bbox_inches="tight")
    pyplot().close(fig)
    return name


def band(ax: Any, res: Plan) -> None:
    """The desired force magnitude |f| (black) and its uncertainty band |f| ± r (orange) over time."""
    mag, r = res.force.magnitude, res.force.r
    ax.fill_between(res.t, mag - r, mag + r, color="orange", alpha=0.3, lw=0, label="|f| ± r (desired force ± r)")
    ax.plot(res.t, mag, "k-", lw=1.6, label="|f| (desired force)")


#: Line styles and markers that keep overlapping curves of different methods apart.
DASHES = ("-", (0, (5, 2)), (0, (1, 1.5)), (0, (6, 2, 1, 2)), (0, (3, 3)), (0, (8, 3)))
MARKERS = ("o", "s", "^", "D", "v", "P")


def verdict_tag(res: Plan) -> str:
    """A legend suffix for a plan that is not feasible: its verdict and what failed (a failed
    solve's curve is its last iterate)."""
    if res.feasible:
        return ""
    failed = ", ".join(res.verdict.failed) if res.verdict is not None else ""
    return f" ({res.label}{': ' + failed if failed else ''})"


def method_line(ax: Any, t: np.ndarray, y: np.ndarray, method: str, index: int, tag: str = "") -> None:
    """One method's curve: its colour, its own dash pattern, and its own markers at staggered samples.

    The markers of method ``index`` sit at different samples than the other methods', so curves
    that coincide stay identifiable.
    """
    color, label = style(method)
    step = max(1, len(t) // 8)
    ax.plot(t, y, color=color, ls=DASHES[index % len(DASHES)], lw=1.8 if index == 0 else 1.4,
            marker=MARKERS[index % len(MARKERS)], ms=4, markevery=(index * step // len(MARKERS), step),
            label=label + tag, zorder=3 if index == 0 else 2)


MANIP_LABEL = "manipulability μ (m³)"
MANIP_DEF = ("μ = √det(J Jᵀ + λI), J the arm's 3 × 7 translational Jacobian (m/rad), λ = 1e-6")
