"""Robot model: default MOCA-like robot, a second URDF arm, world-frame kinematics, errors."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from conftest import random_configuration

from forte.exceptions import InvalidInputError, RobotModelError
from forte.model.robot import (
    PAPER_TORQUE_LIMITS,
    MobileManipulator,
    ToolLoad,
    default_robot,
    robot_from_description,
)


def test_default_robot_is_a_mobile_panda(robot):
    assert robot.n_arm == 7 and robot.nq == 10
    assert robot.arm_joints == tuple(f"panda_joint{i}" for i in range(1, 8))
    np.testing.assert_array_equal(robot.torque_limits, PAPER_TORQUE_LIMITS)
    # The arm sits on the mount: at the home pose the hand is above the mount height.
    assert robot.ee_position(robot.home())[2] > robot.mount[2, 3]


def test_torque_limits_can_be_overridden():
    r = default_robot(torque_limits=[87, 87, 87, 87, 12, 12, 12])
    assert r.torque_limits[0] == 87


def test_base_motion_moves_the_end_effector_rigidly(robot):
    q = robot.home()
    T0 = robot.ee_pose(q)
    q2 = q.copy()
    q2[:3] = [0.5, -0.3, 0.7]
    T1 = robot.ee_pose(q2)
    c, s = np.cos(0.7), np.sin(0.7)
    Rz = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    np.testing.assert_allclose(T1[:3, 3], Rz @ T0[:3, 3] + [0.5, -0.3, 0], atol=1e-12)
    np.testing.assert_allclose(T1[:3, :3], Rz @ T0[:3, :3], atol=1e-12)


@pytest.mark.parametrize("which", ["robot", "ur5"])
def test_whole_body_jacobian_matches_finite_differences(which, request):
    r = request.getfixturevalue(which)
    rng = np.random.default_rng(1)
    for _ in range(5):
        q = random_configuration(r, rng)
        J = r.whole_body_jacobian(q)
        T = r.ee_pose(q)
        h = 1e-6
        for i in range(r.nq):
            dq = np.zeros(r.nq)
            dq[i] = h
            T2 = r.ee_pose(q + dq)
            lin = (T2[:3, 3] - T[:3, 3]) / h
            ang = pin.log3(T2[:3, :3] @ T[:3, :3].T) / h
            np.testing.assert_allclose(J[:3, i], lin, atol=1e-5)
            np.testing.assert_allclose(J[3:, i], ang, atol=1e-5)
        np.testing.assert_allclose(r.arm_jacobian(q), J[:3, 3:], atol=1e-12)


def test_panda_joint7_column_vanishes_at_the_hand(robot):
    J = robot.arm_jacobian(robot.home())
    assert np.linalg.norm(J[:, 6]) < 1e-12


def test_tool_load_adds_its_gravity_torque():
    bare = default_robot(tool=None)
    tool = ToolLoad(mass=1.5, com=(0.01, 0.02, 0.05))
    loaded = default_robot(tool=tool)
    rng = np.random.default_rng(2)
    q = random_configuration(bare, rng)
    qa = q[3:]
    z = np.zeros(7)
    extra = loaded.rnea(qa, z, z) - bare.rnea(qa, z, z)
    # Independent check: J_c^T (m g e_z), with J_c the Jacobian of the tool's centre of mass
    # obtained by finite differences of its world position.
    def com(qa_):
        T = bare.ee_pose(np.concatenate([[0, 0, 0], qa_]))
        return T[:3, :3] @ np.array(tool.com) + T[:3, 3]
    h = 1e-7
    Jc = np.array([(com(qa + h * e) - com(qa)) / h for e in np.eye(7)]).T
    np.testing.assert_allclose(extra, Jc.T @ [0, 0, 1.5 * 9.81], atol=1e-5)


def test_a_second_urdf_arm_loads(ur5):
    assert ur5.n_arm == 6
    assert ur5.arm_joints[0] == "shoulder_pan_joint"
    np.testing.assert_array_equal(ur5.torque_limits, [150, 150, 150, 28, 28, 28])
    assert ur5.arm_jacobian(ur5.home()).shape == (3, 6)


def test_description_round_trip(robot):
    again = robot_from_description(robot.describe())
    q = robot.home() + 0.1
    np.testing.assert_allclose(again.ee_pose(q), robot.ee_pose(q), atol=1e-12)
    np.testing.assert_allclose(again.rnea(q[3:], q[3:], q[3:]), robot.rnea(q[3:], q[3:], q[3:]))
    assert again.fingerprint == robot.fingerprint


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"urdf": "/nonexistent/arm.urdf"}, "urdf: file /nonexistent/arm.urdf does not exist"),
        ({"ee_frame": "no_such_frame"}, "ee_frame: no frame 'no_such_frame'"),
        ({"arm_joints": ("panda_joint1", "bogus")}, "arm_joints: no joint 'bogus'"),
        ({"torque_limits": [1, 2, 3]}, "torque_limits: expected shape (7,)"),
        ({"torque_limits": [60, 60, 60, -1, 12, 12, 12]}, "torque_limits: expected every limit > 0"),
        ({"mount": np.ones((4, 4))}, "mount: expected a 4x4 rigid transform"),
    ],
)
def test_bad_robot_descriptions_name_the_field(kwargs, message):
    with pytest.raises((RobotModelError, InvalidInputError)) as err:
        default_robot(**kwargs)
    assert message in str(err.value)


@pytest.mark.parametrize(
    ("q", "message"),
    [
        (np.zeros(9), "q: expected shape (10,), got (9,)"),
        (np.r_[np.zeros(9), np.nan], "q[9]: expected a finite number"),
    ],
)
def test_bad_configurations(robot, q, message):
    with pytest.raises(InvalidInputError) as err:
        robot.ee_pose(q)
    assert message in str(err.value)


@pytest.mark.parametrize("mass", [-1.0, 0.0, float("nan")])
def test_bad_tool_mass(mass):
    with pytest.raises(InvalidInputError, match="tool.mass"):
        ToolLoad(mass=mass)


def test_unsupported_urdf_text(tmp_path):
    bad = tmp_path / "broken.urdf"
    bad.write_text("<robot name='x'><link name='a'/><joint></robot>")
    with pytest.raises(RobotModelError, match="urdf: cannot parse"):
        MobileManipulator(bad, "a")
