"""Force-capability metric (exact and smooth) and manipulability."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from conftest import TWO_LINK_J, TWO_LINK_TAU_MAX, TWO_LINK_TAU_NOM, random_configuration

from forte.capability.metrics import (
    CapabilityParameters,
    capability_cost,
    capability_margin,
    capability_penalty,
    ellipsoid_axes,
    manipulability,
    manipulability_expr,
    normalization,
    signed_distances,
    smooth_capability_penalty,
    smooth_penalty_expr,
    yoshikawa,
)
from forte.capability.polytope import contains, halfspaces, residual_margins
from forte.exceptions import InvalidInputError

J2, TAU_MAX, TAU_NOM = TWO_LINK_J, TWO_LINK_TAU_MAX, TWO_LINK_TAU_NOM


def test_signed_distances_by_hand():
    A, b = halfspaces(J2, *residual_margins(TAU_NOM, TAU_MAX))
    f, r = np.array([1.0, 2.0, 0.0]), np.array(1.0)
    # d+_1 = (8 - n1.f)/|n1| - r with n1.f = 1;  d-_1 = (12 + 1)/sqrt2 - 1;
    # d+_2 = (6 - (-1)) - 1 = 6;  d-_2 = (4 + (-1)) - 1 = 2
    d = signed_distances(A, b, f, r)
    np.testing.assert_allclose(d, [7 / np.sqrt(2) - 1, 6, 13 / np.sqrt(2) - 1, 2])
    assert capability_margin(A, b, f, r) == pytest.approx(2.0)


def test_penalty_by_hand():
    assert capability_penalty(-5.0, 20.0, kappa=3.0) == pytest.approx(np.exp(0.75) - 1)
    assert capability_penalty(0.0, 20.0) == 0.0
    assert capability_penalty(3.0, 20.0) == 0.0
    assert capability_penalty(-1e9, 1.0, max_exponent=40) == pytest.approx(np.expm1(40.0))
    assert normalization([3.0, 4.0, 0.0], 10.0) == pytest.approx(15.0)
    assert normalization([0.0, 0.0, 0.0], 0.0, eps=1e-3) == pytest.approx(1e-3)


def test_j1_sums_the_waypoint_penalties():
    A, b = halfspaces(J2, *residual_margins(TAU_NOM, TAU_MAX))
    f = np.array([[1.0, 2.0, 0.0], [10.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    r = np.array([1.0, 1.0, 1.0])
    A3, b3 = np.repeat(A[None], 3, 0), np.repeat(b[None], 3, 0)
    # waypoint 2: fx = 10 > 4: d = (4 - 10) - 1 = -7, rho = 11
    expected = np.exp(3 * 7 / 11) - 1
    assert capability_cost(A3, b3, f, r) == pytest.approx(expected)


def test_margin_sign_matches_ball_containment(robot):
    rng = np.random.default_rng(12)
    sphere = rng.normal(size=(4000, 3))
    sphere /= np.linalg.norm(sphere, axis=1, keepdims=True)
    seen = {True: 0, False: 0}
    for _ in range(40):
        q = random_configuration(robot, rng)
        tau = robot.rnea(q[3:], np.zeros(7), np.zeros(7))
        A, b = halfspaces(robot.arm_jacobian(q), *residual_margins(tau, robot.torque_limits), 0.8)
        f = rng.normal(size=3) * rng.uniform(0, 40)
        r = rng.uniform(1, 20)
        d = capability_margin(A, b, f, np.array(r))
        inside = bool(np.all(contains(A, b, f + r * sphere)))
        if d >= 0:
            assert inside
        else:
            # the witness point: ball centre pushed along the most violated normal
            dist = signed_distances(A, b, f, np.array(r))
            i = int(np.argmin(dist))
            witness = f + r * A[i] / np.linalg.norm(A[i])
            assert not contains(A, b, witness)
        seen[d >= 0] += 1
    assert seen[True] > 0 and seen[False] > 0


def test_zero_jacobian_column_is_guarded(robot):
    q = robot.home()
    J = robot.arm_jacobian(q)
    assert np.linalg.norm(J[:, 6]) < 1e-12
    tau = robot.rnea(q[3:], np.zeros(7), np.zeros(7))
    A, b = halfspaces(J, *residual_margins(tau, robot.torque_limits))
    f, r = np.array([0, 0, 20.0]), np.array(10.0)
    assert np.isfinite(capability_margin(A, b, f, r))
    assert np.all(np.isfinite(smooth_capability_penalty(A, b, f, r)))


def random_cases(robot, count, seed):
    rng = np.random.default_rng(seed)
    for _ in range(count):
        q = random_configuration(robot, rng)
        tau = robot.rnea(q[3:], rng.normal(size=7), rng.normal(size=7))
        J = robot.arm_jacobian(q)
        f = rng.normal(size=3) * rng.uniform(5, 60)
        yield J, tau, f, rng.uniform(2, 15)


def test_smooth_surrogate_converges_to_the_exact_penalty(robot):
    cases = list(random_cases(robot, 30, 13))
    previous = np.inf
    for beta in (10.0, 100.0, 1000.0, 1e5):
        params = CapabilityParameters(beta=beta, eps_normal=1e-9)  # the default knee (3)
        worst = 0.0
        for J, tau, f, r in cases:
            A, b = halfspaces(J, *residual_margins(tau, robot.torque_limits), params.alpha)
            exact = capability_penalty(capability_margin(A, b, f, np.array(r)),
                                       normalization(f, r), params.kappa, params.max_exponent)
            smooth = smooth_capability_penalty(A, b, f, np.array(r), params)
            assert smooth >= exact - 1e-9 * (1 + exact)  # upper bound
            worst = max(worst, abs(np.log1p(smooth) - np.log1p(exact)))
        # error in the exponent is at most kappa (log(1 + 2n) + knee) / beta
        assert worst <= params.kappa * (np.log(15) + params.knee) / beta + 1e-9
        assert worst < previous
        previous = worst
    assert previous < 1e-3


def _one_facet_surrogate(d: float, params: CapabilityParameters) -> float:
    """The surrogate of one facet at signed distance ``d`` from a unit ball at the origin (rho = 1)."""
    A, b = np.array([[0.0, 0.0, 1.0]]), np.array([d + 1.0])
    return float(smooth_capability_penalty(A, b, np.zeros(3), np.array(1.0), params))


def test_surrogate_knee_puts_the_smoothing_band_inside_the_polytope():
    """The knee shifts the log-sum-exp by ``knee / beta`` (in ``d / rho``): at ``d = 0`` the surrogate's
    exponent has ``sigmoid(knee)`` of the exact exponent's slope ``kappa / rho``; it stays an upper bound."""
    from scipy.optimize import minimize_scalar
    from scipy.special import expit

    rho = 1.0  # |f| = 0, r = 1: rho = max(|f| + r, eps)
    for knee in (0.0, 1.0, 3.0):
        params = CapabilityParameters(knee=knee, eps_normal=1e-12)
        h = 1e-7
        # the exponent's slope (the penalty's own slope is this times 1 + c~(0))
        slope = (np.log1p(_one_facet_surrogate(-h, params)) - np.log1p(_one_facet_surrogate(h, params))) / (2 * h)
        assert slope == pytest.approx(params.kappa / rho * expit(knee), rel=1e-4)
        for d in np.linspace(-2.0, 2.0, 41):  # an upper bound of the exact penalty everywhere
            exact = capability_penalty(d, rho, params.kappa, params.max_exponent)
            assert _one_facet_surrogate(d, params) >= exact - 1e-12
    # where the exact J1 stops on the ball's edge (a pull of 0.6 of its kink slope toward d < 0),
    # the centred surrogate stops outside and the default knee inside, within (knee + 1) rho / beta
    pull = 0.6 * 3.0 / rho
    for knee, inside in ((0.0, False), (3.0, True)):
        params = CapabilityParameters(knee=knee, eps_normal=1e-12)
        best = minimize_scalar(lambda d, p=params: _one_facet_surrogate(d, p) + pull * d, bounds=(-1, 1),
                               method="bounded", options={"xatol": 1e-10}).x
        assert bool(best >= 0) == inside
        assert abs(best) <= (knee + 1) * rho / params.beta


def test_casadi_surrogate_equals_numpy(robot):
    params = CapabilityParameters()
    Js, taus, fs, rs = ca.SX.sym("J", 3, 7), ca.SX.sym("tau", 7), ca.SX.sym("f", 3), ca.SX.sym("r")
    fn = ca.Function("c", [Js, taus, fs, rs],
                     [smooth_penalty_expr(Js, taus, robot.torque_limits, fs, rs, params)])
    for J, tau, f, r in random_cases(robot, 30, 14):
        A, b = halfspaces(J, *residual_margins(tau, robot.torque_limits), params.alpha)
        expected = smooth_capability_penalty(A, b, f, np.array(r), params)
        assert float(fn(J, tau, f, r)) == pytest.approx(float(expected), rel=1e-9, abs=1e-12)


def test_bad_parameters():
    with pytest.raises(InvalidInputError, match="alpha"):
        CapabilityParameters(alpha=0.0)
    with pytest.raises(InvalidInputError, match="kappa"):
        CapabilityParameters(kappa=-1.0)


def test_manipulability_closed_forms(robot):
    J = np.diag([0.5, 0.2, 0.1])
    assert yoshikawa(J) == pytest.approx(0.01)
    assert manipulability(J, lam=0.01) == pytest.approx(np.sqrt(0.26 * 0.05 * 0.02))
    rng = np.random.default_rng(15)
    Js = ca.SX.sym("J", 3, 7)
    fn = ca.Function("mu", [Js], [manipulability_expr(Js, 1e-6)])
    for _ in range(10):
        Jr = robot.arm_jacobian(random_configuration(robot, rng))
        s = np.linalg.svd(Jr, compute_uv=False)
        assert manipulability(Jr) == pytest.approx(np.sqrt(np.prod(s**2 + 1e-6)))
        assert yoshikawa(Jr) == pytest.approx(np.prod(s))
        assert float(fn(Jr)) == pytest.approx(manipulability(Jr))


def test_ellipsoid_axes_bound_the_image_of_the_unit_ball(robot):
    J = robot.arm_jacobian(robot.home())
    lengths, axes = ellipsoid_axes(J)
    assert np.all(np.diff(lengths) <= 0)
    np.testing.assert_allclose(axes.T @ axes, np.eye(3), atol=1e-12)
    rng = np.random.default_rng(16)
    qd = rng.normal(size=(500, 7))
    qd /= np.linalg.norm(qd, axis=1, keepdims=True)
    v = qd @ J.T
    # points J qd with |qd| = 1 satisfy sum (a_i . v / l_i)^2 <= 1
    coords = (v @ axes) / lengths
    assert np.all(np.sum(coords**2, axis=1) <= 1 + 1e-9)
