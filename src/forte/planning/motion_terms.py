"""Built-in motion terms: smoothness, velocity, nominal, collision and the spectral J5.

Each is a frozen dataclass registered in :data:`forte.planning.costs.COST_TERMS`; see that module
for the interface.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import casadi as ca
import numpy as np
from scipy import sparse

from forte.model.robot import N_BASE
from forte.planning.costs import CostTerm, Stage, register_term
from forte.settings import CostWeights
from forte.validation import FloatArray


@register_term
@dataclass(frozen=True)
class Smoothness(CostTerm):
    """Arm part of J4: ``sum_k 1/2 ||W_s (q_k - q_{k-1})||^2`` with ``W_s = diag(0, 0, 0, arm...)``.

    With :class:`BaseSmoothness` (``W_s = diag(base, 0...)``) at the same weight this is the
    paper's whole-body J4 with ``W_s = diag(base, arm...)``.
    """

    name: ClassVar[str] = "smoothness"
    kind: ClassVar[str] = "quadratic"
    base: tuple[float, float, float] = (0.0, 0.0, 0.0)
    arm: float = 1.0

    @classmethod
    def from_weights(cls, weights: CostWeights) -> Smoothness:
        return cls((0.0, 0.0, 0.0), weights.smoothness_arm)

    def matrix(self, n_arm: int, n: int) -> sparse.csr_matrix:
        size = (n_arm + N_BASE) * n
        if n == 1:
            return sparse.csr_matrix((size, size))
        D = sparse.diags([-np.ones(n - 1), np.ones(n - 1)], [0, 1], shape=(n - 1, n))  # q_{k+1} - q_k
        Ws = sparse.diags(np.concatenate([self.base, np.full(n_arm, self.arm)]) ** 2)
        return sparse.kron(D.T @ D, Ws).tocsr()


@register_term
@dataclass(frozen=True)
class BaseSmoothness(Smoothness):
    """Base part of J4: ``W_s = diag(base, 0...)`` (``smoothness_base``, default (1, 1, 0.5))."""

    name: ClassVar[str] = "base_smoothness"
    base: tuple[float, float, float] = (1.0, 1.0, 0.5)
    arm: float = 0.0

    @classmethod
    def from_weights(cls, weights: CostWeights) -> BaseSmoothness:
        return cls(tuple(weights.smoothness_base), 0.0)


@register_term
@dataclass(frozen=True)
class Velocity(CostTerm):
    """Arm velocity term ``1/2 ||q_a,k - q_a,k-1||^2 / dt_k^2`` (the authors' velocity cost;
    zero at the first waypoint, which starts at rest)."""

    name: ClassVar[str] = "velocity"

    def coordinates(self, s: Stage) -> slice:
        return slice(N_BASE, s.robot.nq)

    def stage(self, s: Stage) -> ca.SX:
        i = self.coordinates(s)
        return 0.5 * ca.sumsqr(s.q0[i] - s.q1[i]) / s.dt0**2


@register_term
@dataclass(frozen=True)
class BaseVelocity(Velocity):
    """Base velocity term ``1/2 ||q_b,k - q_b,k-1||^2 / dt_k^2`` over (x, y, yaw)."""

    name: ClassVar[str] = "base_velocity"

    def coordinates(self, s: Stage) -> slice:
        return slice(0, N_BASE)


@register_term
@dataclass(frozen=True)
class Nominal(CostTerm):
    """Arm nominal term ``1/2 ||q_a,k - q_a,nom,k||^2`` (the nominal trajectory of the task: the
    joint-space interpolation of taught configurations, else the initial guess)."""

    name: ClassVar[str] = "nominal"

    def stage(self, s: Stage) -> ca.SX:
        if s.nominal is None:
            return ca.SX(0)
        return 0.5 * ca.sumsqr(s.q0[N_BASE:] - s.nominal[N_BASE:])


#: Collision model of the built-in robot: the base as a box in the base frame (m) and the arm
#: points that carry spheres (joint origins 3, 4, 5, 7 and the end effector: 6 shares 5's; 1-2 sit on the
#: mount). An estimate: the MOCA base is not in the authors' optimizer URDF.
BASE_BOX: tuple[tuple[float, float, float], tuple[float, float, float]] = ((-0.35, -0.28, 0.0), (0.30, 0.28, 0.50))
COLLISION_JOINTS: tuple[int, ...] = (2, 3, 4, 6)


@register_term
@dataclass(frozen=True)
class Collision(CostTerm):
    """Collision term: ``sum_s max(0, 1 - d_box,s / rho)^2 + max(0, 1 - z_s / rho)^2``.

    Spheres of radius ``rho`` (0.08 m, the authors') at the origins of arm joints 3, 4, 5, 7 and at
    the end effector; ``d_box`` is the distance from a centre to the base box :data:`BASE_BOX`
    (0 inside), ``z`` the height above the floor. Zero when every sphere clears both; each
    penetrating sphere adds up to 2. ``sqrt`` is guarded by ``1e-10`` m^2 (a 1e-5 m offset).
    """

    name: ClassVar[str] = "collision"
    radius: float = 0.08
    box: tuple[tuple[float, float, float], tuple[float, float, float]] = BASE_BOX
    joints: tuple[int, ...] = COLLISION_JOINTS

    @classmethod
    def from_weights(cls, weights: CostWeights) -> Collision:
        return cls(weights.collision_radius)

    def centres(self, s: Stage) -> list[ca.SX]:
        """Sphere centres in the base frame."""
        poses = s.twin._arm_poses(s.q0[N_BASE:])
        _, p_ee = s.twin.arm_ee_pose(s.q0[N_BASE:])
        return [poses[j][1] for j in self.joints if j < len(poses)] + [p_ee]

    def stage(self, s: Stage) -> ca.SX:
        lo, hi = ca.DM(self.box[0]), ca.DM(self.box[1])
        centre, half = (lo + hi) / 2, (hi - lo) / 2
        cost = ca.SX(0)
        for c in self.centres(s):
            out = ca.fmax(ca.fabs(c - centre) - half, 0)
            d_box = ca.sqrt(ca.sumsqr(out) + 1e-10)
            cost += ca.fmax(0, 1 - d_box / self.radius) ** 2 + ca.fmax(0, 1 - c[2] / self.radius) ** 2
        return cost


@register_term
@dataclass(frozen=True)
class BaseSpectral(CostTerm):
    """J5 = ``1/2 sum_xi eta_xi sum_{l in H} gamma_l bhat_{xi,l}^2`` (orthonormal DCT-II per base axis)."""

    name: ClassVar[str] = "base_spectral"
    kind: ClassVar[str] = "quadratic"
    cutoff: float = 0.35
    axis: tuple[float, float, float] = (1.0, 1.0, 0.5)
    power: float = 0.0
    ramp: bool = False

    @classmethod
    def from_weights(cls, weights: CostWeights) -> BaseSpectral:
        return cls(weights.dct_cutoff, tuple(weights.dct_axis), weights.dct_power, weights.dct_ramp)

    def matrix(self, n_arm: int, n: int) -> sparse.csr_matrix:
        nq = n_arm + N_BASE
        if n == 1:
            return sparse.csr_matrix((nq, nq))
        E = np.zeros((nq, nq))
        E[:N_BASE, :N_BASE] = np.diag(self.axis)
        P = dct_penalty(n, self.cutoff, self.power, self.ramp)
        return sparse.kron(sparse.csr_matrix(P), sparse.csr_matrix(E)).tocsr()


def dct_matrix(n: int) -> FloatArray:
    """Orthonormal DCT-II matrix ``C`` (``C @ x`` equals ``scipy.fft.dct(x, norm='ortho')``)."""
    k = np.arange(n)[:, None]
    i = np.arange(n)[None, :]
    C = np.cos(np.pi * (2 * i + 1) * k / (2 * n)) * np.sqrt(2.0 / n)
    C[0] /= np.sqrt(2.0)
    return C


def high_frequencies(n: int, cutoff: float) -> FloatArray:
    """Indices ``l`` of the high-frequency set ``H = {l : l >= ceil(cutoff n)}`` (never l = 0)."""
    return np.arange(max(1, int(np.ceil(cutoff * n))), n)


def ramped_frequencies(n: int, cutoff: float) -> FloatArray:
    """The authors' high set ``H = {l : l / (N - 1) > cutoff}``."""
    ell = np.arange(n)
    return ell[ell / max(n - 1, 1) > cutoff]


def dct_penalty(n: int, cutoff: float, power: float, ramp: bool = False) -> FloatArray:
    """``P`` with ``b^T P b = sum_{l in H} gamma_l bhat_l^2``.

    ``gamma_l = (l / (N - 1))^power`` on ``l >= ceil(cutoff N)`` (the paper's text), or with
    ``ramp`` the authors' ``gamma_l = ((l/(N-1) - c) / (1 - c))^power`` on ``l/(N-1) > c``.
    """
    C = dct_matrix(n)
    H = ramped_frequencies(n, cutoff) if ramp else high_frequencies(n, cutoff)
    if H.size == 0:
        return np.zeros((n, n))
    x = H / max(n - 1, 1)
    gamma = ((x - cutoff) / (1 - cutoff)) ** power if ramp else x**power
    CH = C[H]
    return CH.T @ (gamma[:, None] * CH)


def dct_penalty_matrix(n: int, weights: CostWeights) -> FloatArray:
    """:func:`dct_penalty` with the cutoff and power of ``weights`` (one base coordinate)."""
    return dct_penalty(n, weights.dct_cutoff, weights.dct_power, weights.dct_ramp)
