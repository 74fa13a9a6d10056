"""Dynamic residual force polytope (RFP, paper Section 3.2) and the geometry built on it.

For waypoint ``k`` with nominal torque ``tau_nom,k = RNEA(q_k, dq_k, ddq_k)`` the residual
torque margins are ``tau+ = tau_max - tau_nom`` and ``tau- = -tau_max - tau_nom``, and the RFP is

    P_k = { f in R^3 : alpha tau- <= J_t(q_k)^T f <= alpha tau+ }  =  { f : A_k f <= b_k },
    A_k = [J_t ; -J_t]^T (2n x 3),   b_k = alpha [tau+ ; -tau-].

With ``alpha = 1`` this is the paper's ``P_{r,k}``; the metric of Section 4.2 uses
``0 < alpha <= 1`` to shrink the residual torque interval. All functions broadcast over
leading batch dimensions (``A``: ... x 2n x 3, ``b``: ... x 2n).

Rows with a zero normal (the Panda's joint 7 at its hand frames, whose axis passes through the
end effector) do not constrain ``f``: they are vacuous when ``b_i >= 0`` and make the polytope
empty when ``b_i < 0`` (the nominal motion alone exceeds that joint's limit).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from functools import cached_property
from typing import Any, NamedTuple

import numpy as np

from forte.exceptions import InvalidInputError
from forte.model.robot import MobileManipulator
from forte.model.trajectory import StartMotion, backward_differences
from forte.validation import FloatArray, as_array, check_times

#: Normals shorter than this are treated as zero (units of the Jacobian, m).
ZERO_NORMAL = 1e-9


def nominal_torques(robot: MobileManipulator, q: Any, t: Any, start: StartMotion | None = None) -> FloatArray:
    """``tau_nom,k = RNEA(q_a,k, dq_a,k, ddq_a,k)`` (N x n) with backward differences.

    Args:
        q: Whole-body configurations (N x nq); only the arm part enters the dynamics.
        t: Strictly increasing time stamps (N).
        start: The first waypoint's whole-body motion (default: at rest).
    """
    times = check_times(t)
    Q = as_array(q, "q", (times.size, robot.nq))
    qa = Q[:, 3:]
    dq, ddq = backward_differences(qa, times, "q_a", None if start is None else start.columns(slice(3, None)))
    return robot.rnea_along(qa, dq, ddq)


def residual_margins(tau_nom: Any, tau_max: Any, tau_min: Any = None) -> tuple[FloatArray, FloatArray]:
    """``(tau+, tau-) = (tau_max - tau_nom, tau_min - tau_nom)``; ``tau_min`` defaults to -tau_max."""
    tau_nom = np.asarray(tau_nom, dtype=float)
    tau_max = np.asarray(tau_max, dtype=float)
    tau_min = -tau_max if tau_min is None else np.asarray(tau_min, dtype=float)
    return tau_max - tau_nom, tau_min - tau_nom


class HalfSpaces(NamedTuple):
    """A polytope ``{f : A f <= b}`` (``A``: ... x m x 3, ``b``: ... x m); unpacks as ``A, b``."""

    A: FloatArray
    b: FloatArray


def halfspaces(J: Any, tau_plus: Any, tau_minus: Any, alpha: float = 1.0) -> HalfSpaces:
    """Half-space form ``A f <= b`` of the RFP from ``J`` (... x 3 x n) and the margins."""
    if not 0.0 < alpha <= 1.0:
        raise InvalidInputError(f"alpha: expected 0 < alpha <= 1, got {alpha}")
    J = np.asarray(J, dtype=float)
    Jt = np.swapaxes(J, -1, -2)
    A = np.concatenate([Jt, -Jt], axis=-2)
    b = alpha * np.concatenate([np.asarray(tau_plus), -np.asarray(tau_minus)], axis=-1)
    return HalfSpaces(A, b)


@dataclass(frozen=True)
class ResidualForcePolytope:
    """The dynamic RFP at one configuration: ``{f : A f <= b}``, the paper's ``A_k, b_k``
    (pycapacity writes ``H f <= d``; forte keeps ``d`` for the margin ``d_k``).

    Attributes:
        A, b: half-space form (``2n x 3``, ``2n``), ``A = [J_t; -J_t]^T``,
            ``b = alpha [tau_max - tau_nom; tau_max + tau_nom]``.
        J: world-frame translational Jacobian (3 x n); tau_nom: nominal torque (n).
        alpha: scale of the residual torque interval.
    """

    A: FloatArray
    b: FloatArray
    J: FloatArray
    tau_nom: FloatArray
    alpha: float = 1.0

    @cached_property
    def vertices(self) -> FloatArray:
        """Vertices (V x 3); empty when the polytope is empty."""
        return vertices(self.A, self.b)

    @cached_property
    def faces(self) -> FloatArray:
        """Triangles of the convex hull as rows of vertex indices (F x 3)."""
        from scipy.spatial import ConvexHull

        return ConvexHull(self.vertices).simplices if len(self.vertices) >= 4 else np.zeros((0, 3), int)

    def contains(self, f: Any, tol: float = 1e-9) -> bool:
        return bool(contains(self.A, self.b, f, tol))

    def capacity_along(self, u: Any) -> float:
        """Distance from the origin to the boundary along ``u`` (the paper's directional capacity)."""
        return float(directional_capacity(self.A, self.b, u))

    @property
    def inscribed_radius(self) -> float:
        """Radius of the largest ball centred at the origin inside the polytope."""
        return float(inscribed_radius(self.A, self.b))


def residual_force_polytope(robot: MobileManipulator, q: Any, dq_a: Any = None, ddq_a: Any = None,
                            alpha: float = 1.0) -> ResidualForcePolytope:
    """The RFP at whole-body configuration ``q`` with arm velocity and acceleration (default rest).

    Examples:
        >>> import forte
        >>> robot = forte.default_robot()
        >>> rfp = forte.residual_force_polytope(robot, robot.home())
        >>> rfp.A.shape, bool(rfp.contains([0.0, 0.0, 20.0]))
        ((14, 3), True)
    """
    q = robot.check_configuration(q)
    zeros = np.zeros(robot.n_arm)
    tau = robot.rnea(q[3:], zeros if dq_a is None else dq_a, zeros if ddq_a is None else ddq_a)
    J = robot.arm_jacobian(q)
    A, b = halfspaces(J, *residual_margins(tau, robot.torque_limits), alpha=alpha)
    return ResidualForcePolytope(A, b, J, tau, alpha)


@dataclass(frozen=True)
class TrajectoryRFP:
    """The dynamic RFP along a trajectory: Jacobians, nominal torques and half-spaces."""

    J: FloatArray  # N x 3 x n, world frame
    tau_nom: FloatArray  # N x n
    A: FloatArray  # N x 2n x 3
    b: FloatArray  # N x 2n
    alpha: float

    def at(self, k: int) -> ResidualForcePolytope:
        """The polytope of waypoint ``k``."""
        return ResidualForcePolytope(self.A[k], self.b[k], self.J[k], self.tau_nom[k], self.alpha)


def trajectory_rfp(robot: MobileManipulator, q: Any, t: Any, alpha: float = 1.0,
                   start: StartMotion | None = None) -> TrajectoryRFP:
    """Dynamic RFPs of a whole-body trajectory ``q`` (N x nq) at times ``t`` (``start``: the first
    waypoint's motion, default at rest)."""
    tau_nom = nominal_torques(robot, q, t, start)
    J = robot.arm_jacobians(q)
    A, b = halfspaces(J, *residual_margins(tau_nom, robot.torque_limits), alpha=alpha)
    return TrajectoryRFP(J=J, tau_nom=tau_nom, A=A, b=b, alpha=alpha)


def _row_norms(A: FloatArray) -> FloatArray:
    return np.linalg.norm(A, axis=-1)


def contains(A: FloatArray, b: FloatArray, f: Any, tol: float = 1e-9) -> FloatArray:
    """Whether the point(s) ``f`` satisfy every half-space (with tolerance ``tol``)."""
    f = np.asarray(f, dtype=float)
    return np.all(np.einsum("...ij,...j->...i", A, f) <= b + tol, axis=-1)


def directional_capacity(A: FloatArray, b: FloatArray, u: Any) -> FloatArray:
    """Distance from the origin to the RFP boundary along the unit direction ``u``.

    ``min over rows with a_i . u > 0 of b_i / (a_i . u)``: the force magnitude at which the ray
    from the origin along ``u`` leaves the polytope (the paper's "directional capacity"). It is
    negative when the origin itself lies outside, and ``inf`` when the ray never leaves.
    """
    u = np.asarray(u, dtype=float)
    norms = np.linalg.norm(u, axis=-1, keepdims=True)
    if np.any(norms < 1e-12):
        raise InvalidInputError("direction: expected a non-zero vector")
    u = u / norms
    proj = np.einsum("...ij,...j->...i", A, u)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(proj > ZERO_NORMAL, b / np.where(proj > ZERO_NORMAL, proj, 1.0), np.inf)
    return ratio.min(axis=-1)


def inscribed_radius(A: FloatArray, b: FloatArray) -> FloatArray:
    """Radius of the largest ball centred at the origin inside the RFP (Ferrolho et al. 2021).

    ``min_i b_i / ||a_i||`` over rows with a non-zero normal; negative when the origin is
    outside, ``-inf`` when a zero-normal row makes the polytope empty.
    """
    norms = _row_norms(A)
    live = norms > ZERO_NORMAL
    with np.errstate(divide="ignore", invalid="ignore"):
        dist = np.where(live, b / np.where(live, norms, 1.0), np.where(b >= 0, np.inf, -np.inf))
    return dist.min(axis=-1)


def cone_directions(u: Any, half_angle: float = 0.35, rings: int = 3, azimuths: int = 8) -> FloatArray:
    """Unit rays of the linearized cone around ``u``: the axis plus ``rings x azimuths`` rays."""
    u = np.asarray(u, dtype=float)
    u = u / np.linalg.norm(u)
    helper = np.array([1.0, 0.0, 0.0]) if abs(u[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(u, helper)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(u, e1)
    rays = [u]
    for ring in range(1, rings + 1):
        theta = half_angle * ring / rings
        for j in range(azimuths):
            phi = 2 * np.pi * j / azimuths
            rays.append(np.cos(theta) * u + np.sin(theta) * (np.cos(phi) * e1 + np.sin(phi) * e2))
    return np.array(rays)


def cone_measure(
    A: FloatArray, b: FloatArray, u: Any, half_angle: float = 0.35, rings: int = 3,
    azimuths: int = 8,
) -> float:
    """Volume of the RFP inside a cone of half-angle ``half_angle`` around ``u`` (one waypoint).

    Ray approximation of Ferrolho et al.'s RFP-cone measure: with ``rho_j`` the (non-negative)
    directional capacity along ray ``d_j``,
    ``V ~= Omega / (3 M) sum_j rho_j^3``, ``Omega = 2 pi (1 - cos half_angle)``, M rays.
    """
    rays = cone_directions(u, half_angle, rings, azimuths)
    rho = np.maximum(np.array([directional_capacity(A, b, d) for d in rays]), 0.0)
    omega = 2 * np.pi * (1 - np.cos(half_angle))
    return float(omega / (3 * len(rays)) * np.sum(rho**3))


def vertices(A: Any, b: Any, tol: float = 1e-7) -> FloatArray:
    """Vertices of one bounded polytope ``{f : A f <= b}`` in R^3 (for plots and tests).

    Every triple of rows with independent normals gives a candidate point; the feasible ones
    are kept, duplicates merged. Returns an empty (0 x 3) array when the polytope is empty.
    """
    A = as_array(A, "A", (None, 3))
    b = as_array(b, "b", (A.shape[0],))
    live = np.flatnonzero(_row_norms(A) > ZERO_NORMAL)
    if np.any(b[_row_norms(A) <= ZERO_NORMAL] < 0):
        return np.zeros((0, 3))
    triples = np.array(list(itertools.combinations(live, 3)))
    if triples.size == 0:
        return np.zeros((0, 3))
    M = A[triples]
    rhs = b[triples]
    det = np.linalg.det(M)
    ok = np.abs(det) > 1e-10 * np.prod(np.linalg.norm(M, axis=-1), axis=-1)
    pts = np.linalg.solve(M[ok], rhs[ok][..., None])[..., 0]
    scale = max(1.0, float(np.abs(b).max()))
    feasible = np.all(pts @ A.T <= b + tol * scale, axis=1)
    pts = pts[feasible]
    if pts.size == 0:
        return np.zeros((0, 3))
    keys = np.round(pts / (1e-6 * scale))
    _, idx = np.unique(keys, axis=0, return_index=True)
    return pts[np.sort(idx)]


def facets(A: Any, b: Any, V: Any, tol: float = 1e-7) -> list[FloatArray]:
    """Facets of the bounded polytope ``{f : A f <= b}`` with vertices ``V`` (for plots).

    Facet ``i`` holds the vertices on the plane ``a_i . f = b_i`` (within ``tol`` times the
    scale of ``b``), in order around their centroid; planes touching fewer than three vertices
    (edges, corners, redundant rows) and repeated planes give none. Returns one (k x 3) array
    per facet.
    """
    A, V = np.asarray(A, dtype=float), np.asarray(V, dtype=float)
    b = np.asarray(b, dtype=float)
    if len(V) < 4:
        return []
    scale = max(1.0, float(np.abs(b).max()))
    out, seen = [], set()
    for a, bi in zip(A, b, strict=True):
        norm = np.linalg.norm(a)
        if norm <= ZERO_NORMAL:
            continue
        on = np.flatnonzero(np.abs(V @ a - bi) <= tol * scale)
        key = tuple(on)
        if on.size < 3 or key in seen:
            continue
        seen.add(key)
        P = V[on]
        n = a / norm
        e1 = P[np.argmax(np.linalg.norm(P - P.mean(axis=0), axis=1))] - P.mean(axis=0)
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(n, e1)
        rel = P - P.mean(axis=0)
        out.append(P[np.argsort(np.arctan2(rel @ e2, rel @ e1))])
    return out
