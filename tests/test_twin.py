"""The CasADi twin agrees with Pinocchio numerics on random states (two different arms)."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from conftest import random_configuration

from forte.model.twin import CasadiTwin


@pytest.mark.parametrize("which", ["robot", "ur5"])
def test_twin_matches_pinocchio(which, request):
    r = request.getfixturevalue(which)
    fns = CasadiTwin(r).functions()
    rng = np.random.default_rng(3)
    for _ in range(200):
        q = random_configuration(r, rng)
        dq, ddq = rng.normal(size=(2, r.n_arm)) * 2
        R, p = fns["ee_pose"](q)
        T = r.ee_pose(q)
        np.testing.assert_allclose(np.array(R), T[:3, :3], atol=1e-9)
        np.testing.assert_allclose(np.array(p).ravel(), T[:3, 3], atol=1e-9)
        np.testing.assert_allclose(np.array(fns["arm_jacobian"](q)), r.arm_jacobian(q), atol=1e-9)
        tau = np.array(fns["rnea"](q[3:], dq, ddq)).ravel()
        np.testing.assert_allclose(tau, r.rnea(q[3:], dq, ddq), atol=1e-9)


def test_twin_derivatives_are_exact(robot):
    """The AD Jacobian of the twin's end-effector position equals the analytic arm Jacobian."""
    twin = CasadiTwin(robot)
    q = ca.SX.sym("q", robot.nq)
    _, p = twin.ee_pose(q)
    dp = ca.Function("dp", [q], [ca.jacobian(p, q)])
    rng = np.random.default_rng(4)
    for _ in range(20):
        qk = random_configuration(robot, rng)
        np.testing.assert_allclose(np.array(dp(qk))[:, 3:], robot.arm_jacobian(qk), atol=1e-12)
