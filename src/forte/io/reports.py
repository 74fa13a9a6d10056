"""Reports: plan directories (CSV, JSON, figures), written atomically, and comparisons.

A plan directory holds ``trajectory.csv``, ``metrics.csv``, ``plan.json`` and PNG figures. It is
first written to a temporary sibling and then renamed into place, so a crash never leaves a
half-written directory. A failed optimization never replaces a directory that holds a
successful plan: it goes to ``DIR.failed`` instead (and its ``plan.json`` says why).
"""

from __future__ import annotations

import csv
import json
import os
import platform
import shutil
import tempfile
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np

from forte.capability.metrics import ellipsoid_axes
from forte.capability.polytope import halfspaces, residual_margins, trajectory_rfp, vertices
from forte.model.trajectory import trajectory_header
from forte.planning.planner import PlanResult

METRIC_COLUMNS = ("t", "fx", "fy", "fz", "radius", "d", "directional_capacity", "capacity_margin",
                  "inscribed_radius", "manipulability", "max_torque_ratio", "max_torque_ratio_with_force")
PACKAGES = ("forte", "numpy", "scipy", "casadi", "pin", "example-robot-data", "matplotlib", "mujoco", "openai")


def package_versions() -> dict[str, str]:
    out = {"python": platform.python_version()}
    for name in PACKAGES:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = "not installed"
    return out


def _write_csv(path: Path, header: list[str], rows: np.ndarray) -> None:
    with path.open("w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(header)
        for row in rows:
            writer.writerow([repr(float(v)) for v in row])


def jsonable(value: Any) -> Any:
    """``value`` with numpy types, paths and non-finite floats turned into plain JSON values."""
    if isinstance(value, dict):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return jsonable(value.tolist())
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, float) and not np.isfinite(value):
        return str(value)
    if isinstance(value, Path):
        return str(value)
    return value


def plan_summary(result: PlanResult) -> dict[str, float]:
    """The quantities the paper discusses, for one plan."""
    m = result.metrics
    return {
        "min_d": float(np.min(m["d"])),
        "min_capacity_margin": float(np.min(m["capacity_margin"])),
        "mean_manipulability": float(np.mean(m["manipulability"])),
        "min_manipulability": float(np.min(m["manipulability"])),
        "max_torque_ratio": float(np.max(m["max_torque_ratio"])),
        "max_torque_ratio_with_force": float(np.max(m["max_torque_ratio_with_force"])),
        "waypoints_with_d_negative": int(np.sum(m["d"] < 0)),
    }


def plan_document(result: PlanResult) -> dict[str, Any]:
    """Everything ``plan.json`` records."""
    from dataclasses import asdict

    task = result.task
    return jsonable({
        "task": {"name": task.name, "file": str(task.source) if task.source else None, "mode": task.mode,
                 "waypoints": task.n, "duration_s": float(task.t[-1] - task.t[0]), "definition": task.raw},
        "method": result.method,
        "status": "success" if result.success else "failure",
        "solver_status": result.status,
        "solver": result.solver,
        "weights": asdict(task.weights),
        "solver_options": asdict(task.solver),
        "kinematic_limits": asdict(task.limits),
        "robot": task.robot.describe() | {"alpha": task.weights.capability_params.alpha},
        "payload": {"mass": task.payload.get("mass"), "description": task.payload.get("description"),
                    "image": task.payload.get("image"), "estimate": result.estimate},
        "force": {"t": task.t, "f": result.force.f, "r": result.force.r,
                  "given_profile": task.force_profile is not None},
        "q_init": task.q_init,
        "summary": plan_summary(result),
        "versions": package_versions(),
    })


# -- figures ------------------------------------------------------------------------------
def pyplot() -> Any:
    """matplotlib.pyplot with the non-interactive Agg backend (no display needed)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_capacity(results: list[PlanResult], path: Path) -> None:
    """Directional capacity vs time, with the desired |f| and its +-r band."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7, 3.6))
    ref = results[0]
    mag = ref.force.magnitude
    ax.fill_between(ref.t, mag - ref.force.r, mag + ref.force.r, color="orange", alpha=0.3, label="|f| ± r")
    ax.plot(ref.t, mag, "k-", lw=1.5, label="|f| desired")
    for res in results:
        ax.plot(res.t, res.metrics["directional_capacity"], lw=1.5, label=res.method)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("RFP capacity along f (N)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, ncol=2)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_manipulability(results: list[PlanResult], path: Path) -> None:
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7, 3.2))
    for res in results:
        ax.plot(res.t, res.metrics["manipulability"], lw=1.5, label=res.method)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("manipulability (Yoshikawa)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def worst_waypoint(result: PlanResult) -> int:
    return int(np.argmin(result.metrics["d"]))


def draw_polytope(ax: Any, result: PlanResult, k: int) -> None:
    """The RFP (alpha = 1) at waypoint k with the force ball, on a 3-D axis."""
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection
    from scipy.spatial import ConvexHull, QhullError

    robot = result.task.robot
    rfp = trajectory_rfp(robot, result.q, result.t, alpha=1.0)
    A, b = halfspaces(rfp.J[k], *residual_margins(rfp.tau_nom[k], robot.torque_limits))
    V = vertices(A, b)
    if len(V) >= 4:
        try:
            hull = ConvexHull(V)
            ax.add_collection3d(Poly3DCollection(V[hull.simplices], alpha=0.25, facecolor="tab:blue",
                                                 edgecolor="tab:blue", linewidth=0.3))
        except QhullError:
            pass
    f, r = result.force.f[k], result.force.r[k]
    u, v = np.mgrid[0:2 * np.pi:24j, 0:np.pi:12j]
    ax.plot_wireframe(f[0] + r * np.cos(u) * np.sin(v), f[1] + r * np.sin(u) * np.sin(v), f[2] + r * np.cos(v),
                      color="tab:red", linewidth=0.4)
    pts = np.vstack([V, f + r, f - r]) if len(V) else np.vstack([f + r, f - r])
    lim = np.max(np.abs(pts)) * 1.05 + 1e-9
    ax.set_xlim(-lim, lim)
    ax.set_ylim(-lim, lim)
    ax.set_zlim(-lim, lim)
    ax.set_xlabel("fx (N)")
    ax.set_ylabel("fy (N)")
    ax.set_zlabel("fz (N)")


def plot_polytope(result: PlanResult, path: Path) -> None:
    plt = pyplot()
    k = worst_waypoint(result)
    fig = plt.figure(figsize=(5.5, 5.5))
    ax = fig.add_subplot(projection="3d")
    draw_polytope(ax, result, k)
    ax.set_title(f"{result.method}: RFP at t = {result.t[k]:.2f} s (d = {result.metrics['d'][k]:.1f} N)", fontsize=9)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def draw_ellipses(axes: Any, result: PlanResult, k: int, color: str = "tab:green") -> None:
    """Projections of the velocity-manipulability ellipsoid on the xy, xz and yz planes."""
    J = result.task.robot.arm_jacobian(result.q[k])
    cov = J @ J.T
    theta = np.linspace(0, 2 * np.pi, 100)
    for ax, (i, j) in zip(axes, [(0, 1), (0, 2), (1, 2)], strict=True):
        sub = cov[np.ix_([i, j], [i, j])]
        w, U = np.linalg.eigh(sub)
        pts = U @ (np.sqrt(np.maximum(w, 0))[:, None] * np.vstack([np.cos(theta), np.sin(theta)]))
        ax.plot(pts[0], pts[1], color=color, label=result.method)
        ax.set_aspect("equal")
        ax.set_xlabel("xyz"[i] + " (m/s)")
        ax.set_ylabel("xyz"[j] + " (m/s)")
        ax.grid(alpha=0.3)


def plot_ellipsoid(result: PlanResult, path: Path) -> None:
    plt = pyplot()
    k = worst_waypoint(result)
    fig, axes = plt.subplots(1, 3, figsize=(9, 3.2))
    draw_ellipses(axes, result, k)
    lengths, _ = ellipsoid_axes(result.task.robot.arm_jacobian(result.q[k]))
    fig.suptitle(f"{result.method}: manipulability ellipsoid at t = {result.t[k]:.2f} s, "
                 f"semi-axes {np.round(lengths, 3).tolist()} m/s", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


# -- plan directories ---------------------------------------------------------------------
def _fill(result: PlanResult, directory: Path, figures: bool) -> None:
    task = result.task
    # a failed optimization keeps its last iterate, never under the name of a plan
    name = "trajectory.csv" if result.success else "last_iterate.csv"
    _write_csv(directory / name, trajectory_header(task.robot.n_arm), np.column_stack([task.t, result.q]))
    rows = np.column_stack([result.metrics[c] for c in METRIC_COLUMNS])
    _write_csv(directory / "metrics.csv", list(METRIC_COLUMNS), rows)
    (directory / "plan.json").write_text(json.dumps(plan_document(result), indent=2))
    if figures:
        plot_capacity([result], directory / "capacity.png")
        plot_manipulability([result], directory / "manipulability.png")
        plot_polytope(result, directory / "rfp_worst.png")
        plot_ellipsoid(result, directory / "ellipsoid.png")


def holds_success(directory: Path) -> bool:
    try:
        return json.loads((directory / "plan.json").read_text()).get("status") == "success"
    except (OSError, ValueError):
        return False


def replace_directory(build: Any, out: Path) -> None:
    """Build a directory with ``build(tmp_path)`` and move it to ``out`` in one rename."""
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=out.parent))
    try:
        build(tmp)
        if out.exists():
            old = Path(tempfile.mkdtemp(prefix=f".{out.name}.old.", dir=out.parent))
            os.replace(out, old / "previous")
            os.replace(tmp, out)
            shutil.rmtree(old, ignore_errors=True)
        else:
            os.replace(tmp, out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


def write_plan(result: PlanResult, out: Path, figures: bool = True) -> Path:
    """Write a plan directory atomically; returns where it went (``out`` or ``out.failed``)."""
    out = Path(out)
    target = out
    if not result.success and holds_success(out):
        target = out.with_name(out.name + ".failed")
    replace_directory(lambda d: _fill(result, d, figures), target)
    return target


def comparison_rows(results: list[PlanResult]) -> list[dict[str, Any]]:
    rows = []
    for res in results:
        row: dict[str, Any] = {"method": res.method, "status": "success" if res.success else "failure"}
        row.update(plan_summary(res))
        row["solve_time_s"] = res.solver.get("solve_time_s", 0.0)
        row["iterations"] = res.solver.get("iterations", 0)
        rows.append(row)
    return rows


def write_comparison(results: list[PlanResult], directory: Path) -> None:
    """summary.md, summary.csv and comparison.png for the plans of every method."""
    rows = comparison_rows(results)
    keys = list(rows[0])
    with (directory / "summary.csv").open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=keys)
        writer.writeheader()
        writer.writerows(rows)
    task = results[0].task
    lines = [f"# {task.name}: comparison ({task.mode}, {task.n} waypoints, payload "
             f"{task.payload.get('mass', 'given force profile')} kg)", "",
             "| method | status | min d (N) | min capacity − (\\|f\\| + r) (N) | mean manipulability | "
             "max torque ratio (nominal / with force) | solve (s) |",
             "|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['method']} | {r['status']} | {r['min_d']:.2f} | {r['min_capacity_margin']:.2f} | "
                     f"{r['mean_manipulability']:.4f} | {r['max_torque_ratio']:.2f} / "
                     f"{r['max_torque_ratio_with_force']:.2f} | {r['solve_time_s']:.2f} |")
    (directory / "summary.md").write_text("\n".join(lines) + "\n")
    plt = pyplot()
    if task.mode == "hold":
        fig, ax = plt.subplots(figsize=(7, 3.5))
        names = [r.method for r in results]
        caps = [r.metrics["directional_capacity"][0] for r in results]
        ax.bar(names, caps, color="tab:blue", alpha=0.7, label="capacity along f")
        need = results[0].force.magnitude[0]
        rad = results[0].force.r[0]
        ax.axhspan(need - rad, need + rad, color="orange", alpha=0.3, label="|f| ± r")
        ax.set_ylabel("N")
        ax2 = ax.twinx()
        ax2.plot(names, [r.metrics["manipulability"][0] for r in results], "o-", color="tab:green",
                 label="manipulability")
        ax2.set_ylabel("manipulability")
        ax.legend(loc="upper left", fontsize=8)
        ax2.legend(loc="upper right", fontsize=8)
    else:
        fig, (ax, ax2) = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
        ref = results[0]
        mag = ref.force.magnitude
        ax.fill_between(ref.t, mag - ref.force.r, mag + ref.force.r, color="orange", alpha=0.3, label="|f| ± r")
        ax.plot(ref.t, mag, "k-", label="|f|")
        for r in results:
            ax.plot(r.t, r.metrics["directional_capacity"], label=r.method)
            ax2.plot(r.t, r.metrics["manipulability"], "--", label=r.method)
        ax.set_ylabel("capacity along f (N)")
        ax2.set_ylabel("manipulability")
        ax2.set_xlabel("time (s)")
        ax.legend(fontsize=8, ncol=3)
        ax.grid(alpha=0.3)
        ax2.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(directory / "comparison.png", dpi=110)
    plt.close(fig)
