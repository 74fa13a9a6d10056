"""Controller references: the quintic Hermite against scipy, the plan's own derivatives at the knots."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import BPoly

from forte.exceptions import InvalidInputError
from forte.execution.reference import plan_reference, quintic_hermite
from forte.model.trajectory import backward_differences


def _random_plan(seed: int = 0, n: int = 9, d: int = 4):
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(0.1, 0.4, n)) - 0.1
    return t, np.cumsum(rng.normal(0.0, 0.05, (n, d)), axis=0)


def test_quintic_hermite_equals_scipy_s_piecewise_polynomial_from_derivatives():
    t, q = _random_plan()
    rng = np.random.default_rng(1)
    v, a = rng.normal(size=q.shape), rng.normal(size=q.shape)
    times = np.sort(rng.uniform(t[0], t[-1], 200))
    pos, vel, acc = quintic_hermite(t, q, v, a, times)
    for j in range(q.shape[1]):
        ref = BPoly.from_derivatives(t, np.stack([q[:, j], v[:, j], a[:, j]], axis=1))
        np.testing.assert_allclose(pos[:, j], ref(times), atol=1e-9)
        np.testing.assert_allclose(vel[:, j], ref(times, 1), atol=1e-8)
        np.testing.assert_allclose(acc[:, j], ref(times, 2), atol=1e-7)


def test_plan_reference_has_the_plan_s_backward_differences_at_its_waypoints():
    t, q = _random_plan(2, d=10)
    v, a = backward_differences(q, t)
    ref = plan_reference(t, q, t, kind="plan")
    np.testing.assert_allclose(ref.q, q, atol=1e-12)
    np.testing.assert_allclose(ref.dq, v, atol=1e-9)
    np.testing.assert_allclose(ref.ddq, a, atol=1e-7)
    # the spline passes through the same points with its own derivatives
    spline = plan_reference(t, q, t)
    np.testing.assert_allclose(spline.q, q, atol=1e-12)
    assert np.abs(spline.ddq - a).max() > 1e-3
    # outside the plan: the last waypoint held at rest
    after = plan_reference(t, q, np.array([t[-1] + 1.0]), kind="plan")
    np.testing.assert_allclose(after.q[0], q[-1])
    assert not after.dq.any() and not after.ddq.any()


def test_unknown_reference_kind_is_refused():
    t, q = _random_plan()
    with pytest.raises(InvalidInputError, match="reference: expected one of spline, plan"):
        plan_reference(t, q, t, kind="linear")


@pytest.mark.parametrize("n", [1, 2, 3, 7, 40])
def test_clamped_spline_equals_scipy_s(n):
    from scipy.interpolate import CubicSpline

    from forte.model.trajectory import clamped_spline

    rng = np.random.default_rng(n)
    t = np.cumsum(rng.uniform(0.1, 0.6, n))
    q = rng.normal(size=(n, 4))
    times = np.linspace(t[0] - 0.2, t[-1] + 0.2, 301)
    pos, vel, acc = clamped_spline(t, q, times)
    if n == 1:
        assert np.all(pos == q[0]) and not vel.any() and not acc.any()
        return
    ref = CubicSpline(t, q, axis=0, bc_type="clamped")
    tc = np.clip(times, t[0], t[-1])
    inside = ((times >= t[0]) & (times <= t[-1]))[:, None]
    np.testing.assert_allclose(pos, ref(tc), atol=1e-10)
    np.testing.assert_allclose(vel, np.where(inside, ref(tc, 1), 0.0), atol=1e-9)
    np.testing.assert_allclose(acc, np.where(inside, ref(tc, 2), 0.0), atol=1e-8)


def test_a_spline_that_ends_at_rest_is_clamped_where_the_rest_begins():
    """A motion that arrives at a joint limit and rests there (a goal at the limit): the spline through
    the rest's equal knots would ring past the limit; the executed one stops at the rest's first knot
    (SciPy's clamped spline on the knots up to it) and holds; so does one that rests just inside
    the limit (within LIMIT_REST_NEAR). A coordinate that rests inside its range, and any coordinate
    without limits given, keeps the spline through every knot."""
    from scipy.interpolate import CubicSpline

    from forte.model.trajectory import LIMIT_REST_NEAR, clamped_spline, resting_from

    t = np.linspace(0.0, 2.9, 30)
    limit = 2.8973
    q = np.full((30, 3), limit)
    q[:28, 0] = np.linspace(2.0, limit, 28)  # arriving at a constant speed
    q[:, 1] = np.r_[np.sin(np.linspace(0, 4, 28)), np.sin(4.0), np.sin(4.0)]  # rests inside its range
    near = limit - 0.5 * LIMIT_REST_NEAR
    q[:, 2] = np.r_[np.linspace(2.0, near, 28), near, near]  # rests 5 mrad inside the limit
    assert resting_from(q) == 27
    times = np.linspace(0.0, 3.2, 2001)
    limits = (np.full(3, -limit), np.full(3, limit))
    pos, vel, acc = clamped_spline(t, q, times, limits=limits)
    assert pos[:, 0].max() <= limit + 1e-12
    through = CubicSpline(t, q, axis=0, bc_type="clamped")
    assert through(times)[:, 0].max() > limit + 1e-4  # through every knot: past the limit
    ref = CubicSpline(t[:28], q[:28, 0], bc_type="clamped")
    early = times <= t[27]
    np.testing.assert_allclose(pos[early, 0], ref(times[early]), atol=1e-10)
    assert np.all(pos[~early, 0] == limit) and not vel[~early, 0].any() and not acc[~early, 0].any()
    inside = np.clip(times, t[0], t[-1])
    np.testing.assert_allclose(pos[:, 1], through(inside)[:, 1], atol=1e-10)  # not at a limit
    assert through(times)[:, 2].max() > near + 1e-4 and pos[:, 2].max() <= near + 1e-12  # near it: clamped
    np.testing.assert_allclose(clamped_spline(t, q, times)[0], through(inside), atol=1e-10)  # no limits given
