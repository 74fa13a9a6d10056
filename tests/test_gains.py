"""Controller gains for any arm: the bandwidth rule, its 1 kHz stability and the ``controller:`` mapping."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from forte.exceptions import InvalidInputError
from forte.execution.control import DEFAULT_D_A, DEFAULT_K_A, ControlGains, sampled_loop_spectral_radius
from forte.execution.gains import (
    DEFAULT_BANDWIDTH_HZ,
    default_gains,
    gains_from_mapping,
    joint_inertia_diagonal,
)
from forte.execution.model import ARM_ARMATURE, build_sim_model
from forte.model.robot import MOCA_MOUNT, MOCA_TOOL, N_BASE, MobileManipulator

UR5_START = np.array([0.0, -1.2, 1.5, -1.9, -1.57, 0.0])


@pytest.fixture(scope="module")
def ur5_mounted() -> MobileManipulator:
    """A UR5 on the default robot's base: same mount and tool as the built-in Panda."""
    return MobileManipulator("erd:ur_description/urdf/ur5_robot.urdf", "tool0", name="ur5",
                             mount=np.array(MOCA_MOUNT), tool=MOCA_TOOL)


def _full_inertia(robot: MobileManipulator, q_a: np.ndarray) -> np.ndarray:
    """Arm block of MuJoCo's whole-body inertia (rotor inertia included) at ``q_a``."""
    sim = build_sim_model(robot)
    sim.set_state(np.concatenate([np.zeros(N_BASE), q_a]))
    M = np.zeros((sim.model.nv, sim.model.nv))
    mujoco.mj_fullM(sim.model, sim.data, M)
    arm = sim.dof_idx[N_BASE:]
    return M[np.ix_(arm, arm)]


def test_panda_keeps_franka_gains(robot: MobileManipulator) -> None:
    assert default_gains(robot) == ControlGains()
    assert default_gains(robot).K_a == DEFAULT_K_A and default_gains(robot).D_a == DEFAULT_D_A
    # Naming the rule switches the Panda to it.
    ruled = gains_from_mapping({"bandwidth_hz": 4.0}, robot)
    assert ruled.K_a != DEFAULT_K_A


def test_rule_values_from_the_joint_inertia(ur5_mounted: MobileManipulator) -> None:
    m = joint_inertia_diagonal(ur5_mounted, UR5_START)
    # Pinocchio's diagonal + rotor inertia equals the simulated arm's (MuJoCo) diagonal.
    assert np.allclose(m, np.diag(_full_inertia(ur5_mounted, UR5_START)), atol=1e-9)
    gains = default_gains(ur5_mounted, UR5_START)
    omega = 2 * np.pi * DEFAULT_BANDWIDTH_HZ
    assert np.allclose(gains.K_a, m * omega**2)
    assert np.allclose(gains.D_a, 2 * 1.0 * m * omega)
    slow = gains_from_mapping({"bandwidth_hz": 2.0, "damping_ratio": 0.5}, ur5_mounted, q_a=UR5_START)
    assert np.allclose(slow.K_a, m * (2 * np.pi * 2.0) ** 2)
    assert np.allclose(slow.D_a, 2 * 0.5 * m * 2 * np.pi * 2.0)


@pytest.mark.parametrize("arm", ["panda", "ur5"])
def test_default_rule_is_stable_at_1khz_everywhere(
    arm: str, robot: MobileManipulator, ur5_mounted: MobileManipulator
) -> None:
    # Gains fixed at the start configuration, inertia anywhere in the joint box: the sampled
    # loop stays stable (spectral radius < 1) with a wide margin on dt * eig(M^-1 D) < 2.
    r, start = (robot, robot.home()[N_BASE:]) if arm == "panda" else (ur5_mounted, np.zeros(6))
    gains = gains_from_mapping({"bandwidth_hz": DEFAULT_BANDWIDTH_HZ}, r, q_a=start)
    rng = np.random.default_rng(3)
    lo, hi = np.maximum(r.lower, -np.pi), np.minimum(r.upper, np.pi)
    worst_radius = worst_rate = 0.0
    for _ in range(150):
        M = _pin_inertia(r, rng.uniform(lo, hi))
        worst_radius = max(worst_radius, sampled_loop_spectral_radius(M, gains.K_a, gains.D_a, 1e-3))
        rate = np.abs(np.linalg.eigvals(np.linalg.solve(M, np.diag(gains.D_a)))).max() * 1e-3
        worst_rate = max(worst_rate, rate)
    assert worst_radius < 1.0
    assert worst_rate < 0.7


def _pin_inertia(robot: MobileManipulator, q_a: np.ndarray) -> np.ndarray:
    import pinocchio as pin

    M = pin.crba(robot.model, robot.data, q_a)
    return np.triu(M) + np.triu(M, 1).T + ARM_ARMATURE * np.eye(robot.n_arm)


def test_mapping_fields(ur5_mounted: MobileManipulator) -> None:
    m = joint_inertia_diagonal(ur5_mounted, UR5_START)
    K = [500.0, 800.0, 400.0, 100.0, 100.0, 40.0]
    g = gains_from_mapping({"K_a": K, "damping_ratio": 0.7}, ur5_mounted, q_a=UR5_START)
    assert g.K_a == tuple(K)
    assert np.allclose(g.D_a, 2 * 0.7 * np.sqrt(np.array(K) * m))  # damping of the given stiffness
    g = gains_from_mapping({"K_a": 50, "D_a": 5, "K_b": [1, 2, 3], "M_b": 4, "base_feedforward": False,
                            "force_feedforward": False}, ur5_mounted)
    assert g.K_a == (50.0,) * 6 and g.D_a == (5.0,) * 6
    assert g.K_b == (1.0, 2.0, 3.0) and g.M_b == (4.0,) * 3
    assert not g.base_feedforward and not g.force_feedforward
    assert g.B_b == ControlGains().B_b  # untouched base fields keep the defaults
    assert gains_from_mapping(None, ur5_mounted) == gains_from_mapping({}, ur5_mounted)


@pytest.mark.parametrize(("mapping", "message"), [
    ({"K_a": [1.0] * 7}, r"^controller\.K_a: expected 6 numbers >= 0 \(Nm/rad, one per arm joint\) or one "
                         r"number, got 7 numbers$"),
    ({"D_a": [1, 2, "x", 4, 5, 6]}, r"^controller\.D_a: expected 6 numbers .*, got \[1, 2, 'x', 4, 5, 6\]$"),
    ({"K_a": [1, 2, 3, -4, 5, 6]}, r"^controller\.K_a: expected 6 numbers >= 0 .*got \[1, 2, 3, -4, 5, 6\]$"),
    ({"M_b": [1, 0, 1]}, r"^controller\.M_b: expected 3 numbers > 0 \(kg, kg m\^2, one per base axis\)"),
    ({"K_b": [1, 2]}, r"^controller\.K_b: expected 3 numbers >= 0 .*got 2 numbers$"),
    ({"bandwidth_hz": 0}, r"^controller\.bandwidth_hz: expected a number > 0, got 0$"),
    ({"damping_ratio": "1"}, r"^controller\.damping_ratio: expected a number > 0, got '1'$"),
    ({"K_a": True}, r"^controller\.K_a: expected 6 numbers"),
    ({"force_feedforward": 1}, r"^controller\.force_feedforward: expected true or false, got 1$"),
    ({"stiffness": 1}, r"^controller\.stiffness: unknown field; expected one of bandwidth_hz, damping_ratio, K_a"),
    ([1, 2], r"^controller: expected a mapping of gains, got list$"),
])
def test_mapping_errors_name_field_and_shape(ur5_mounted: MobileManipulator, mapping: object, message: str) -> None:
    with pytest.raises(InvalidInputError, match=message):
        gains_from_mapping(mapping, ur5_mounted)  # type: ignore[arg-type]
