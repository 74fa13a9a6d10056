"""Figures of plans and comparisons (matplotlib, Agg backend: no display needed)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from forte.capability.metrics import ellipsoid_axes
from forte.capability.polytope import halfspaces, residual_margins, trajectory_rfp, vertices
from forte.planning.planner import Plan


def pyplot() -> Any:
    """matplotlib.pyplot with the non-interactive Agg backend (no display needed)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_capacity(results: list[Plan], path: Path) -> None:
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


def plot_manipulability(results: list[Plan], path: Path) -> None:
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


def worst_waypoint(result: Plan) -> int:
    return int(np.argmin(result.metrics["d"]))


def draw_polytope(ax: Any, result: Plan, k: int) -> None:
    """The RFP (alpha = 1) at waypoint k with the force ball, on a 3-D axis."""
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection
    from scipy.spatial import ConvexHull, QhullError

    robot = result.robot
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


def plot_polytope(result: Plan, path: Path) -> None:
    plt = pyplot()
    k = worst_waypoint(result)
    fig = plt.figure(figsize=(5.5, 5.5))
    ax = fig.add_subplot(projection="3d")
    draw_polytope(ax, result, k)
    ax.set_title(f"{result.method}: RFP at t = {result.t[k]:.2f} s (d = {result.metrics['d'][k]:.1f} N)", fontsize=9)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def draw_ellipses(axes: Any, result: Plan, k: int, color: str = "tab:green") -> None:
    """Projections of the velocity-manipulability ellipsoid on the xy, xz and yz planes."""
    J = result.robot.arm_jacobian(result.q[k])
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


def plot_ellipsoid(result: Plan, path: Path) -> None:
    plt = pyplot()
    k = worst_waypoint(result)
    fig, axes = plt.subplots(1, 3, figsize=(9, 3.2))
    draw_ellipses(axes, result, k)
    lengths, _ = ellipsoid_axes(result.robot.arm_jacobian(result.q[k]))
    fig.suptitle(f"{result.method}: manipulability ellipsoid at t = {result.t[k]:.2f} s, "
                 f"semi-axes {np.round(lengths, 3).tolist()} m/s", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_comparison(results: list[Plan], path: Path) -> None:
    """Capacity along f and manipulability of every method: bars (hold) or curves (trajectory)."""
    plt = pyplot()
    mode = results[0].task.mode if results[0].task is not None else "trajectory"
    if mode == "hold":
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
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plan_figures(plan: Plan, directory: Path) -> None:
    """The four figures of a plan directory."""
    plot_capacity([plan], directory / "capacity.png")
    plot_manipulability([plan], directory / "manipulability.png")
    plot_polytope(plan, directory / "rfp_worst.png")
    plot_ellipsoid(plan, directory / "ellipsoid.png")
