"""Section 5.4: single-point holding with 0.33 L and 2.7 L payloads, five configurations.

Each configuration is held for :data:`HOLD_SECONDS` in simulation with the nominal mass and
``trials`` times with a seeded mass error; claims follow :mod:`forte.experiments.common`.

Figures: ``hold_metrics`` (capacity along f against the |f| ± r band, and manipulability, as
bars per method), ``hold_polytopes`` (per method the residual force polytope's section by the
vertical x-z plane through the force ball's centre, zoomed on the ball) and ``hold_ellipsoids``
(projections of the velocity-manipulability ellipsoid).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from forte.capability.polytope import directional_capacity, trajectory_rfp
from forte.experiments.baseline_weights import SWEEP_FACTORS, weight_sweep_report
from forte.experiments.common import (
    MANIP_DEF,
    MANIP_LABEL,
    MASS_ERROR,
    Case,
    Log,
    check_format,
    paper_methods,
    plan_payloads,
    quiet,
    save,
    simulate_cases,
    style,
    unloaded_runs,
    write_summary,
)
from forte.experiments.hold_claims import hold_claims, hold_notes
from forte.io.figures import pyplot
from forte.io.outputs import replace_directory
from forte.planning.planner import Plan

HOLD_SECONDS = 3.0


# -- figures ---------------------------------------------------------------------------------
def plot_hold_metrics(cases: list[Case], directory: Path, fmt: str) -> str:
    """Bars per method: capacity along f against the |f| ± r band (top), manipulability (bottom)."""
    plt = pyplot()
    fig, axes = plt.subplots(2, len(cases), figsize=(10, 6), sharey="row", layout="constrained")
    for col, case in enumerate(cases):
        names = list(case.results)
        ref = case.results[names[0]]
        need, rad = float(ref.force.magnitude[0]), float(ref.force.r[0])
        colors = [style(m)[0] for m in names]
        x = np.arange(len(names))
        ax_c, ax_m = axes[0, col], axes[1, col]
        ax_c.axhspan(need - rad, need + rad, color="orange", alpha=0.25, lw=0, zorder=0,
                     label="|f| ± r (desired force ± r)")
        for y, ls in ((need - rad, "--"), (need + rad, "--"), (need, "-")):
            ax_c.axhline(y, color="k", ls=ls, lw=1.0 if ls == "--" else 1.4, zorder=3)
        caps = [float(case.results[m].metrics["directional_capacity"][0]) for m in names]
        mus = [float(case.results[m].metrics["manipulability"][0]) for m in names]
        for ax, values, digits in ((ax_c, caps, 1), (ax_m, mus, 3)):
            bars = ax.bar(x, values, width=0.65, color=colors, edgecolor="black", lw=0.6, zorder=2)
            ax.bar_label(bars, labels=[f"{v:.{digits}f}" for v in values], fontsize=7, padding=2,
                         bbox={"facecolor": "white", "edgecolor": "none", "pad": 0.6}, zorder=4)
            ax.set_xticks(x, [style(m)[1] for m in names], rotation=20, fontsize=8)
            ax.grid(axis="y", alpha=0.3, zorder=0)
            ax.margins(y=0.12)
        ax_c.set_title(f"{case.label} beverage (payload {case.mass:g} kg): |f| = {need:.1f} N, r = {rad:.0f} N",
                       fontsize=9)
    axes[0, 0].set_ylabel("RFP capacity along f (N)")
    axes[1, 0].set_ylabel(MANIP_LABEL)
    handles = [*axes[0, 0].get_legend_handles_labels()[0],
               plt.Line2D([], [], color="k", lw=1.4, label="|f|"),
               plt.Line2D([], [], color="k", ls="--", lw=1.0, label="|f| − r and |f| + r")]
    axes[0, -1].legend(handles=handles, loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=8, frameon=False)
    fig.suptitle("Section 5.4, single-point holding: capacity along the upward task force f and manipulability",
                 fontsize=10)
    fig.text(0.0, -0.02, "capacity = distance from the origin to the residual force polytope (α = 1) along f; "
             + MANIP_DEF + ".", fontsize=7, ha="left", va="top")
    return save(fig, directory, "hold_metrics", fmt)


def clip_polygon(poly: np.ndarray, a: np.ndarray, b: float) -> np.ndarray:
    """The part of the convex polygon ``poly`` (k x 2, in order) with ``a . p <= b`` (Sutherland-Hodgman)."""
    out = []
    for p, q in zip(poly, np.roll(poly, -1, axis=0), strict=True):
        sp, sq = a @ p - b, a @ q - b
        if sp <= 0:
            out.append(p)
        if sp * sq < 0:
            out.append(p + (q - p) * sp / (sp - sq))
    return np.array(out).reshape(-1, 2)


def polytope_section(A: np.ndarray, b: np.ndarray, f: np.ndarray, box: tuple[float, float, float, float]
                     ) -> np.ndarray:
    """Section of ``{g : A g <= b}`` by the plane ``g_y = f_y``, in (g_x, g_z), within ``box`` = (x0, x1, z0, z1)."""
    x0, x1, z0, z1 = box
    poly = np.array([[x0, z0], [x1, z0], [x1, z1], [x0, z1]], dtype=float)
    for row, bound in zip(A, b, strict=True):
        a2 = row[[0, 2]]
        rhs = bound - row[1] * f[1]
        if np.linalg.norm(a2) < 1e-12:
            if rhs < 0:
                return np.zeros((0, 2))
            continue
        poly = clip_polygon(poly, a2, rhs)
        if not len(poly):
            break
    return poly


def _section_data(res: Plan) -> dict[str, Any]:
    """Half-spaces (alpha = 1), the metric's alpha, the force ball and the capacity point of a hold plan."""
    rfp = trajectory_rfp(res.task.robot, res.q, res.t, alpha=1.0)
    A, b = rfp.A[0], rfp.b[0]
    f, r = res.force.f[0], float(res.force.r[0])
    cap = float(directional_capacity(A, b, f))
    return {"A": A, "b": b, "f": f, "r": r, "cap": cap, "alpha": res.task.settings.capability_params.alpha,
            "point": cap * f / np.linalg.norm(f)}


def _window(data: list[dict[str, Any]]) -> tuple[float, float, float, float]:
    """A square window (x0, x1, z0, z1) holding the origin, every ball and every capacity point."""
    pts = [np.zeros(2)]
    for d in data:
        fx, fz = d["f"][0], d["f"][2]
        pts += [np.array([fx - d["r"], fz - d["r"]]), np.array([fx + d["r"], fz + d["r"]])]
        if np.isfinite(d["cap"]):
            pts.append(d["point"][[0, 2]])
    pts = np.array(pts)
    centre = (pts.min(axis=0) + pts.max(axis=0)) / 2
    half = 0.6 * float(np.max(pts.max(axis=0) - pts.min(axis=0))) + 0.3 * max(d["r"] for d in data)
    return centre[0] - half, centre[0] + half, centre[1] - half, centre[1] + half


def _draw_section(ax: Any, d: dict[str, Any], box: tuple[float, float, float, float], res: Plan) -> None:
    full = polytope_section(d["A"], d["b"], d["f"], box)
    shrunk = polytope_section(d["A"], d["alpha"] * d["b"], d["f"], box)
    if len(full):
        ax.fill(full[:, 0], full[:, 1], facecolor="0.8", edgecolor="0.3", lw=1.2)
    if len(shrunk):
        ax.fill(shrunk[:, 0], shrunk[:, 1], fill=False, edgecolor="0.3", ls="--", lw=1.0)
    fx, fz = d["f"][0], d["f"][2]
    ax.add_patch(pyplot().Circle((fx, fz), d["r"], facecolor="orange", alpha=0.45, edgecolor="darkorange", lw=1.2))
    ax.plot([0.0, fx], [0.0, fz], color="k", lw=1.0)
    ax.plot(fx, fz, "o", color="darkorange", ms=3)
    if np.isfinite(d["cap"]) and abs(d["point"][1] - d["f"][1]) < 1e-6 * max(1.0, d["cap"]):
        ax.plot(*d["point"][[0, 2]], "kx", ms=7, mew=1.6)
    ax.plot(0.0, 0.0, "k+", ms=6)
    ax.set_xlim(box[0], box[1])
    ax.set_ylim(box[2], box[3])
    ax.set_aspect("equal")
    ax.grid(alpha=0.3)
    ax.tick_params(labelsize=7)
    ax.set_title(f"{style(res.method)[1]}\nd = {res.metrics['d'][0]:.1f} N, capacity {d['cap']:.1f} N",
                 fontsize=8)


def plot_hold_polytopes(cases: list[Case], directory: Path, fmt: str) -> str:
    """Per method and payload, the RFP's section by the x-z plane through the ball's centre, zoomed on the ball."""
    plt = pyplot()
    rows = cases[::-1]  # the paper puts 2.7 L on top
    cols = list(rows[0].results)
    fig, axes = plt.subplots(len(rows), len(cols), figsize=(2.4 * len(cols) + 1.8, 2.7 * len(rows)),
                             sharey="row", layout="constrained", squeeze=False)
    for i, case in enumerate(rows):
        data = [_section_data(case.results[m]) for m in cols]
        box = _window(data)
        for j, method in enumerate(cols):
            _draw_section(axes[i, j], data[j], box, case.results[method])
        axes[i, 0].set_ylabel(f"{case.label} beverage, |f| = {np.linalg.norm(data[0]['f']):.1f} N\n"
                              "$f_z$ (N)", fontsize=8)
    for ax in axes[-1]:
        ax.set_xlabel("$f_x$ (N)", fontsize=8)
    alpha = _section_data(rows[0].results[cols[0]])["alpha"]
    handles = [plt.Rectangle((0, 0), 1, 1, facecolor="0.8", edgecolor="0.3", label="residual force polytope P (α = 1)"),
               plt.Line2D([], [], color="0.3", ls="--", label=f"α·P, α = {alpha:g} (the metric's d)"),
               plt.Rectangle((0, 0), 1, 1, facecolor="orange", alpha=0.45, edgecolor="darkorange",
                             label="force ball: centre f, radius r"),
               plt.Line2D([], [], color="k", marker="x", ls="-", lw=1.0,
                          label="ray 0 → f; x: capacity along f")]
    axes[0, -1].legend(handles=handles, loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=8, frameon=False)
    fig.suptitle("Section 5.4: the residual force polytope's section by the vertical x-z plane through the force "
                 "ball's centre f (zoomed on the ball)", fontsize=10)
    return save(fig, directory, "hold_polytopes", fmt)


def plot_hold_ellipses(cases: list[Case], directory: Path, fmt: str) -> str:
    """Per configuration, the xy, xz and yz projections of the velocity-manipulability ellipsoid."""
    plt = pyplot()
    rows = cases[::-1]
    cols = list(rows[0].results)
    fig, axes = plt.subplots(len(rows), len(cols), figsize=(2.3 * len(cols) + 1.6, 2.5 * len(rows)),
                             sharex=True, sharey=True, layout="constrained", squeeze=False)
    theta = np.linspace(0, 2 * np.pi, 120)
    planes = {"xy": ((0, 1), "black", "-"), "xz": ((0, 2), "tab:cyan", "--"), "yz": ((1, 2), "tab:olive", ":")}
    for i, case in enumerate(rows):
        for j, method in enumerate(cols):
            ax, res = axes[i, j], case.results[method]
            J = res.task.robot.arm_jacobian(res.q[0])
            cov = J @ J.T
            for name, ((a, b), color, ls) in planes.items():
                w, U = np.linalg.eigh(cov[np.ix_([a, b], [a, b])])
                pts = U @ (np.sqrt(np.maximum(w, 0))[:, None] * np.vstack([np.cos(theta), np.sin(theta)]))
                ax.plot(pts[0], pts[1], color=color, ls=ls, lw=1.4, label=f"{name} plane")
            ax.set_aspect("equal")
            ax.grid(alpha=0.3)
            ax.tick_params(labelsize=7)
            ax.set_title(f"{style(method)[1]}\nμ = {res.metrics['manipulability'][0]:.3f} m³", fontsize=8)
        axes[i, 0].set_ylabel(f"{case.label} beverage", fontsize=9)
    axes[0, -1].legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=8, frameon=False)
    fig.supxlabel("first coordinate of the plane: x (xy, xz) or y (yz), end-effector speed (m/s)", fontsize=8)
    fig.supylabel("second coordinate: y (xy) or z (xz, yz) (m/s)", fontsize=8)
    fig.suptitle("Section 5.4: projections of the arm's velocity-manipulability ellipsoid {J q̇ : |q̇| ≤ 1 rad/s} "
                 f"on the xy, xz and yz planes\n{MANIP_DEF}", fontsize=9)
    return save(fig, directory, "hold_ellipsoids", fmt)


# -- run -------------------------------------------------------------------------------------
def run_hold(out: str | Path, trials: int = 3, waypoints: int | None = None, seed: int = 0,
             log: Log = quiet, fmt: str = "png",
             weight_factors: tuple[float, ...] = SWEEP_FACTORS, weights: str | None = None,
             torque_limits: str = "paper") -> dict[str, Any]:
    """Plan, simulate (nominal + ``trials`` seeded mass errors) and summarize Section 5.4 in ``out``.

    ``waypoints`` is accepted for a uniform interface (a hold task has one waypoint); ``fmt`` is
    the figure format (png, pdf or svg).
    ``weight_factors``: the RFP baselines' capability weight in the sweep of
    :mod:`forte.experiments.baseline_weights`, as multiples of the authors' (empty: no sweep).
    ``weights``: a weight set replacing the task file's (default: the task file's,
    ``forte-hold``); the summary names the set it used.
    ``torque_limits``: ``paper`` (60/12 Nm, the default) or ``urdf`` (the URDF's efforts, 87/12 Nm,
    a what-if), in planning and in every simulated run; the summary names them.
    """
    out, fmt = Path(out), check_format(fmt)
    cases = plan_payloads("hold", paper_methods("hold"), waypoints, log, weights, torque_limits)

    def build(tmp: Path) -> None:
        simulate_cases(tmp, cases, trials, seed, log, hold=HOLD_SECONDS)
        unloaded = unloaded_runs(tmp, cases[1], HOLD_SECONDS, log)
        sweep = weight_sweep_report(cases, tmp, weight_factors, trials, seed, HOLD_SECONDS, log, fmt, "5.4", "hold")
        figures = [plot_hold_metrics(cases, tmp, fmt), plot_hold_polytopes(cases, tmp, fmt),
                   plot_hold_ellipses(cases, tmp, fmt), *sweep.figures]
        write_summary(tmp, "Section 5.4: single-point holding", [
            "Task `examples/tasks/hold.yaml`: one end-effector pose; the optimized methods choose the whole-body "
            "configuration, `teaching` is the given teaching configuration. Payload 0.35 kg (0.33 L) and 2.7 kg "
            f"(2.7 L). Each configuration is held {HOLD_SECONDS:.0f} s in MuJoCo with the nominal mass, then "
            f"{trials} time(s) with a seeded payload-mass error uniform in ±{MASS_ERROR:.0%} (seed {seed}); a claim "
            "on the simulation counts only if it holds in every run."],
            cases, [*hold_claims(cases, unloaded), *sweep.claims], figures,
            {"trials": trials, "seed": seed, "mass_error": MASS_ERROR, "hold_s": HOLD_SECONDS,
             "unloaded_2p7_plans": unloaded, "format": fmt}, hold_notes(cases, unloaded), sweep.sections, sweep.extra)

    replace_directory(build, out)
    return json.loads((out / "summary.json").read_text())
