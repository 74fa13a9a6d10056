"""Dynamic residual force polytope: a hand-computed example, random-state properties, pycapacity."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import TWO_LINK_J, TWO_LINK_TAU_MAX, TWO_LINK_TAU_NOM, random_configuration

from forte.capability.polytope import (
    cone_directions,
    cone_measure,
    contains,
    directional_capacity,
    facets,
    halfspaces,
    inscribed_radius,
    nominal_torques,
    residual_margins,
    trajectory_rfp,
    vertices,
)
from forte.exceptions import InvalidInputError
from forte.model.robot import MobileManipulator
from forte.model.trajectory import backward_differences

J2, TAU_MAX, TAU_NOM = TWO_LINK_J, TWO_LINK_TAU_MAX, TWO_LINK_TAU_NOM


def test_two_link_margins_and_halfspaces_by_hand():
    plus, minus = residual_margins(TAU_NOM, TAU_MAX)
    np.testing.assert_allclose(plus, [8, 6])
    np.testing.assert_allclose(minus, [-12, -4])
    A, b = halfspaces(J2, plus, minus)
    # -fx + fy <= 8, -fx <= 6, fx - fy <= 12, fx <= 4
    np.testing.assert_allclose(A, [[-1, 1, 0], [-1, 0, 0], [1, -1, 0], [1, 0, 0]])
    np.testing.assert_allclose(b, [8, 6, 12, 4])
    A8, b8 = halfspaces(J2, plus, minus, alpha=0.5)
    np.testing.assert_allclose(b8, [4, 3, 6, 2])
    assert directional_capacity(A, b, [1, 0, 0]) == pytest.approx(4.0)
    assert directional_capacity(A, b, [0, 1, 0]) == pytest.approx(8.0)
    assert directional_capacity(A, b, [0, 0, 1]) == np.inf  # planar arm: no z constraint
    assert inscribed_radius(A, b) == pytest.approx(4.0)


def test_alpha_out_of_range_is_rejected():
    with pytest.raises(InvalidInputError, match="alpha"):
        halfspaces(J2, [1, 1], [-1, -1], alpha=1.5)


def two_link_urdf(tmp_path, m1=2.0, m2=1.0):
    """A vertical-plane 2R arm: links of 1 m along x with point-like masses at their tips."""
    link = """<link name="{n}"><inertial><origin xyz="{x} 0 0"/><mass value="{m}"/>
      <inertia ixx="1e-9" iyy="1e-9" izz="1e-9" ixy="0" ixz="0" iyz="0"/></inertial></link>"""
    text = f"""<robot name="twolink"><link name="base"/>
      {link.format(n="l1", x=1.0, m=m1)}{link.format(n="l2", x=1.0, m=m2)}
      <link name="tip"/>
      <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
        <axis xyz="0 -1 0"/><limit effort="10" lower="-3" upper="3" velocity="1"/></joint>
      <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/><origin xyz="1 0 0"/>
        <axis xyz="0 -1 0"/><limit effort="5" lower="-3" upper="3" velocity="1"/></joint>
      <joint name="jt" type="fixed"><parent link="l2"/><child link="tip"/><origin xyz="1 0 0"/></joint>
    </robot>"""
    path = tmp_path / "twolink.urdf"
    path.write_text(text)
    return MobileManipulator(path, "tip", name="twolink")


def test_two_link_gravity_torques_by_hand(tmp_path):
    arm = two_link_urdf(tmp_path)
    g = 9.81
    for q1, q2 in [(0.0, 0.0), (0.3, 0.5), (-0.7, 1.2)]:
        qa = np.array([q1, q2])
        # Axis -y: positive angles lift the links (z up). tau = moments of the weights.
        tau1 = g * (2.0 * np.cos(q1) + 1.0 * (np.cos(q1) + np.cos(q1 + q2)))
        tau2 = g * 1.0 * np.cos(q1 + q2)
        np.testing.assert_allclose(arm.rnea(qa, [0, 0], [0, 0]), [tau1, tau2], atol=1e-9)
        J = arm.arm_jacobian(np.r_[0, 0, 0, qa])
        s1, s12, c1, c12 = np.sin(q1), np.sin(q1 + q2), np.cos(q1), np.cos(q1 + q2)
        np.testing.assert_allclose(J, [[-s1 - s12, -s12], [0, 0], [c1 + c12, c12]], atol=1e-12)


def test_nominal_torques_use_backward_differences(robot):
    rng = np.random.default_rng(5)
    t = np.cumsum(rng.uniform(0.05, 0.2, size=6))
    q = np.array([random_configuration(robot, rng) for _ in t])
    tau = nominal_torques(robot, q, t)
    dq, ddq = backward_differences(q[:, 3:], t)
    # independent: explicit formulas of the paper, first sample at rest
    k = 3
    dq3 = (q[k, 3:] - q[k - 1, 3:]) / (t[k] - t[k - 1])
    dq2 = (q[k - 1, 3:] - q[k - 2, 3:]) / (t[k - 1] - t[k - 2])
    np.testing.assert_allclose(dq[k], dq3)
    np.testing.assert_allclose(ddq[k], (dq3 - dq2) / (t[k] - t[k - 1]))
    np.testing.assert_allclose(tau[k], robot.rnea(q[k, 3:], dq3, (dq3 - dq2) / (t[k] - t[k - 1])))
    np.testing.assert_allclose(tau[0], robot.rnea(q[0, 3:], np.zeros(7), np.zeros(7)))


def random_rfps(robot, count, seed):
    rng = np.random.default_rng(seed)
    for _ in range(count):
        q = random_configuration(robot, rng)
        qa = q[3:]
        tau = robot.rnea(qa, 0.3 * rng.normal(size=7), 0.3 * rng.normal(size=7))
        J = robot.arm_jacobian(q)
        yield J, tau, halfspaces(J, *residual_margins(tau, robot.torque_limits))


def test_vertices_satisfy_the_halfspaces_with_three_active_rows(robot):
    for _, _, (A, b) in random_rfps(robot, 20, 6):
        V = vertices(A, b)
        if len(V) == 0:
            continue
        slack = b - V @ A.T
        assert np.all(slack >= -1e-6 * np.abs(b).max())
        assert np.all((np.abs(slack) < 1e-6 * np.abs(b).max()).sum(axis=1) >= 3)


def test_facets_tile_the_convex_hull(robot):
    """The facets' polygons (vertices ordered around each face) cover the hull SciPy computes:
    same total area; every polygon lies on its plane and is convex in the order given."""
    ConvexHull = pytest.importorskip("scipy.spatial").ConvexHull
    checked = 0
    for _, _, (A, b) in random_rfps(robot, 12, 9):
        V = vertices(A, b)
        if len(V) < 4:
            continue
        polygons = facets(A, b, V)
        area = 0.0
        for P in polygons:
            n = np.cross(P[1] - P[0], P[2] - P[0])
            assert np.allclose((P - P[0]) @ n, 0, atol=1e-6 * np.abs(P).max() ** 3)
            turns = [np.cross(P[i] - P[i - 1], P[(i + 1) % len(P)] - P[i]) for i in range(len(P))]
            assert all(t @ turns[0] >= -1e-9 * np.abs(P).max() ** 2 for t in turns)  # one turning sense
            area += 0.5 * np.linalg.norm(sum(np.cross(P[i], P[(i + 1) % len(P)]) for i in range(len(P))))
        assert area == pytest.approx(ConvexHull(V).area, rel=1e-6)
        checked += 1
    assert checked >= 5


def test_vertices_match_pycapacity(robot):
    pycapacity = pytest.importorskip("pycapacity.robot")
    checked = 0
    for J, tau, (A, b) in random_rfps(robot, 10, 7):
        if not np.all(contains(A, b, np.zeros(3))):
            continue  # pycapacity's enumeration assumes a non-empty polytope around the bias
        ours = vertices(A, b)
        theirs = pycapacity.force_polytope(J, robot.torque_limits, -robot.torque_limits, tau).vertices.T
        scale = np.abs(b).max()
        for v in theirs:
            assert np.min(np.linalg.norm(ours - v, axis=1)) < 1e-6 * scale
        for v in ours:
            assert np.min(np.linalg.norm(theirs - v, axis=1)) < 1e-6 * scale
        checked += 1
    assert checked >= 3


def test_directional_capacity_point_lies_on_the_boundary(robot):
    rng = np.random.default_rng(8)
    for _, _, (A, b) in random_rfps(robot, 30, 9):
        if not contains(A, b, np.zeros(3)):
            continue
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        t = directional_capacity(A, b, u)
        p = t * u
        assert np.max(A @ p - b) == pytest.approx(0.0, abs=1e-8 * np.abs(b).max())
        assert contains(A, b, 0.999 * p) and not contains(A, b, 1.001 * p + 1e-9)


def test_inscribed_radius_ball_fits(robot):
    rng = np.random.default_rng(10)
    sphere = rng.normal(size=(2000, 3))
    sphere /= np.linalg.norm(sphere, axis=1, keepdims=True)
    for _, _, (A, b) in random_rfps(robot, 10, 11):
        rad = inscribed_radius(A, b)
        if rad <= 0:
            continue
        assert np.all(contains(A, b, 0.999 * rad * sphere))
        # the touching point of the binding row lies outside a slightly larger ball
        norms = np.linalg.norm(A, axis=1)
        i = np.argmin(np.where(norms > 1e-9, b / np.maximum(norms, 1e-12), np.inf))
        assert not contains(A, b, 1.001 * rad * A[i] / norms[i])


def test_cone_measure_of_a_sphere_like_polytope_is_the_spherical_sector():
    u = np.array([0.2, -0.3, 0.9])
    rays = cone_directions(u, half_angle=0.35)
    assert rays.shape == (25, 3)
    np.testing.assert_allclose(np.linalg.norm(rays, axis=1), 1.0)
    angles = np.arccos(np.clip(rays @ (u / np.linalg.norm(u)), -1, 1))
    assert angles.max() == pytest.approx(0.35)
    R = 7.0
    A, b = rays, np.full(len(rays), R)  # tangent planes exactly on every ray
    omega = 2 * np.pi * (1 - np.cos(0.35))
    assert cone_measure(A, b, u) == pytest.approx(omega * R**3 / 3)


def test_trajectory_rfp_shapes(robot):
    t = np.linspace(0, 1, 4)
    q = np.tile(robot.home(), (4, 1))
    rfp = trajectory_rfp(robot, q, t, alpha=0.8)
    assert rfp.A.shape == (4, 14, 3) and rfp.b.shape == (4, 14)
    zeros = np.zeros(7)
    np.testing.assert_allclose(rfp.tau_nom[2], robot.rnea(q[2, 3:], zeros, zeros))
    np.testing.assert_allclose(rfp.b[0, :7], 0.8 * (robot.torque_limits - rfp.tau_nom[0]))


def test_zero_normal_rows_are_vacuous_or_empty():
    A = np.array([[1.0, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1], [0, 0, 0]])
    b = np.array([1.0, 1, 1, 1, 1, 1, 2])
    assert len(vertices(A, b)) == 8
    assert inscribed_radius(A, b) == pytest.approx(1.0)
    b[-1] = -0.5
    assert len(vertices(A, b)) == 0
    assert inscribed_radius(A, b) == -np.inf
