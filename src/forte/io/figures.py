"""Figures of plans and comparisons (matplotlib, Agg backend: no display needed).

Every figure uses the method colours and labels of :data:`forte.planning.methods.catalog.METHODS`, puts
its legend outside the data, labels its axes with units and says what each symbol is: ``f`` the
desired end-effector force, ``r`` the radius of its uncertainty ball, ``d`` the signed distance
of the ball to the RFP boundary (negative: the ball leaves the polytope). The file format is that
of :func:`figure_format` (PNG by default; PDF and SVG are vector).
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from contextvars import ContextVar
from pathlib import Path
from typing import Any

import numpy as np

from forte.capability.metrics import ellipsoid_axes
from forte.capability.polytope import facets, halfspaces, residual_margins, trajectory_rfp, vertices
from forte.exceptions import InvalidInputError
from forte.io.figure_processes import run_split
from forte.model.description import BASE_BOX_HALF_XY
from forte.model.scene import Box, Capsule, Cylinder, Mesh, SceneObject, mesh_vertices
from forte.planning.methods.catalog import METHODS
from forte.planning.planner import Plan

FORMATS = ("png", "pdf", "svg")
_FORMAT: ContextVar[str] = ContextVar("forte_figure_format", default="png")
BAND_COLOR = "#f4a261"


@contextlib.contextmanager
def figure_format(fmt: str) -> Iterator[None]:
    """Write the figures drawn inside the ``with`` block as ``fmt`` (png, pdf or svg)."""
    if fmt not in FORMATS:
        raise InvalidInputError(f"--format: expected one of {', '.join(FORMATS)}, got {fmt!r}")
    token = _FORMAT.set(fmt)
    try:
        yield
    finally:
        _FORMAT.reset(token)


def current_format() -> str:
    """The format in effect (:func:`figure_format`; png outside any block)."""
    return _FORMAT.get()


def figure_path(directory: Path, stem: str) -> Path:
    """``directory/stem.<format>`` in the format in effect."""
    return Path(directory) / f"{stem}.{_FORMAT.get()}"


def _save(fig: Any, path: Path) -> None:
    """Write ``fig`` (laid out by its constrained layout: no second, "tight" layout pass); PNGs
    with fast zlib compression (level 1: about a third less encoding time, files about 10 % larger)."""
    path = Path(path)
    fmt = path.suffix.lstrip(".").lower() or _FORMAT.get()
    extra = {"dpi": 150, "pil_kwargs": {"compress_level": 1}} if fmt == "png" else {}
    fig.savefig(path, format=fmt, **extra)


def style(method: str) -> tuple[str, str]:
    """(colour, label) of a method from the registry (grey and the name when unregistered)."""
    m = METHODS.get(method)
    return (m.style.color, m.style.label) if m is not None else ("0.4", method)


def pyplot() -> Any:
    """matplotlib.pyplot with the non-interactive Agg backend (no display needed)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _force_band(ax: Any, ref: Plan) -> None:
    mag = ref.force.magnitude
    ax.fill_between(ref.t, mag - ref.force.r, mag + ref.force.r, color=BAND_COLOR, alpha=0.35, lw=0,
                    label="|f| ± r (desired force ± uncertainty radius)")
    ax.plot(ref.t, mag, color="k", lw=1.2, label="|f| (desired force magnitude)")


def plot_capacity(results: list[Plan], path: Path) -> None:
    """Directional capacity (RFP boundary along f) vs time, with |f| and its ±r band."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.5, 3.6), layout="constrained")
    _force_band(ax, results[0])
    for res in results:
        color, label = style(res.method)
        # a plan that is not feasible is drawn dashed and says so in the legend
        verdict = "" if res.feasible or res.verdict is None else f" ({res.label})"
        ax.plot(res.t, res.metrics["directional_capacity"], color=color, lw=1.6, ls="-" if not verdict else "--",
                label=f"capacity along f: {label}{verdict}")
    ax.set_xlabel("time t (s)")
    ax.set_ylabel("force (N)")
    ax.grid(alpha=0.3)
    fig.legend(loc="outside lower center", ncol=2, fontsize=8, frameon=False)
    _save(fig, path)
    plt.close(fig)


def plot_manipulability(results: list[Plan], path: Path) -> None:
    """Yoshikawa manipulability sqrt(det(J J^T)) of the arm's translational Jacobian vs time."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.5, 3.2), layout="constrained")
    for res in results:
        color, label = style(res.method)
        ax.plot(res.t, res.metrics["manipulability"], color=color, lw=1.6, label=label)
    ax.set_xlabel("time t (s)")
    ax.set_ylabel("manipulability √det(J Jᵀ) (m³)")
    ax.grid(alpha=0.3)
    fig.legend(loc="outside lower center", ncol=4, fontsize=8, frameon=False)
    _save(fig, path)
    plt.close(fig)


def worst_waypoint(result: Plan) -> int:
    return int(np.argmin(result.metrics["d"]))


def _rfp_halfspaces(result: Plan, k: int) -> tuple[np.ndarray, np.ndarray]:
    robot = result.robot
    rfp = trajectory_rfp(robot, result.q, result.t, alpha=1.0)
    return halfspaces(rfp.J[k], *residual_margins(rfp.tau_nom[k], robot.torque_limits))


def _ball_wireframe(ax: Any, f: np.ndarray, r: float, color: str = "tab:red") -> None:
    u, v = np.mgrid[0:2 * np.pi:24j, 0:np.pi:12j]
    ax.plot_wireframe(f[0] + r * np.cos(u) * np.sin(v), f[1] + r * np.sin(u) * np.sin(v), f[2] + r * np.cos(v),
                      color=color, linewidth=0.4)


def draw_polytope(ax: Any, result: Plan, k: int, color: str | None = None) -> None:
    """The RFP (alpha = 1) at waypoint k with the force f and its ball of radius r, on a 3-D axis."""
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    color = color or style(result.method)[0]
    A, b = _rfp_halfspaces(result, k)
    V = vertices(A, b)
    polygons = facets(A, b, V)
    if polygons:
        ax.add_collection3d(Poly3DCollection(polygons, alpha=0.2, facecolor=color, edgecolor=color, linewidth=0.3))
    f, r = result.force.f[k], result.force.r[k]
    _ball_wireframe(ax, f, r)
    ax.quiver(0, 0, 0, *f, color="tab:red", linewidth=1.2, arrow_length_ratio=0.08)
    pts = np.vstack([V, f + r, f - r]) if len(V) else np.vstack([f + r, f - r])
    lim = np.max(np.abs(pts)) * 1.05 + 1e-9
    for setter in (ax.set_xlim, ax.set_ylim, ax.set_zlim):
        setter(-lim, lim)
    ax.set_xlabel("fx (N)", labelpad=-2)
    ax.set_ylabel("fy (N)", labelpad=-2)
    ax.set_zlabel("fz (N)", labelpad=-2)
    ax.tick_params(labelsize=7, pad=0)


def _slice_basis(f: np.ndarray) -> tuple[np.ndarray, np.ndarray, str]:
    """A vertical plane through f and the origin: (horizontal unit u, e_z, name of u)."""
    h = np.array([f[0], f[1], 0.0])
    if np.linalg.norm(h) < 1e-6 * max(1.0, np.linalg.norm(f)):
        return np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0]), "fx"
    u = h / np.linalg.norm(h)
    return u, np.array([0.0, 0.0, 1.0]), f"f along ({u[0]:.2f}, {u[1]:.2f}, 0)"


def slice_polygon(A: np.ndarray, b: np.ndarray, c: np.ndarray, e1: np.ndarray, e2: np.ndarray) -> np.ndarray:
    """Vertices (in order) of the slice ``{(s, t) : A (c + s e1 + t e2) <= b}`` (empty: 0 x 2)."""
    A2 = np.column_stack([A @ e1, A @ e2])
    b2 = b - A @ c
    norms = np.linalg.norm(A2, axis=1)
    flat = norms <= 1e-12
    if np.any(b2[flat] < 0):
        return np.zeros((0, 2))
    A2, b2 = A2[~flat], b2[~flat]
    pts = []
    for i in range(len(A2)):
        for j in range(i + 1, len(A2)):
            M = A2[[i, j]]
            if abs(np.linalg.det(M)) > 1e-10 * np.linalg.norm(M[0]) * np.linalg.norm(M[1]):
                pts.append(np.linalg.solve(M, b2[[i, j]]))
    if not pts:
        return np.zeros((0, 2))
    P = np.array(pts)
    scale = max(1.0, float(np.abs(b2).max()))
    P = P[np.all(P @ A2.T <= b2 + 1e-7 * scale, axis=1)]
    if len(P) < 3:
        return np.zeros((0, 2))
    centre = P.mean(axis=0)
    return P[np.argsort(np.arctan2(P[:, 1] - centre[1], P[:, 0] - centre[0]))]


def draw_slice(ax: Any, result: Plan, k: int, color: str | None = None) -> None:
    """Zoomed 2-D slice of the RFP through the ball's centre f (a vertical plane through f and 0)."""
    color = color or style(result.method)[0]
    A, b = _rfp_halfspaces(result, k)
    f, r = result.force.f[k], float(result.force.r[k])
    e1, e2, name = _slice_basis(f)
    fc = np.array([f @ e1, f @ e2])
    poly = slice_polygon(A, b, np.zeros(3), e1, e2)
    if len(poly):
        closed = np.vstack([poly, poly[:1]])
        ax.fill(closed[:, 0], closed[:, 1], color=color, alpha=0.2, lw=0)
        ax.plot(closed[:, 0], closed[:, 1], color=color, lw=1.2, label="RFP boundary (slice)")
    theta = np.linspace(0, 2 * np.pi, 200)
    ax.plot(fc[0] + r * np.cos(theta), fc[1] + r * np.sin(theta), color="tab:red", lw=1.2,
            label=f"force ball, radius r = {r:.0f} N")
    ax.plot(*fc, "+", color="tab:red", ms=9, mew=1.5, label=f"desired force f (|f| = {np.linalg.norm(f):.1f} N)")
    d = float(result.metrics["d"][k])
    reach = max(4 * r, 1.3 * (abs(d) + r)) if np.isfinite(d) else 4 * r
    ax.set_xlim(fc[0] - reach, fc[0] + reach)
    ax.set_ylim(fc[1] - reach, fc[1] + reach)
    ax.set_aspect("equal")
    ax.set_xlabel(f"{name} (N)")
    ax.set_ylabel("fz (N)")
    ax.grid(alpha=0.3)


def plot_polytope(result: Plan, path: Path) -> None:
    """The RFP at the worst waypoint (least d): full 3-D polytope beside a zoomed slice through f."""
    plt = pyplot()
    k = worst_waypoint(result)
    fig = plt.figure(figsize=(9.5, 4.6), layout="constrained")
    ax3 = fig.add_subplot(1, 2, 1, projection="3d")
    draw_polytope(ax3, result, k)
    ax3.set_title("full residual force polytope (RFP)", fontsize=9)
    ax2 = fig.add_subplot(1, 2, 2)
    draw_slice(ax2, result, k)
    ax2.set_title("zoom: vertical slice through f", fontsize=9)
    label = style(result.method)[1]
    fig.suptitle(f"{label}: RFP at t = {result.t[k]:.2f} s, the waypoint of least d "
                 f"(d = {result.metrics['d'][k]:.1f} N: the ball's 3-D margin to the RFP scaled by the metric's α)",
                 fontsize=9)
    fig.legend(*ax2.get_legend_handles_labels(), loc="outside lower center", ncol=3, fontsize=8, frameon=False)
    _save(fig, path)
    plt.close(fig)


def draw_ellipses(axes: Any, result: Plan, k: int, color: str | None = None) -> None:
    """Projections of the velocity-manipulability ellipsoid ``{J w : |w| <= 1 rad/s}`` on xy, xz, yz."""
    color = color or style(result.method)[0]
    J = result.robot.arm_jacobian(result.q[k])
    cov = J @ J.T
    theta = np.linspace(0, 2 * np.pi, 100)
    for ax, (i, j) in zip(axes, [(0, 1), (0, 2), (1, 2)], strict=True):
        sub = cov[np.ix_([i, j], [i, j])]
        w, U = np.linalg.eigh(sub)
        pts = U @ (np.sqrt(np.maximum(w, 0))[:, None] * np.vstack([np.cos(theta), np.sin(theta)]))
        ax.plot(pts[0], pts[1], color=color, label=style(result.method)[1])
        ax.set_aspect("equal")
        ax.set_xlabel("v" + "xyz"[i] + " (m/s)")
        ax.set_ylabel("v" + "xyz"[j] + " (m/s)")
        ax.grid(alpha=0.3)


def plot_ellipsoid(result: Plan, path: Path) -> None:
    """The velocity-manipulability ellipsoid at the worst waypoint, projected on three planes."""
    plt = pyplot()
    k = worst_waypoint(result)
    fig, axes = plt.subplots(1, 3, figsize=(9, 3.4), layout="constrained")
    draw_ellipses(axes, result, k)
    lengths, _ = ellipsoid_axes(result.robot.arm_jacobian(result.q[k]))
    fig.suptitle(f"{style(result.method)[1]}: end-effector velocities v = J q̇ for joint speeds |q̇| ≤ 1 rad/s "
                 f"at t = {result.t[k]:.2f} s (semi-axes {', '.join(f'{x:.3f}' for x in lengths)} m/s)", fontsize=9)
    _save(fig, path)
    plt.close(fig)


def plot_comparison(results: list[Plan], path: Path) -> None:
    """Every method side by side: grouped bars and points (hold: categories) or curves over time."""
    plt = pyplot()
    mode = results[0].task.mode if results[0].task is not None else ("hold" if len(results[0].t) == 1
                                                                      else "trajectory")
    styles = [style(r.method) for r in results]
    if mode == "hold":
        fig, (ax, ax2) = plt.subplots(1, 2, figsize=(9, 3.8), layout="constrained")
        x = np.arange(len(results))
        labels = [label for _, label in styles]
        caps = [float(r.metrics["directional_capacity"][0]) for r in results]
        ax.bar(x, caps, color=[c for c, _ in styles], width=0.6, edgecolor="k", linewidth=0.5)
        need, rad = float(results[0].force.magnitude[0]), float(results[0].force.r[0])
        ax.axhline(need + rad, color="tab:red", ls="--", lw=1.2, label=f"|f| + r = {need + rad:.1f} N")
        ax.axhline(need, color="k", lw=1.0, label=f"|f| = {need:.1f} N (desired force)")
        ax.set_ylabel("capacity along f (N)")
        ax.set_title("force capacity (bar above the dashed line: enough)", fontsize=9)
        ax2.scatter(x, [float(r.metrics["manipulability"][0]) for r in results], c=[c for c, _ in styles],
                    s=60, edgecolor="k", linewidth=0.5, zorder=3)
        ax2.set_ylabel("manipulability √det(J Jᵀ) (m³)")
        ax2.set_title("manipulability (points: one per method)", fontsize=9)
        for a in (ax, ax2):
            a.set_xticks(x, labels, rotation=20, ha="right", fontsize=8)
            a.grid(axis="y", alpha=0.3)
        ax2.set_ylim(bottom=0)
        fig.legend(*ax.get_legend_handles_labels(), loc="outside lower center", ncol=2, fontsize=8, frameon=False)
    else:
        fig, (ax, ax2) = plt.subplots(2, 1, figsize=(7, 6), sharex=True, layout="constrained")
        _force_band(ax, results[0])
        for r, (color, label) in zip(results, styles, strict=True):
            ax.plot(r.t, r.metrics["directional_capacity"], color=color, lw=1.5, label=label)
            ax2.plot(r.t, r.metrics["manipulability"], color=color, lw=1.5)
        ax.set_ylabel("capacity along f (N)")
        ax2.set_ylabel("manipulability √det(J Jᵀ) (m³)")
        ax2.set_xlabel("time t (s)")
        ax.grid(alpha=0.3)
        ax2.grid(alpha=0.3)
        fig.legend(*ax.get_legend_handles_labels(), loc="outside lower center", ncol=3, fontsize=8, frameon=False)
    _save(fig, path)
    plt.close(fig)


def footprint(obj: SceneObject, samples: int = 48) -> np.ndarray:
    """The outline (M x 2, counter-clockwise) of a scene body seen from above: the convex hull of
    its corners, of its end circles (cylinder, capsule, sphere) or of its vertices (mesh)."""
    s, R, p = obj.shape, obj.pose[:3, :3], obj.pose[:3, 3]
    a = np.linspace(0, 2 * np.pi, samples, endpoint=False)
    circle = np.column_stack([np.cos(a), np.sin(a), np.zeros_like(a)])
    if isinstance(s, Box):
        local = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * np.asarray(s.size) / 2
    elif isinstance(s, Mesh):
        local = mesh_vertices(s)
    elif isinstance(s, Cylinder):  # its end circles
        local = np.vstack([s.radius * circle + [0, 0, z] for z in (-s.length / 2, s.length / 2)])
    else:  # sphere, capsule: a ball seen from above is a disk around its centre's projection
        half = s.length / 2 if isinstance(s, Capsule) else 0.0
        centres = np.array([[0, 0, -half], [0, 0, half]]) @ R.T + p
        return _hull(np.vstack([c[:2] + s.radius * circle[:, :2] for c in centres]))
    return _hull((local @ R.T + p)[:, :2])


def _hull(points: np.ndarray) -> np.ndarray:
    """Convex hull of 2-D points, counter-clockwise (Andrew's monotone chain)."""
    pts = sorted(map(tuple, np.round(points, 12)))

    def chain(seq: list[tuple[float, float]]) -> list[tuple[float, float]]:
        out: list[tuple[float, float]] = []
        for p in seq:
            while len(out) >= 2 and ((out[-1][0] - out[-2][0]) * (p[1] - out[-2][1])
                                     - (out[-1][1] - out[-2][1]) * (p[0] - out[-2][0])) <= 0:
                out.pop()
            out.append(p)
        return out

    lower, upper = chain(pts), chain(pts[::-1])
    return np.array(lower[:-1] + upper[:-1])


def plot_scene(plan: Plan, path: Path) -> None:
    """Top-down view: the scene's footprints, the base path with the base box at the start and
    the end, and the end-effector path (x, y in the world frame)."""
    plt = pyplot()
    color, label = style(plan.method)
    fig, ax = plt.subplots(figsize=(6, 5), layout="constrained")
    for obj in plan.scene.objects:
        outline = footprint(obj)
        ax.fill(*outline.T, color="0.75", edgecolor="0.35", lw=0.8)
        ax.annotate(obj.name, obj.pose[:2, 3], ha="center", va="center", fontsize=7)
    box = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1], [-1, -1]]) * BASE_BOX_HALF_XY
    for k, ls in ((0, ":"), (-1, "-")):
        x, y, yaw = plan.q[k, :3]
        R = np.array([[np.cos(yaw), -np.sin(yaw)], [np.sin(yaw), np.cos(yaw)]])
        ax.plot(*(box @ R.T + [x, y]).T, color="k", ls=ls, lw=0.8)
    ax.plot(plan.q[:, 0], plan.q[:, 1], color="k", lw=1.2, label="base path (box: start dotted, end solid)")
    ee = np.array([plan.robot.ee_position(q) for q in plan.q])
    ax.plot(ee[:, 0], ee[:, 1], color=color, lw=1.2, label=f"end effector ({label})")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title("scene seen from above (grey: the bodies' footprints)", fontsize=9)
    ax.grid(alpha=0.3)
    fig.legend(*ax.get_legend_handles_labels(), loc="outside lower center", ncol=2, fontsize=8, frameon=False)
    _save(fig, path)
    plt.close(fig)


def plan_figures(plan: Plan, directory: Path) -> None:
    """The four figures of a plan directory (in the format of :func:`figure_format`), and
    ``scene`` (:func:`plot_scene`) when the plan has one, drawn here: two groups in two processes
    where :func:`~forte.io.figure_processes.run_split` can fork (about 0.3 s of CPU time each).
    :func:`forte.io.figure_worker.draw_plan_figures` hands them to a worker forked earlier."""
    scene = [lambda: plot_scene(plan, figure_path(directory, "scene"))] if plan.scene else []
    run_split([
        [lambda: plot_polytope(plan, figure_path(directory, "rfp_worst")),
         lambda: plot_manipulability([plan], figure_path(directory, "manipulability"))],
        [lambda: plot_ellipsoid(plan, figure_path(directory, "ellipsoid")),
         lambda: plot_capacity([plan], figure_path(directory, "capacity")), *scene],
    ])
