"""Desired task force f_k = m (p''_k - g) with backward differences (paper, Section 4.1)."""

from __future__ import annotations

import numpy as np
import pytest

from forte.exceptions import InvalidInputError
from forte.force.taskforce import given_force, mass_range_radius, payload_force
from forte.model.trajectory import backward_differences, quintic_path


def test_static_payload_needs_upward_gravity_compensation():
    t = np.linspace(0, 1, 5)
    p = np.tile([0.5, 0.0, 0.9], (5, 1))
    task = payload_force(t, p, mass=2.7)
    np.testing.assert_allclose(task.f, np.tile([0, 0, 2.7 * 9.81], (5, 1)))
    np.testing.assert_allclose(task.r, 10.0)
    np.testing.assert_allclose(task.direction, np.tile([0, 0, 1.0], (5, 1)))


def test_constant_acceleration_is_recovered_after_the_first_samples():
    dt = 0.1
    t = np.arange(8) * dt
    acc = np.array([0.4, -0.2, 1.5])
    p = 0.5 * t[:, None] ** 2 * acc
    task = payload_force(t, p, mass=2.0, radius=5.0)
    # k = 0: at rest; k = 1: v_0 = 0 so a_1 = v_1 / dt = acc / 2; k >= 2: exact
    np.testing.assert_allclose(task.f[0], 2.0 * np.array([0, 0, 9.81]))
    np.testing.assert_allclose(task.f[1], 2.0 * (acc / 2 + [0, 0, 9.81]))
    np.testing.assert_allclose(task.f[2:], np.tile(2.0 * (acc + [0, 0, 9.81]), (6, 1)), atol=1e-9)


def test_backward_differences_with_uneven_steps():
    t = np.array([0.0, 0.1, 0.3, 0.35])
    x = np.array([[0.0], [1.0], [2.0], [4.0]])
    v, a = backward_differences(x, t)
    np.testing.assert_allclose(v[:, 0], [0, 10, 5, 40])
    np.testing.assert_allclose(a[:, 0], [0, 100, -25, 700])


def test_quintic_path_passes_knots_at_rest():
    kt = np.array([0.0, 1.0, 3.0])
    knots = np.array([[0.0, 0, 0], [1, 2, 3], [0, 0, 1]])
    t = np.linspace(0, 3, 301)
    p = quintic_path(kt, knots, t)
    np.testing.assert_allclose(p[[0, 100, 300]], knots, atol=1e-12)
    v = np.gradient(p, t, axis=0)
    assert np.abs(v[100]).max() < 0.05  # rest at the interior knot


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"mass": -1.0}, "mass: expected a finite number >= 0"),
        ({"mass": float("nan")}, "mass: expected a finite number >= 0"),
        ({"mass": 1.0, "t": [0.0, 0.2, 0.1]}, "t[2]: time stamps must be strictly increasing"),
        ({"mass": 1.0, "positions": np.zeros((3, 2))}, "positions: expected shape (3, 3), got (3, 2)"),
        ({"mass": 1.0, "radius": -2.0}, "radius: expected a finite number >= 0"),
    ],
)
def test_bad_task_force_inputs(kwargs, message):
    args = {"t": [0.0, 0.1, 0.2], "positions": np.zeros((3, 3))} | kwargs
    with pytest.raises(InvalidInputError) as err:
        payload_force(**args)
    assert message in str(err.value)


def test_given_force_profile():
    task = given_force([0, 1], [[1, 2, 3], [0, 0, 0]], radius=[1, 2])
    np.testing.assert_allclose(task.magnitude, [np.sqrt(14), 0])
    np.testing.assert_allclose(task.direction[1], [0, 0, 1])
    with pytest.raises(InvalidInputError, match=r"radius\[1\]"):
        given_force([0, 1], [[1, 2, 3], [0, 0, 0]], radius=[1, -2])


def test_mass_range_radius_hand_example() -> None:
    # Holding still: f = M g upward with M = 2.7 + 1.146 kg; the range [1.0, 4.5] kg is 1.8 kg
    # wide on the heavy side, so the ball needs 1.8 g = 17.66 N; [2.0, 3.5] needs 0.8 g = 7.85 N,
    # less than the 10 N floor.
    t, pos = np.array([0.0, 1.0]), np.zeros((2, 3))
    total = 2.7 + 1.146
    force = payload_force(t, pos, total, 10.0)
    wide = mass_range_radius(force, total, 2.7, (1.0, 4.5), 10.0)
    np.testing.assert_allclose(wide.r, 1.8 * 9.81, rtol=1e-3)
    np.testing.assert_allclose(mass_range_radius(force, total, 2.7, (2.0, 3.5), 10.0).r, 10.0)
    np.testing.assert_array_equal(wide.f, force.f)
    with pytest.raises(InvalidInputError, match="low <= mass <= high"):
        mass_range_radius(force, total, 2.7, (3.0, 4.0), 10.0)


def test_mass_range_ball_contains_every_mass_of_the_range() -> None:
    rng = np.random.default_rng(3)
    t = np.linspace(0.0, 2.0, 21)
    pos = np.cumsum(rng.normal(0, 0.01, (21, 3)), axis=0)
    mass, low, high, tool = 1.5, 0.9, 2.4, 1.146
    force = payload_force(t, pos, mass + tool, 0.0)
    ball = mass_range_radius(force, mass + tool, mass, (low, high), 0.0)
    for m in np.linspace(low, high, 13):
        other = payload_force(t, pos, m + tool, 0.0)
        assert np.all(np.linalg.norm(other.f - ball.f, axis=1) <= ball.r + 1e-9)
    # the extreme mass touches the ball's surface somewhere (the radius is not loose)
    extreme = payload_force(t, pos, high + tool, 0.0)
    np.testing.assert_allclose(np.linalg.norm(extreme.f - ball.f, axis=1), ball.r, rtol=1e-12)
