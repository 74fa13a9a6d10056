"""J5's sparse forms: every form equals its formula computed with scipy.fft.dct (value and gradient),
the optimizer's lifted NLP equals the formula on q, and lift plans do not move where the form is exact."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import casadi as ca
import numpy as np
import pytest
from scipy.fft import dct, idct

from forte.exceptions import InvalidInputError
from forte.model.trajectory import clamped_spline
from forte.planning.methods.catalog import Method, method_names, register_method, unregister_method
from forte.planning.nlp.optimizer import TrajectoryOptimizer
from forte.planning.planner import plan
from forte.planning.tasks.tasks import load_task
from forte.planning.terms.motion_terms import BaseSpectral, Smoothness
from forte.planning.terms.reference import base_spectral_cost
from forte.planning.terms.spectral import (
    DENSE_MAX_WAYPOINTS,
    banded_form,
    dct_matrix,
    neumann_laplacian,
    spectral_form,
)
from forte.settings import CostWeights, SolverOptions, TermSettings

#: J5 with gamma = 1 over the high frequencies (its exact form is sparse: the lifted rows).
FLAT = TermSettings({"base_spectral": {"power": 0.0}})


def spectral(task, **changes):
    """``task`` with the ``base_spectral`` term's settings ``changes``."""
    return replace(task, settings=task.settings.with_values("base_spectral", **changes))

LIFT = Path(__file__).resolve().parents[1] / "examples" / "tasks" / "lift.yaml"
#: (cutoff, power, ramp): the authors' set, the paper-demo set, a constant ramp, a weighted paper set.
SETTINGS = [(0.1, 2.0, True), (0.35, 0.0, False), (0.1, 0.0, True), (0.35, 1.0, False), (0.9, 0.0, False)]


def paper_gamma(n: int, cutoff: float, power: float, ramp: bool) -> np.ndarray:
    """gamma_l as the paper / the authors write it (independent of forte's code)."""
    x = np.arange(n) / (n - 1)
    if ramp:
        return np.where(x > cutoff, np.clip((x - cutoff) / (1 - cutoff), 0, None) ** power, 0.0)
    return np.where(np.arange(n) >= np.ceil(cutoff * n), x**power, 0.0)


def alternative_gamma(n: int, cutoff: float, power: float, ramp: bool, reference: int) -> np.ndarray:
    """The banded alternative's gamma_l written out: ((kappa_l - kappa(l_c)) / (l_r^2 - l_c^2))^(p/2)."""
    kappa = lambda ell: (2 * n / np.pi) ** 2 * np.sin(np.pi * ell / (2 * n)) ** 2  # noqa: E731
    ell, l_r = np.arange(n), reference - 1.0
    if ramp:
        l_c = cutoff * l_r
        return np.where(ell > l_c, ((kappa(ell) - kappa(l_c)) / (l_r**2 - l_c**2)) ** (power / 2), 0.0)
    return np.where(ell >= np.ceil(cutoff * reference), (kappa(ell) / l_r**2) ** (power / 2), 0.0)


def direct(b: np.ndarray, gamma: np.ndarray) -> tuple[float, np.ndarray]:
    """``1/2 sum gamma_l bhat_l^2`` and its gradient ``C^T (gamma bhat)`` with scipy's DCT."""
    bhat = dct(b, norm="ortho")
    return 0.5 * float(np.sum(gamma * bhat**2)), idct(gamma * bhat, norm="ortho")



def _derivatives_and_ad(opt, x, p, rng):
    """The NLP's assembled constraint Jacobian and Lagrangian Hessian (upper triangle) at ``(x, p)``
    with random multipliers, and CasADi's automatic ones of the same functions (all dense)."""
    xs, ps = ca.MX.sym("x", x.size), ca.MX.sym("p", p.size)
    out = opt.solver.oracle()(x=xs, p=ps)
    lam_g = rng.normal(size=out["g"].numel())
    lagrangian = 0.7 * out["f"] + ca.dot(ca.DM(lam_g), out["g"])
    auto = ca.Function("auto", [xs, ps], [ca.jacobian(out["g"], xs), ca.hessian(lagrangian, xs)[0]])
    jac_a, hess_a = (np.array(ca.densify(v)) for v in auto(x, p))
    _, jac = opt.solver.get_function("nlp_jac_g")(x, p)
    hess = np.array(ca.densify(opt.solver.get_function("nlp_hess_l")(x, p, 0.7, lam_g)))
    return np.array(ca.densify(jac)), jac_a, hess, hess_a

def test_dct_rows_and_the_laplacian_they_diagonalize():
    x = np.random.default_rng(1).normal(size=30)
    C = dct_matrix(30)
    np.testing.assert_allclose(C @ x, dct(x, norm="ortho"), atol=1e-12)
    lam = C @ neumann_laplacian(30).toarray() @ C.T
    np.testing.assert_allclose(lam, np.diag(4 * np.sin(np.pi * np.arange(30) / 60) ** 2), atol=1e-12)


@pytest.mark.parametrize("n", [7, 25, 41, 100, 400])
@pytest.mark.parametrize(("cutoff", "power", "ramp"), SETTINGS)
def test_every_form_equals_its_formula(n, cutoff, power, ramp):
    b = np.random.default_rng(n).normal(size=n) + np.linspace(0, 3, n)
    exact_value, exact_grad = direct(b, paper_gamma(n, cutoff, power, ramp))
    scale = 1 + abs(exact_value)
    for form in ("auto", "exact", "dense"):
        f = spectral_form(n, cutoff, power, ramp, form)
        if f.kind == "banded":
            continue
        assert f.value(b) == pytest.approx(exact_value, abs=1e-9 * scale)
        np.testing.assert_allclose(f.gradient(b), exact_grad, atol=1e-9 * scale)
    if power % 2 == 0:
        f = banded_form(n, cutoff, power, ramp, 41)
        value, grad = direct(b, alternative_gamma(n, cutoff, power, ramp, 41))
        assert f.kind == "banded" and f.value(b) == pytest.approx(value, abs=1e-9 * (1 + abs(value)))
        np.testing.assert_allclose(f.gradient(b), grad, atol=1e-9 * (1 + abs(value)))
        width = max(abs(i - j) for i, j in zip(*f.banded.nonzero(), strict=True)) if f.banded.nnz else 0
        assert width <= power // 2  # a polynomial of degree power/2 in the Laplacian


def test_the_exact_form_is_sparse_when_gamma_is_constant_over_the_high_set():
    f = spectral_form(400, 0.35, 0.0, False, "exact")
    assert f.kind == "lifted" and f.rows.shape == (140, 400) and f.banded.nnz == 400  # g0 I - g0 C_L^T C_L
    assert spectral_form(400, 0.9, 0.0, False, "exact").rows.shape[0] == 40  # lifts H when it is smaller
    assert spectral_form(400, 0.1, 2.0, True, "exact").kind == "dense"  # the authors' ramp has no sparse form


def test_auto_keeps_the_formula_up_to_64_waypoints_and_goes_banded_beyond():
    assert spectral_form(DENSE_MAX_WAYPOINTS, 0.1, 2.0, True).kind == "dense"
    assert spectral_form(DENSE_MAX_WAYPOINTS + 1, 0.1, 2.0, True).kind == "banded"
    assert spectral_form(400, 0.1, 0.0, True).kind == "lifted"  # exact and sparse: always
    assert spectral_form(400, 0.35, 1.0, False).kind == "dense"  # odd power: no banded form
    with pytest.raises(InvalidInputError, match="even power"):
        spectral_form(100, 0.35, 1.0, False, "banded")
    with pytest.raises(InvalidInputError, match="^form: expected one of auto, exact, dense, banded, got 'sparse'$"):
        BaseSpectral.from_settings({"base_spectral": {"form": "sparse"}})
    with pytest.raises(InvalidInputError, match="^reference_waypoints: expected an integer >= 2, got 1$"):
        BaseSpectral.from_settings({"base_spectral": {"reference_waypoints": 1}})


def test_the_banded_alternative_is_resolution_independent():
    """Its low set keeps its size and the weight of a given wavenumber converges as N grows;
    the authors' cutoff moves with N."""
    rows = {n: banded_form(n, 0.1, 2.0, True, 41).rows.shape[0] for n in (50, 100, 200, 400, 800)}
    assert set(rows.values()) == {5}  # l = 0..4 (l_c = 4)
    ell = np.arange(30)
    limit = np.where(ell > 4, (ell**2 - 16.0) / (40.0**2 - 16.0), 0.0)
    for n in (400, 1600):
        gamma = alternative_gamma(n, 0.1, 2.0, True, 41)[:30]
        assert np.abs(gamma - limit).max() < 30 * 30**2 / n**2  # kappa_l = l^2 (1 + O(l^2 / N^2))
    assert np.count_nonzero(paper_gamma(400, 0.1, 2.0, True) == 0) == 40  # vs 5 at N = 41


@pytest.fixture
def spectral_method():
    """An optimized method with J5 and the arm smoothness only (no compiled kernels needed)."""
    method = register_method(Method("test-j5", "J5 and smoothness", terms=("smoothness", "base_spectral")),
                             replace=True)
    yield method
    unregister_method("test-j5")


@pytest.mark.parametrize(("settings", "kind"), [
    ({}, "dense"), ({"power": 0.0}, "lifted"), ({"form": "banded", "reference_waypoints": 6}, "banded")])
def test_the_optimizer_minimizes_the_formula(robot, spectral_method, settings, kind):
    """Objective and reduced gradient of the lifted NLP on ``z = A q`` equal the formula (scipy's DCT);
    the assembled Jacobian and Hessian equal CasADi's AD of the lifted NLP; reports show the exact J5."""
    n, nq = 9, robot.nq
    weights, settings = CostWeights(), TermSettings({"base_spectral": settings})
    opt = TrajectoryOptimizer(robot, n, spectral_method, weights, options=SolverOptions(codegen=False),
                              settings=settings)
    assert opt.quadratic_forms["base_spectral"] == kind
    j5_term, arm = BaseSpectral.from_settings(settings), Smoothness.from_settings(settings).arm
    m = opt._lift.shape[0]
    assert (m > 0) == (kind != "dense")
    rng = np.random.default_rng(3)
    q = np.tile(robot.home(), (n, 1)) + 0.2 * rng.normal(size=(n, nq))
    T = np.repeat(robot.ee_pose(robot.home())[None], n, 0)
    t, f, r = np.linspace(0, 2, n), np.zeros((n, 3)), np.full(n, 10.0)
    p = opt.parameters(t, T, f, r)
    x = opt.full_x(q)
    value, grad = opt.solver.get_function("nlp_grad_f")(x, p)
    grad = np.array(grad).ravel()
    reduced = grad[: n * nq] + opt._lift.T @ grad[opt.spans.lifted]  # d/dq f(q, A q)
    # the executed spline's knot accelerations (on_spline, after z) are outside every cost term
    assert opt.spans.knots.stop > opt.spans.knots.start and not np.any(grad[opt.spans.knots])
    smooth = 0.5 * np.sum((np.diff(q, axis=0)[:, 3:] * arm) ** 2)
    gamma = (alternative_gamma(n, j5_term.cutoff, j5_term.power, True, 6) if kind == "banded"
             else paper_gamma(n, j5_term.cutoff, j5_term.power, j5_term.ramp))
    w5 = weights.base_spectral
    parts = [direct(q[:, i], gamma) for i in range(3)]
    j5 = sum(eta * v for eta, (v, _) in zip(j5_term.axis, parts, strict=True))
    assert float(value) == pytest.approx(weights.smoothness * smooth + w5 * j5, rel=1e-9)
    expected = np.zeros((n, nq))
    expected[1:, 3:] += weights.smoothness * arm**2 * np.diff(q, axis=0)[:, 3:]
    expected[:-1, 3:] -= weights.smoothness * arm**2 * np.diff(q, axis=0)[:, 3:]
    for i, (eta, (_, g)) in enumerate(zip(j5_term.axis, parts, strict=True)):
        expected[:, i] += w5 * eta * g
    np.testing.assert_allclose(reduced, expected.ravel(), atol=1e-9 * (1 + np.abs(expected).max()))
    # derivatives of the whole lifted NLP (pose rows, kinematic rows, lifting rows) against AD
    x = x + 0.05 * rng.normal(size=x.size)  # off the lifting manifold too
    jac, jac_a, hess, hess_a = _derivatives_and_ad(opt, x, p, rng)
    np.testing.assert_allclose(jac, jac_a, atol=1e-12)
    np.testing.assert_allclose(np.triu(hess) + np.triu(hess, 1).T, hess_a, atol=1e-10 * (1 + np.abs(hess_a).max()))
    # what reports show is J5 itself, whatever form the solver used
    terms = opt.cost_terms(q, t, T, f, r)
    assert terms["base_spectral"] == pytest.approx(base_spectral_cost(q[:, :3], settings), rel=1e-9)


def test_multipliers_shift_around_the_lifted_block(robot, spectral_method):
    n, nq = 9, robot.nq
    opt = TrajectoryOptimizer(robot, n, spectral_method, CostWeights(),
                              options=SolverOptions(codegen=False), settings=FLAT)
    ng, nx = opt.solver.size_out("g")[0], opt.solver.size_in("x0")[0]
    lam_x = np.concatenate([np.repeat(np.arange(n, dtype=float), nq), np.full(nx - n * nq, -1.0)])
    lam_g = np.arange(ng, dtype=float)
    sx, sg = opt.shifted_multipliers(lam_x, lam_g, 2)
    assert sx.shape == lam_x.shape and sg.shape == lam_g.shape
    np.testing.assert_array_equal(sx[: n * nq].reshape(n, nq)[:, 0], [2, 3, 4, 5, 6, 7, 8, 8, 8])
    np.testing.assert_array_equal(sx[n * nq:], -1.0)  # the lifted variables' and knot accelerations' blocks stay
    after = opt.spans.lifting.start  # so do the lifting rows and everything after them (the spline's rows)
    assert opt.spans.lifting.stop > after
    np.testing.assert_array_equal(sg[after:], lam_g[after:])


def test_bounds_cover_the_lifted_variables_and_rows(robot, spectral_method):
    """``bounds`` and ``full_x`` fit the lifted NLP (what a caller of the raw solver, such as
    the SQP benchmark, hands it): z free, lifting rows 0, and ``full_x(q)`` satisfies them."""
    n, nq = 9, robot.nq
    opt = TrajectoryOptimizer(robot, n, spectral_method, CostWeights(),
                              options=SolverOptions(codegen=False), settings=FLAT)
    m = opt._lift.shape[0]
    assert m > 0
    q0 = robot.home()
    t = np.linspace(0, 2, n)
    b = opt.bounds(t, q0)
    spans = opt.spans  # [vec(q); z; the spline's knot accelerations] (on_spline: on by default)
    knots = spans.knots.stop - spans.knots.start
    assert spans.lifted == slice(n * nq, n * nq + m) and knots == len(opt._spline_rows) * n > 0
    assert b.lbx.size == b.ubx.size == opt.solver.size_in("x0")[0] == n * nq + m + knots
    assert b.lbg.size == b.ubg.size == opt.solver.size_in("lbg")[0] == spans.keep_level.stop
    np.testing.assert_array_equal(b.lbx[:nq], q0)
    np.testing.assert_array_equal(b.ubx[:nq], q0)
    assert np.all(b.lbx[spans.lifted] == -np.inf) and np.all(b.ubx[spans.lifted] == np.inf)
    np.testing.assert_array_equal(b.ubx[spans.knots], np.tile(opt._acc[opt._spline_rows], n))
    np.testing.assert_array_equal(b.lbx[spans.knots], -b.ubx[spans.knots])
    assert spans.lifting.stop - spans.lifting.start == m
    np.testing.assert_array_equal(b.lbg[spans.lifting], 0)
    np.testing.assert_array_equal(b.ubg[spans.lifting], 0)
    q = np.tile(q0, (n, 1)) + 0.01 * np.random.default_rng(4).normal(size=(n, nq))
    T = np.repeat(robot.ee_pose(q0)[None], n, 0)
    p = opt.parameters(t, T, np.zeros((n, 3)), np.full(n, 10.0))
    g = np.array(opt.solver.oracle()(x=opt.full_x(q), p=p)["g"]).ravel()
    np.testing.assert_allclose(g[spans.lifting], 0, atol=1e-12)  # z = A vec(q)
    # and the knot accelerations of full_x are the spline's: its continuity rows (the spline
    # block's first ones, equalities) hold at their bounds, 0 from a start at rest
    continuity = slice(spans.spline.start, spans.spline.start + knots)
    np.testing.assert_array_equal(b.lbg[continuity], b.ubg[continuity])
    np.testing.assert_allclose(g[continuity], b.lbg[continuity], atol=1e-9)


@pytest.mark.slow
def test_a_replanner_with_lifted_variables_shifts_its_horizon():
    from forte.planning.online.replan import Replanner

    task = load_task(LIFT, waypoints=15)
    task = replace(task, settings=task.settings.with_values("base_spectral", form="banded", reference_waypoints=8))
    planner = Replanner(task)
    assert planner.optimizer._lift.shape[0] > 0
    result = planner.shift(2)
    assert result.plan.solved and result.warm


@pytest.mark.slow
@pytest.mark.parametrize("method", method_names(optimized=True))
def test_lift_plans_do_not_move_where_the_form_is_exact(method):
    """lift.yaml (N = 41): the default equals the dense formula, and the lifted exact form of a
    constant gamma (power 0) plans what its dense matrix plans, to the solver's tolerance."""
    task = load_task(LIFT)
    dense = plan(spectral(task, form="dense"), method)
    default = plan(task, method)
    assert dense.solved and default.solved
    np.testing.assert_allclose(default.q, dense.q, atol=1e-9)
    lifted = plan(spectral(task, power=0.0), method)
    flat_dense = plan(spectral(task, power=0.0, form="dense"), method)
    assert lifted.solved and flat_dense.solved
    if "base_spectral" in lifted.solver["quadratic_forms"]:
        assert lifted.solver["quadratic_forms"]["base_spectral"] == "lifted"
    np.testing.assert_allclose(lifted.q, flat_dense.q, atol=1e-6)
    assert lifted.solver["objective"] == pytest.approx(flat_dense.solver["objective"], rel=1e-8)


@pytest.mark.slow
def test_the_banded_alternative_plans_the_authors_lift_like_the_formula():
    """N = 100 (``auto`` is banded there): the plan stays within 1 mm / 1 mrad of the dense formula's
    and J5's exact value within 5 % (measured: 6.8e-5, 0.4 %; benchmarks/bench_scaling.py)."""
    task = load_task(LIFT, waypoints=100)
    banded = plan(task, "forte")
    dense = plan(spectral(task, form="dense"), "forte")
    assert banded.solver["quadratic_forms"]["base_spectral"] == "banded" and banded.solved and dense.solved
    assert np.abs(banded.q - dense.q).max() < 1e-3
    j5 = banded.solver["cost_terms"]["base_spectral"], dense.solver["cost_terms"]["base_spectral"]
    assert j5[0] == pytest.approx(j5[1], rel=0.05)


def test_the_spline_rows_knot_accelerations_follow_the_lifted_block(robot, spectral_method):
    """With J5 lifted and the spline rows on, the knot accelerations are the last variables: the
    spline's own (full_x) meet their rows, and the assembled Jacobian and Hessian of the whole NLP
    equal CasADi's AD."""
    n, nq = 9, robot.nq
    opt = TrajectoryOptimizer(robot, n, spectral_method, CostWeights(), options=SolverOptions(codegen=False),
                              settings=FLAT, goal="configuration", on_spline=True)
    m, arm = opt._lift.shape[0], len(opt._spline_rows)
    assert m > 0 and arm > 0
    rng = np.random.default_rng(5)
    q = np.tile(robot.home(), (n, 1)) + 0.2 * rng.normal(size=(n, nq))
    T = np.repeat(robot.ee_pose(robot.home())[None], n, 0)
    t, f, r = np.linspace(0, 2, n), np.zeros((n, 3)), np.full(n, 10.0)
    p = opt.parameters(t, T, f, r)
    x = opt.full_x(q)
    assert x.size == n * nq + m + arm * n
    g = np.array(opt._g(x, p)).ravel()
    velocity = len(opt._spline.velocity) * (2 * n - 3)  # the velocity rows, after the continuity rows
    end = g.size - opt._lateral - velocity
    np.testing.assert_allclose(g[end - arm * n:end], 0.0, atol=1e-8)  # the spline rows, at rest at the start
    lbx, ubx, _, ubg = opt.bounds(t, q[0], q_goal=q[-1])
    np.testing.assert_allclose(ubx[-arm * n:], np.tile(opt._spline.acceleration, n))
    fast = [opt._spline_rows[j] for j in opt._spline.velocity]  # the velocity rows' ends: the spline's knot slopes
    h = np.diff(t)[:, None]  # the rows are h v (the kinematic rows' units)
    ends = np.r_[g[end:end + velocity], np.zeros(len(fast))].reshape(n - 1, 2, len(fast))[:, 1] / h
    np.testing.assert_allclose(ends[:-1], clamped_spline(t, q[:, fast], t)[1][1:-1], atol=1e-9)
    np.testing.assert_allclose(ubg[end:end + velocity], (np.repeat(h, 2, 0) * opt._vel[fast]).ravel()[:velocity])
    x = x + 0.05 * rng.normal(size=x.size)
    jac, jac_a, hess, hess_a = _derivatives_and_ad(opt, x, p, rng)
    np.testing.assert_allclose(jac, jac_a, atol=1e-9 * (1 + np.abs(jac_a).max()))
    np.testing.assert_allclose(np.triu(hess) + np.triu(hess, 1).T, hess_a, atol=1e-10 * (1 + np.abs(hess_a).max()))
