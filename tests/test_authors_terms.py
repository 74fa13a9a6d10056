"""Differential test: the authors' weight sets and baselines, term by term against their code's formulas.

Every formula here is written from the authors' public code as ``AUTHORS_SETUP.md`` records it
(their ``whole_body_optimizer.cpp`` and ``rfp_comparison_costs.cpp``), in numpy on Pinocchio:
forte's robot is used only for its Pinocchio model (mount included), its end-effector frame and
the base pose; none of forte's cost code is called. On a plan of each authors' set and each
baseline the formulas must equal forte's ``plan.solver["cost_terms"]`` to 1e-9 (relative), and
the term weights the authors' weights. forte optimizes smooth surrogates of the capability terms
(J1, the inscribed radius, the cone volume) and reports those; the authors' hard-minimum values
are compared with forte's exact metric on the same states (and the surrogates must bound them).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pinocchio as pin
import pytest

import forte
from forte.capability.metrics import capability_cost
from forte.capability.polytope import cone_measure, inscribed_radius, residual_force_polytope, trajectory_rfp
from forte.settings import WEIGHT_SETS

RTOL = 1e-9

# -- the authors' configuration (AUTHORS_SETUP.md, "Metric and costs", "Baselines") -----------
TAU_MAX = np.array([60.0, 60, 60, 60, 12, 12, 12])
KAPPA, CAP, LAMBDA, EPS_M, MARGIN = 3.0, 40.0, 1e-6, 1e-8, 0.05
METRIC = np.array([1.0, 1.0, 0.5])  # base smoothness, base velocity and J5 axis weights
DCT_CUTOFF, DCT_POWER = 0.1, 2.0
CONE = (0.1, 4, 12)  # half-angle (rad), rings, azimuths
SAFE = 0.08
BASKET = [((0, 0, 0.1), 0.15), ((0, 0, 0.3), 0.18), ((0.106, 0.106, 0.3), 0.18), ((-0.106, -0.106, 0.3), 0.18)]
BODY = [((0, 0, 0.35), 0.52), ((0.2, 0, 0.8), 0.15)]
DOF = {"trajectory": [0, 2, 1, 10, 0, 1, 2, 1, 0, 0], "manipulability": [0, 2, 1, 10, 5, 1, 2, 1, 0, 0],
       "hold": [0, 1, 1, 9, 0, 1, 1, 1, 0, 0]}
REGULARIZATION = {"smoothness": 8, "velocity": 10, "nominal": 0.05, "base_smoothness": 8, "base_velocity": 0.5,
                  "base_spectral": 8, "collision": 1}
#: The weights each method runs with on the lift (TPY ``optimizer_algorithm_weights``).
LIFT_WEIGHTS = {
    "forte": {"capability": 1, "manipulability": 1, "joint_limits": 8, **REGULARIZATION},
    "rfp-radius": {"rfp_radius": 60, "joint_limits": 8, **REGULARIZATION, "base_velocity": 0.54},
    "rfp-cone": {"rfp_cone": 60, "joint_limits": 2, **{k: v for k, v in REGULARIZATION.items() if k != "base_spectral"},
                 "velocity": 7, "collision": 0.1},
    "manipulability": {"manipulability": 1, "joint_limits": 8},
    "static-polytope": {"static_radius": 2, "joint_limits": 8, **REGULARIZATION},
}


def hold_weights(method: str, as_run: bool) -> dict[str, float]:
    """A single point: one set for every method (capability 2, manipulability 1, joint limit 1), or,
    as run after a trajectory set-up, each method's lift weights; no regularization either way."""
    lift = LIFT_WEIGHTS[method]
    if as_run:
        return {k: (0.0 if k in REGULARIZATION else v) for k, v in lift.items()}
    own = {"capability": 2, "rfp_radius": 2, "rfp_cone": 2, "static_radius": 2, "manipulability": 1, "joint_limits": 1}
    return {k: own.get(k, 0.0) for k in lift}


# -- kinematics and dynamics on Pinocchio ------------------------------------------------------
def _rz(yaw: float) -> np.ndarray:
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])


def _base(qk: np.ndarray) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3], T[:2, 3] = _rz(qk[2]), qk[:2]
    return T


class Authors:
    """The authors' per-term formulas on one plan (q: N x 10, t, f, r, nominal)."""

    def __init__(self, robot, plan, nominal, alpha: float, cap: bool):
        self.model, self.data, self.ee = robot.model, robot.model.createData(), robot.ee_frame_id
        self.q, self.t, self.nom = plan.q, plan.t, nominal
        self.f, self.r, self.alpha, self.cap = plan.force.f, plan.force.r, alpha, cap
        self.lower, self.upper = np.array(self.model.lowerPositionLimit), np.array(self.model.upperPositionLimit)

    def ee_world(self, qk: np.ndarray) -> np.ndarray:
        pin.framesForwardKinematics(self.model, self.data, qk[3:])
        return _base(qk) @ self.data.oMf[self.ee].homogeneous

    def jacobian(self, qk: np.ndarray) -> np.ndarray:
        """3 x 7 translational arm Jacobian (LOCAL_WORLD_ALIGNED in the base, turned by the yaw)."""
        J = pin.computeFrameJacobian(self.model, self.data, qk[3:], self.ee, pin.LOCAL_WORLD_ALIGNED)
        return _rz(qk[2]) @ J[:3]

    def torque(self, k: int, static: bool = False) -> np.ndarray:
        """Nominal torque: backward differences, zero velocity before the first waypoint; gravity
        only at the first waypoint (no previous state) and for the static residual."""
        qa, zero = self.q[k, 3:], np.zeros(7)
        if static or k == 0:
            return pin.rnea(self.model, self.data, qa, zero, zero)
        dt = self.t[k] - self.t[k - 1]
        dq = (qa - self.q[k - 1, 3:]) / dt
        dq_prev = (self.q[k - 1, 3:] - self.q[k - 2, 3:]) / (self.t[k - 1] - self.t[k - 2]) if k >= 2 else zero
        return pin.rnea(self.model, self.data, qa, dq, (dq - dq_prev) / dt)

    # -- capability terms (WBO computeForceBallSignedClearance, RFC) --
    def clearance(self, k: int) -> float:
        J, tau, f, r = self.jacobian(self.q[k]), self.torque(k), self.f[k], self.r[k]
        d = 1e12
        for i in range(7):
            n = J[:, i]
            norm = np.sqrt(max(n @ n, 1e-18))
            if norm > 1e-9:
                d = min(d, (self.alpha * (TAU_MAX[i] - tau[i]) - n @ f) / norm - r,
                        (self.alpha * (TAU_MAX[i] + tau[i]) + n @ f) / norm - r)
        return d if d < 1e11 else 0.0

    def capability(self) -> float:
        total = 0.0
        for k in range(len(self.q)):
            x = KAPPA * max(0.0, -self.clearance(k) / max(abs(np.linalg.norm(self.f[k]) + self.r[k]), 1e-6))
            total += np.exp(min(CAP, x) if self.cap else x) - 1.0
        return total

    def radius(self, k: int, static: bool) -> float:
        J, tau, R = self.jacobian(self.q[k]), self.torque(k, static), 1e12
        for i in range(7):
            norm = np.sqrt(max(J[:, i] @ J[:, i], 1e-18))
            if norm > 1e-9:
                R = min(R, self.alpha * (TAU_MAX[i] - tau[i]) / norm, self.alpha * (TAU_MAX[i] + tau[i]) / norm)
        return max(0.0, R if R < 1e11 else 0.0)

    def rfp_radius(self, static: bool = False) -> float:
        return sum(1 / max(abs(self.radius(k, static)), 1e-6) for k in range(len(self.q)))

    def volume(self, k: int) -> float:
        J, tau = self.jacobian(self.q[k]), self.torque(k)
        f = self.f[k]
        rays = cone_rays(f / np.linalg.norm(f) if np.linalg.norm(f) > 1e-9 else np.array([0, 0, 1.0]), *CONE)
        cubes = 0.0
        for d in rays:
            cap = 1e12
            for i, p in enumerate(J.T @ d):
                if p > 1e-9:
                    cap = min(cap, self.alpha * (TAU_MAX[i] - tau[i]) / p)
                if p < -1e-9:
                    cap = min(cap, self.alpha * (TAU_MAX[i] + tau[i]) / -p)
            cubes += max(0.0, cap if cap < 1e11 else 0.0) ** 3
        return 2 * np.pi * (1 - np.cos(CONE[0])) * cubes / (3 * len(rays))

    def rfp_cone(self) -> float:
        return sum(1 / max(abs(self.volume(k)), 1e-6) for k in range(len(self.q)))

    # -- J2, J3 (WBO computeManipulabilitySymbolic, evaluateCostSymbolic) --
    def manipulability(self) -> float:
        total = 0.0
        for qk in self.q:
            p = self.ee_world(qk)[:3, 3]
            J = np.column_stack([[-(p[1] - qk[1]), p[0] - qk[0], 0.0], self.jacobian(qk)])  # 3 x 8
            mu = np.sqrt(max(EPS_M, np.linalg.det(J @ J.T + LAMBDA * np.eye(3))))
            total += 1 / max(EPS_M, mu)
        return total

    def joint_limits(self, dof) -> float:
        w = np.array(dof, dtype=float) / max(dof)
        centre, half = (self.lower + self.upper) / 2, (self.upper - self.lower) / 2
        margin = MARGIN * (self.upper - self.lower)
        safe = np.maximum(1e-6, half - margin)
        total = 0.0
        for qk, nk in zip(self.q, self.nom, strict=True):
            total += np.sum(w[:3] * _base_diff(qk, nk) ** 2)
            e = (qk[3:] - centre) / safe
            excess = (np.abs(qk[3:] - centre) - safe) / np.maximum(1e-6, margin)
            total += np.sum(w[3:] * (e**2 + np.where(np.abs(qk[3:] - centre) > safe, excess**4, 0.0)))
        return total

    # -- regularization (WBO evaluateCostSymbolic, computeBaseSpectralEnergyCostSymbolic) --
    def steps(self):
        """Per waypoint after the first: (arm step, base step with the yaw wrapped, dt)."""
        for k in range(1, len(self.q)):
            yield self.q[k, 3:] - self.q[k - 1, 3:], _base_diff(self.q[k], self.q[k - 1]), self.t[k] - self.t[k - 1]

    def regularization(self) -> dict[str, float]:
        arm = [0.5 * da @ da for da, _, _ in self.steps()]
        base = [0.5 * METRIC @ db**2 for _, db, _ in self.steps()]
        dt2 = [dt**2 for _, _, dt in self.steps()]
        return {"smoothness": sum(arm), "velocity": sum(a / d for a, d in zip(arm, dt2, strict=True)),
                "base_smoothness": sum(base), "base_velocity": sum(b / d for b, d in zip(base, dt2, strict=True)),
                "nominal": sum(0.5 * np.sum((qk[3:] - nk[3:]) ** 2) for qk, nk in zip(self.q, self.nom, strict=True)),
                "collision": sum(self.collision(qk) for qk in self.q), "base_spectral": self.spectral()}

    def collision(self, qk: np.ndarray) -> float:
        ee, base = self.ee_world(qk), _base(qk)
        total = 0.0
        for ca, ra in BASKET:
            pa = ee[:3, :3] @ ca + ee[:3, 3]
            for cb, rb in BODY:
                pb = base[:3, :3] @ cb + base[:3, 3]
                clearance = np.sqrt(np.sum((pa - pb) ** 2) + 1e-12) - ra - rb
                total += max(0.0, SAFE - clearance) ** 2
        return total

    def spectral(self) -> float:
        n = len(self.q)
        if n < 2:
            return 0.0
        yaw = self.q[0, 2] + np.r_[0.0, np.cumsum([db[2] for _, db, _ in self.steps()])]  # unwrapped
        signals = (self.q[:, 0], self.q[:, 1], yaw)
        total = 0.0
        for eta, x in zip(METRIC, signals, strict=True):
            for k in range(1, n):
                ratio = k / (n - 1)
                if ratio <= DCT_CUTOFF:
                    continue
                c = np.sqrt(2 / n) * np.sum(x * np.cos(np.pi * (np.arange(n) + 0.5) * k / n))  # orthonormal DCT-II
                total += eta * ((ratio - DCT_CUTOFF) / (1 - DCT_CUTOFF)) ** DCT_POWER * c**2
        return 0.5 * total


def _base_diff(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    d = a[:3] - b[:3]
    return np.r_[d[:2], np.arctan2(np.sin(d[2]), np.cos(d[2]))]


def cone_rays(axis: np.ndarray, half_angle: float, rings: int, azimuths: int) -> np.ndarray:
    """The authors' rays: the axis, then ``rings x azimuths`` rays at ``half_angle * j / rings``."""
    ref = np.array([0.0, 1, 0]) if abs(axis[0]) > 0.9 else np.array([1.0, 0, 0])
    a = np.cross(axis, ref)
    a /= np.linalg.norm(a)
    b = np.cross(axis, a)
    b /= np.linalg.norm(b)
    rays = [axis]
    for j in range(1, rings + 1):
        th = half_angle * j / rings
        for s in range(azimuths):
            phi = 2 * np.pi * s / azimuths
            d = np.cos(th) * axis + np.sin(th) * (np.cos(phi) * a + np.sin(phi) * b)
            rays.append(d / np.linalg.norm(d))
    return np.array(rays)


# -- forte's exact capability metrics on the same states ---------------------------------------
def forte_exact(plan, term: str) -> float:
    """forte's exact (hard-minimum) value of a capability-type term (not the optimized surrogate)."""
    w = plan.task.settings
    rfp = trajectory_rfp(plan.robot, plan.q, plan.t, alpha=w.alpha)
    f, r = plan.force.f, plan.force.r
    if term == "capability":
        return capability_cost(rfp.A, rfp.b, f, r, w.capability_params)
    if term == "static_radius":
        static = [residual_force_polytope(plan.robot, qk, alpha=w.alpha) for qk in plan.q]
        return sum(1 / max(abs(max(0.0, float(inscribed_radius(p.A, p.b)))), 1e-6) for p in static)
    if term == "rfp_radius":
        return sum(1 / max(abs(max(0.0, float(inscribed_radius(A, b)))), 1e-6) for A, b in zip(rfp.A, rfp.b,
                                                                                                 strict=True))
    axes = [fk if np.linalg.norm(fk) > 1e-9 else np.array([0, 0, 1.0]) for fk in f]
    return sum(1 / max(cone_measure(A, b, u, *CONE), 1e-6) for A, b, u in zip(rfp.A, rfp.b, axes, strict=True))


# -- the plans ---------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def lift():
    """The 2.7 L lift on 9 waypoints with the authors' trajectory set."""
    task = forte.load_task("examples/tasks/lift.yaml", waypoints=9)
    return task.with_weights(WEIGHT_SETS["authors-trajectory"])


@pytest.fixture(scope="module")
def hold():
    """The 2.7 L hold from the authors' single start."""
    task = forte.load_task("examples/tasks/hold.yaml")
    return replace(task, solver=replace(task.solver, hold_starts=1))


def check_plan(plan, authors: Authors, dof, weights: dict[str, float]) -> float:
    """Every term against the authors' formula; returns the largest relative difference."""
    assert plan.solved, plan.status
    assert plan.solver["term_weights"] == weights
    # the metric itself: their signed clearance is forte's exact d at every waypoint
    clearance = [authors.clearance(k) for k in range(len(plan.q))]
    np.testing.assert_allclose(clearance, plan.metrics["d"], rtol=RTOL, atol=0)
    theirs = authors.regularization() | {"manipulability": authors.manipulability(),
                                         "joint_limits": authors.joint_limits(dof)}
    capability = {"capability": authors.capability, "rfp_radius": authors.rfp_radius, "rfp_cone": authors.rfp_cone,
                  "static_radius": lambda: authors.rfp_radius(static=True)}
    worst = 0.0
    for name, value in plan.solver["cost_terms"].items():
        if name in capability:  # forte reports the surrogate it optimizes, an upper bound of the exact term
            value, theirs[name] = forte_exact(plan, name), capability[name]()
            assert plan.solver["cost_terms"][name] >= value * (1 - RTOL), name
        assert theirs[name] == pytest.approx(value, rel=RTOL, abs=0), name
        worst = max(worst, abs(theirs[name] - value) / abs(value) if value else 0.0)
    return worst


@pytest.mark.slow
@pytest.mark.parametrize("method", ["forte", "rfp-radius", "rfp-cone", "manipulability", "static-polytope"])
def test_lift_terms_equal_the_authors_formulas(lift, method):
    plan = forte.plan(lift, method)
    authors = Authors(plan.robot, plan, lift.nominal(), alpha=0.9, cap=True)
    dof = DOF["manipulability" if method == "manipulability" else "trajectory"]
    worst = check_plan(plan, authors, dof, LIFT_WEIGHTS[method])
    assert worst < RTOL


@pytest.mark.slow
@pytest.mark.parametrize("preset", ["authors-hold", "authors-hold-as-run"])
@pytest.mark.parametrize("method", ["forte", "rfp-radius", "rfp-cone", "manipulability", "static-polytope"])
def test_hold_terms_equal_the_authors_formulas(hold, preset, method):
    """The authors' single point: gravity-only residual; their holding set (alpha 0.7, the exponent
    cap off), or the trajectory set with the single point's terms only (alpha 0.9, cap on)."""
    as_run = preset == "authors-hold-as-run"
    plan = forte.plan(hold.with_weights(WEIGHT_SETS[preset]), method)
    authors = Authors(plan.robot, plan, hold.nominal(), alpha=0.9 if as_run else 0.7, cap=as_run)
    dof = DOF["manipulability" if as_run and method == "manipulability" else "trajectory" if as_run else "hold"]
    assert check_plan(plan, authors, dof, hold_weights(method, as_run)) < RTOL
