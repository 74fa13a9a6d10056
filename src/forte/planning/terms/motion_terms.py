"""Built-in motion terms: smoothness, velocity, nominal, collision and the spectral J5.

Each is a frozen dataclass registered in :data:`forte.planning.terms.costs.COST_TERMS`; see that module
for the interface.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import casadi as ca
import numpy as np
from scipy import sparse

from forte.model.collision import AUTHORS_SPHERES, CollisionSphere, SpherePairs
from forte.model.robot import N_BASE
from forte.planning.terms.costs import (
    CostTerm,
    LiftedQuadratic,
    Stage,
    TermSetting,
    nonnegative,
    nonnegative_vector,
    positive,
    register_term,
    setting,
)
from forte.planning.terms.spectral import SpectralForm, dct_penalty, spectral_form
from forte.settings import COLLISION_MODELS, DCT_FORMS
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
    arm: float = setting(1.0, "1", "the arm entries of W_s", expected="a finite number > 0", valid=positive,
                         legacy="smoothness_arm")


    def metric(self, n_arm: int) -> FloatArray:
        """The per-coordinate weights ``m_i`` of ``sum_k 1/2 sum_i m_i (q_k - q_k-1)_i^2``: ``W_s^2``."""
        return np.concatenate([self.base, np.full(n_arm, self.arm)]) ** 2

    def matrix(self, n_arm: int, n: int) -> sparse.csr_matrix:
        size = (n_arm + N_BASE) * n
        if n == 1:
            return sparse.csr_matrix((size, size))
        D = sparse.diags([-np.ones(n - 1), np.ones(n - 1)], [0, 1], shape=(n - 1, n))  # q_{k+1} - q_k
        return sparse.kron(D.T @ D, sparse.diags(self.metric(n_arm))).tocsr()


@register_term
@dataclass(frozen=True)
class BaseSmoothness(Smoothness):
    """Base part of J4 over (x, y, yaw), ``b = smoothness_base`` (default (1, 1, 0.5)):

    - the paper's text (default): ``sum_k 1/2 ||W_s (q_b,k - q_b,k-1)||^2``, ``W_s = diag(b)``,
      i.e. the weights ``b_i^2`` (yaw 0.25);
    - ``linear`` (``base_smoothness_linear``, the authors' code and every ``authors-*`` set):
      ``sum_k 1/2 sum_i b_i (q_b,k - q_b,k-1)_i^2``, the weights ``b_i`` (yaw 0.5), the metric
      their base velocity term also uses. Their code wraps the yaw step to (-pi, pi]; this
      constant quadratic does not, which changes nothing while ``|yaw_k - yaw_k-1| < pi`` (the
      base yaw velocity limit keeps it below 0.4 rad per 0.25 s step).
    """

    name: ClassVar[str] = "base_smoothness"
    base: tuple[float, float, float] = setting(
        (1.0, 1.0, 0.5), "1 (m^-1, m^-1, rad^-1 per unit weight)", "b, the base entries of W_s for (x, y, yaw); "
        "also the base velocity term's metric", kind="vector", expected="3 finite numbers >= 0",
        valid=nonnegative_vector(3), legacy="smoothness_base")
    arm: float = 0.0
    linear: bool = setting(False, "", "the metric b used linearly (the authors' code) instead of W_s = diag(b)",
                           kind="bool", expected="true or false", valid=None, legacy="base_smoothness_linear")

    def metric(self, n_arm: int) -> FloatArray:
        return np.r_[self.base, np.zeros(n_arm)] if self.linear else super().metric(n_arm)


@register_term
@dataclass(frozen=True)
class Velocity(CostTerm):
    """Arm velocity term ``1/2 ||q_a,k - q_a,k-1||^2 / dt_k^2`` (the authors' velocity cost;
    zero at the first waypoint, which starts at rest)."""

    name: ClassVar[str] = "velocity"

    def stage(self, s: Stage) -> ca.SX:
        i = slice(N_BASE, s.robot.nq)
        return 0.5 * ca.sumsqr(s.q0[i] - s.q1[i]) / s.dt0**2


@register_term
@dataclass(frozen=True)
class BaseVelocity(CostTerm):
    """Base velocity term ``1/2 sum_i m_i (q_b,k - q_b,k-1)_i^2 / dt_k^2`` over (x, y, yaw).

    Not in the paper's text: the authors' code, where it is their base smoothness divided by
    ``dt^2``, the metric ``m`` (``smoothness_base``, default (1, 1, 0.5)) used linearly and the
    yaw difference wrapped to (-pi, pi] (``atan2(sin, cos)``). forte's base smoothness (J4, see
    :class:`BaseSmoothness` for its two forms) and J5 are constant quadratics on the raw yaw; the
    wrap changes nothing while ``|yaw_k - yaw_k-1| < pi`` (the base yaw velocity limit keeps it
    below 0.4 rad per 0.25 s step).
    """

    name: ClassVar[str] = "base_velocity"
    metric: tuple[float, float, float] = (1.0, 1.0, 0.5)

    @classmethod
    def from_settings(cls, settings: Any = None) -> CostTerm:
        """The metric is the base smoothness term's ``base`` setting (the authors' one metric)."""
        return cls(BaseSmoothness.setting_values(settings)["base"])

    def stage(self, s: Stage) -> ca.SX:
        d = s.q0[:N_BASE] - s.q1[:N_BASE]
        d_yaw = ca.atan2(ca.sin(d[2]), ca.cos(d[2]))
        m = self.metric
        return 0.5 * (m[0] * d[0] ** 2 + m[1] * d[1] ** 2 + m[2] * d_yaw**2) / s.dt0**2


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


@register_term
@dataclass(frozen=True)
class Collision(CostTerm):
    """The authors' collision term (``collision_model: authors``, the default):

    ``sum_{a in basket} sum_{b in body} max(0, s - c_ab)^2``,  ``c_ab = ||p_a - p_b|| - (r_a + r_b)``

    over the sphere pairs of :data:`forte.model.collision.AUTHORS_SPHERES` (basket spheres on
    the end effector, body spheres on the base), ``s`` the safe distance (0.08 m), in m^2. Not in
    the paper's text; defined by the authors' code, whose experiments weigh it 1 (0.1 for the
    cone baseline). The centres are the forward kinematics of their frames; the distance is
    taken in the base frame, equal to the world distance since both sets share the base's
    rigid motion. ``||.||`` is guarded by ``1e-12`` m^2 under the root (as theirs). Zero while
    every pair keeps ``s`` of clearance.
    """

    name: ClassVar[str] = "collision"
    spheres: SpherePairs = AUTHORS_SPHERES
    safe_distance: float = 0.08

    def __post_init__(self) -> None:
        SpherePairs(*self.spheres).check()

    settings: ClassVar[tuple[TermSetting, ...]] = (
        TermSetting("model", None, "authors", "", "authors: the authors' spheres on the end effector against "
                    "spheres on the base; box: arm-joint spheres against a base box and the floor", None, "str",
                    f"one of {', '.join(COLLISION_MODELS)}", lambda v: v in COLLISION_MODELS, "collision_model"),
        TermSetting("safe_distance", None, 0.08, "m", "clearance below which the authors' model penalizes a pair",
                    None, "float", "a finite number >= 0", nonnegative, "collision_safe_distance"),
        TermSetting("radius", None, 0.08, "m", "radius of the box model's arm spheres", None, "float",
                    "a finite number > 0", positive, "collision_radius"),
    )

    @classmethod
    def from_settings(cls, settings: Any = None) -> CostTerm:
        values = cls.setting_values(settings)
        if values["model"] == "box":
            return BoxCollision(values["radius"])
        return cls(AUTHORS_SPHERES, values["safe_distance"])

    @staticmethod
    def centres(s: Stage, spheres: tuple[CollisionSphere, ...]) -> list[ca.SX]:
        """Sphere centres in the base frame."""
        R_ee, p_ee = s.twin.arm_ee_pose(s.q0[N_BASE:])
        return [p_ee + R_ee @ ca.DM(sp.centre) if sp.frame == "ee" else ca.DM(sp.centre) for sp in spheres]

    def stage(self, s: Stage) -> ca.SX:
        basket, body = self.spheres
        cost = ca.SX(0)
        body_centres = self.centres(s, body)
        for a, p_a in zip(basket, self.centres(s, basket), strict=True):
            for b, p_b in zip(body, body_centres, strict=True):
                clearance = ca.sqrt(ca.sumsqr(p_a - p_b) + 1e-12) - (a.radius + b.radius)
                cost += ca.fmax(0, self.safe_distance - clearance) ** 2
        return cost


#: The ``box`` collision model's base box in the base frame (m) and the arm joints that carry
#: spheres (origins of joints 3, 4, 5, 7 and the end effector: 6 shares 5's; 1-2 sit on the mount).
#: forte's estimate before the authors' model: the MOCA base is not in the authors' optimizer URDF.
BASE_BOX: tuple[tuple[float, float, float], tuple[float, float, float]] = ((-0.35, -0.28, 0.0), (0.30, 0.28, 0.50))
COLLISION_JOINTS: tuple[int, ...] = (2, 3, 4, 6)


@dataclass(frozen=True)
class BoxCollision(CostTerm):
    """The ``box`` collision model: ``sum_s max(0, 1 - d_box,s / rho)^2 + max(0, 1 - z_s / rho)^2``.

    Spheres of radius ``rho`` (``collision_radius``, 0.08 m) at the origins of arm joints 3, 4,
    5, 7 and at the end effector; ``d_box`` is the distance from a centre to the base box
    :data:`BASE_BOX` (0 inside), ``z`` the height above the floor. Zero when every sphere clears
    both; each penetrating sphere adds up to 2 (dimensionless). ``sqrt`` is guarded by
    ``1e-10`` m^2. Served under the name ``collision`` by :meth:`Collision.from_settings`.
    """

    name: ClassVar[str] = "collision"
    radius: float = 0.08
    box: tuple[tuple[float, float, float], tuple[float, float, float]] = BASE_BOX
    joints: tuple[int, ...] = COLLISION_JOINTS

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
    """J5 = ``1/2 sum_xi eta_xi sum_{l in H} gamma_l bhat_{xi,l}^2`` (orthonormal DCT-II per base axis).

    :meth:`matrix` is the formula (the value every report shows); :meth:`lifted` is the form the
    optimizer solves with, :func:`forte.planning.terms.spectral.spectral_form` by ``form`` (exact unless
    ``banded`` is chosen, or ``auto`` meets the authors' ramp beyond
    :data:`~forte.planning.terms.spectral.DENSE_MAX_WAYPOINTS` waypoints).
    """

    name: ClassVar[str] = "base_spectral"
    kind: ClassVar[str] = "quadratic"
    cutoff: float = setting(0.1, "1", "frequencies l >= ceil(cutoff N) form the high-frequency set H",
                            expected="0 < cutoff < 1", valid=lambda v: 0 < v < 1, legacy="dct_cutoff")
    axis: tuple[float, float, float] = setting((1.0, 1.0, 0.5), "1", "eta_xi for x, y, yaw", kind="vector",
                                               expected="3 finite numbers >= 0", valid=nonnegative_vector(3),
                                               legacy="dct_axis")
    power: float = setting(2.0, "1", "gamma_l = (l / (N - 1)) ** power (0: every high frequency weighs 1), or "
                           "with ramp ((l/(N-1) - c)/(1 - c)) ** power over l/(N-1) > c", legacy="dct_power")
    ramp: bool = setting(True, "", "the authors' ramped gamma and high set", kind="bool",
                         expected="true or false", valid=None, legacy="dct_ramp")
    form: str = setting("auto", "", "how the optimizer solves J5 (forte.planning.terms.spectral.spectral_form)",
                        kind="str", expected=f"one of {', '.join(DCT_FORMS)}", valid=lambda v: v in DCT_FORMS,
                        legacy="dct_form")
    reference: int = setting(41, "waypoints", "the horizon whose cutoff and scale the banded weighting keeps",
                             kind="int", expected="an integer >= 2", valid=lambda v: v >= 2,
                             legacy="dct_reference_waypoints", name="reference_waypoints")

    def _selector(self, n_arm: int) -> sparse.csr_matrix:
        E = np.zeros((n_arm + N_BASE, n_arm + N_BASE))
        E[:N_BASE, :N_BASE] = np.diag(self.axis)
        return sparse.csr_matrix(E)

    def matrix(self, n_arm: int, n: int) -> sparse.csr_matrix:
        nq = n_arm + N_BASE
        if n == 1:
            return sparse.csr_matrix((nq, nq))
        P = dct_penalty(n, self.cutoff, self.power, self.ramp)
        return sparse.kron(sparse.csr_matrix(P), self._selector(n_arm)).tocsr()

    def spectral_form(self, n: int) -> SpectralForm:
        return spectral_form(n, self.cutoff, self.power, self.ramp, self.form, self.reference)

    def solved_as(self, n: int) -> str:
        return "exact" if n == 1 else self.spectral_form(n).kind

    def lifted(self, n_arm: int, n: int) -> LiftedQuadratic:
        """``sum_xi eta_xi (b_xi^T B b_xi + z_xi^T diag(g) z_xi) / 2`` with ``z_xi = R b_xi``."""
        nq = n_arm + N_BASE
        if n == 1:
            return super().lifted(n_arm, n)
        f = self.spectral_form(n)
        D = sparse.kron(f.banded, self._selector(n_arm)).tocsr()
        axes = [i for i in range(N_BASE) if self.axis[i] != 0 and f.gains.size]
        A = sparse.vstack([sparse.kron(sparse.csr_matrix(f.rows), sparse.csr_matrix(np.eye(1, nq, i)))
                           for i in axes] or [sparse.csr_matrix((0, nq * n))]).tocsr()
        g = np.concatenate([self.axis[i] * f.gains for i in axes] or [np.zeros(0)])
        return LiftedQuadratic(D, A, g)


def dct_penalty_matrix(n: int, settings: Any = None) -> FloatArray:
    """:func:`~forte.planning.terms.spectral.dct_penalty` with ``base_spectral``'s settings in ``settings``
    (term -> {setting: value}; default: its defaults), one base coordinate."""
    term = BaseSpectral.from_settings(settings)
    return dct_penalty(n, term.cutoff, term.power, term.ramp)
