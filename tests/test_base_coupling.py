"""The arm's feedforward on a moving base (forte.execution.base_coupling, ``controller.base_coupling``):
the arm rows of the whole-body inverse dynamics, against MuJoCo's own inverse dynamics, and what
it does to the arm's tracking while the base turns."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from forte.execution.base_coupling import BaseCoupling
from forte.execution.control import ControlGains, interpolate_plan
from forte.execution.gains import gains_from_mapping
from forte.execution.model import build_sim_model
from forte.execution.run import run_simulation
from forte.model.robot import MobileManipulator

MOUNT = np.eye(4)
MOUNT[:3, 3] = [0.2575, 0.0, 0.52]  # the authors' mount


@pytest.fixture(scope="module")
def robot() -> MobileManipulator:
    return MobileManipulator(urdf="erd:panda_description/urdf/panda.urdf", ee_frame="panda_hand",
                             base="holonomic", mount=MOUNT)


def test_the_arm_rows_are_mujocos_inverse_dynamics_and_the_fixed_ones_at_rest(robot):
    sim = build_sim_model(robot)
    coupling = BaseCoupling(robot)
    rng = np.random.default_rng(3)
    for _ in range(5):
        q = np.r_[rng.uniform(-1, 1, 3), rng.uniform(robot.lower, robot.upper)]
        dq, ddq = rng.normal(size=robot.nq), rng.normal(size=robot.nq)
        sim.set_state(q, dq)
        sim.data.qacc[:] = 0.0
        sim.data.qacc[sim.dof_idx] = ddq
        mujoco.mj_inverse(sim.model, sim.data)  # MuJoCo's whole body: slides, hinge, the arm
        mj = sim.data.qfrc_inverse[sim.dof_idx[3:]] - sim.armature * ddq[3:]
        ours = coupling.torques(q, dq, ddq)
        assert np.allclose(ours, mj, atol=1e-8)
        at_rest = coupling.torques(q, np.r_[0.0, 0.0, 0.0, dq[3:]], np.r_[0.0, 0.0, 0.0, ddq[3:]])
        assert np.allclose(at_rest, robot.rnea(q[3:], dq[3:], ddq[3:]), atol=1e-9)
        assert np.abs(ours - at_rest).max() > 0.5  # the base's motion is felt at the joints


def test_the_option_is_off_by_default_and_read_from_the_controller_mapping(robot):
    assert not ControlGains().base_coupling
    assert gains_from_mapping({"base_coupling": True}, robot).base_coupling


def test_the_coupling_cuts_the_arms_error_while_the_base_turns_and_drives(robot):
    """The arm held outstretched while the base turns 1 rad and drives 0.3 m in 3 s: with the
    paper's feedforward the joints lag by the base's inertial forces; with the coupling they track
    several times closer."""
    t = np.linspace(0.0, 3.0, 31)
    s = 0.5 - 0.5 * np.cos(np.pi * t / 3.0)
    arm = np.array([0.0, 0.3, 0.0, -1.2, 0.0, 1.6, 0.785])
    q = np.column_stack([0.3 * s, np.zeros_like(s), s, np.tile(arm, (len(t), 1))])
    errors = {}
    for on in (False, True):
        sim = build_sim_model(robot)
        ref = interpolate_plan(t, q, np.arange(0.0, 3.5, sim.timestep))
        result = run_simulation(sim, ref, gains=ControlGains(base_coupling=on))
        errors[on] = result.summary["max_arm_joint_error_rad"]
    assert errors[True] < 0.5 * errors[False]
