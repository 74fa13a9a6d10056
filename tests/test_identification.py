"""Online payload identification: the RLS estimate on a MuJoCo run converges to the true mass."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from forte.exceptions import InvalidInputError
from forte.execution.identification import PayloadIdentifier
from forte.execution.model import build_sim_model
from forte.model.robot import N_BASE


def _identify(robot, true_mass: float, prior: float, seconds: float = 1.5):
    """Track a joint-space sine with a PD + gravity law that knows nothing of the payload, feed
    the identifier with MuJoCo's applied torques and accelerations; returns (times, estimates)."""
    sim = build_sim_model(robot, true_mass)
    q0 = robot.home()
    sim.set_state(q0)
    ident = PayloadIdentifier(robot, armature=sim.armature, prior_mass=prior)
    arm = sim.dof_idx[N_BASE:]
    times, estimates = [], []
    for k in range(int(seconds / sim.timestep)):
        t = k * sim.timestep
        q, dq = sim.state()
        q_d = q0[N_BASE:] + 0.3 * np.sin(2 * np.pi * 0.7 * t) * np.array([0, 1, 0, 1, 0, 1, 0])
        tau = robot.rnea(q[N_BASE:], dq[N_BASE:], np.zeros(robot.n_arm)) + 300 * (q_d - q[N_BASE:]) - 30 * dq[N_BASE:]
        sim.data.ctrl[sim.arm_act] = np.clip(tau, -robot.torque_limits, robot.torque_limits)
        sim.data.ctrl[sim.base_act] = 0.0
        mujoco.mj_step(sim.model, sim.data)
        applied = sim.data.qfrc_actuator[arm].copy()
        estimates.append(ident.update(q, dq[N_BASE:], sim.data.qacc[arm].copy(), applied))
        times.append(t)
    return np.array(times), np.array(estimates), ident


@pytest.mark.parametrize(("true_mass", "prior"), [(2.7, 0.35), (0.5, 2.7)])
def test_estimate_converges_to_the_true_mass(robot, true_mass, prior):
    t, m, ident = _identify(robot, true_mass, prior)
    settled = m[t >= 0.5]
    assert np.all(np.abs(settled - true_mass) < 0.05 * true_mass + 0.02), (settled.min(), settled.max())
    assert ident.sigma < 0.05 and ident.samples == t.size
    # the radius rule grows with the uncertainty and never drops below r_min
    assert ident.radius([[0.0, 0.0, 0.0]])[0] == 10.0
    assert ident.radius([[0.0, 0.0, 0.0]], r_min=0.0)[0] == pytest.approx(9.81 * 3 * ident.sigma)


def test_regressor_is_the_payload_torque_per_kilogram(robot):
    """Closed form at rest: phi = J^T (0 - g) is the torque that holds 1 kg at the end effector."""
    ident = PayloadIdentifier(robot)
    q = robot.home()
    zeros = np.zeros(robot.n_arm)
    J = robot.arm_jacobian(q)
    np.testing.assert_allclose(ident.regressor(q, zeros, zeros), J.T @ np.array([0.0, 0.0, 9.81]), atol=1e-12)


def test_bad_forgetting_factor():
    from forte.model.robot import default_robot

    with pytest.raises(InvalidInputError, match="forgetting"):
        PayloadIdentifier(default_robot(), forgetting=1.5)
