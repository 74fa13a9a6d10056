"""The IK's step metric (:func:`forte.planning.tasks.ik.step_weights`): a prismatic joint's metres
count as the fraction of its range they use, so a lift does not take a reach the arm can make."""

from __future__ import annotations

import importlib.util
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from forte.model.robot import N_BASE
from forte.model.self_collision import arm_geometry
from forte.planning.tasks.ik import IKOptions, pose_error, solve_pose, step_weights
from forte.planning.tasks.tasks import task_from_dict

ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location("feasibility_matrix", ROOT / "benchmarks" / "feasibility_matrix.py")
fm = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(fm)


def _task(robot: str, kind: str, size: float, tmp_path: Path):
    return task_from_dict(fm.task_dict(fm.Cell(robot, fm.Reach(kind, size, fm.SIZES[size]), 0.0, 21)),
                          tmp_path / "task.yaml")


def _urdf_ranges(urdf: Path, joints: list[str]) -> dict[str, tuple[str, float]]:
    """Each joint's type and ``upper - lower`` read from the URDF's XML (not through Pinocchio)."""
    out = {}
    for joint in ET.parse(urdf).getroot().findall("joint"):  # not the transmissions' joints
        if joint.get("name") in joints:
            limit = joint.find("limit")
            out[joint.get("name")] = (joint.get("type"), float(limit.get("upper")) - float(limit.get("lower")))
    return out


def test_a_prismatic_joint_is_weighted_by_its_range_over_the_revolute_joints_mean(tmp_path):
    robot = _task("tiago", "down", 0.1, tmp_path).robot
    ranges = _urdf_ranges(robot.urdf_path, list(robot.arm_joints))
    assert ranges["torso_lift_joint"][0] == "prismatic"
    revolute = [span for kind, span in ranges.values() if kind == "revolute"]
    assert len(revolute) == 7
    expected = (ranges["torso_lift_joint"][1] / np.mean(revolute)) ** 2  # 0.35 m of a 3.50 rad mean: 0.01
    w = step_weights(robot, 10.0)
    assert w[N_BASE] == pytest.approx(expected, rel=1e-9) and expected == pytest.approx(0.01, abs=1e-3)
    np.testing.assert_array_equal(w[:N_BASE], 0.1)
    np.testing.assert_array_equal(w[N_BASE + 1:], 1.0)
    panda = _task("authors", "down", 0.1, tmp_path).robot  # no prismatic joint: the step as before
    np.testing.assert_array_equal(step_weights(panda, 10.0), np.r_[np.full(N_BASE, 0.1), np.ones(panda.n_arm)])


def test_one_step_is_the_weighted_minimum_norm_step(tmp_path):
    """Undamped and away from the limits, one step solves ``min dq^T W dq`` s.t. ``J dq = e``: the
    same step from the KKT system ``[[W, J^T], [J, 0]] [dq; mu] = [0; e]``."""
    task = _task("tiago", "down", 0.1, tmp_path)
    robot, q0 = task.robot, np.asarray(task.q_init, dtype=float)
    target = robot.ee_pose(q0).copy()
    target[2, 3] -= 0.005
    q1, _ = solve_pose(robot, target, q0, IKOptions(damping=1e-9, max_iterations=1))
    J, e = robot.whole_body_jacobian(q0), pose_error(robot, q0, target)
    W = np.diag(1.0 / step_weights(robot, 10.0))
    n = q0.size
    kkt = np.block([[W, J.T], [J, np.zeros((6, 6))]])
    dq = np.linalg.solve(kkt, np.r_[np.zeros(n), e])[:n]
    np.testing.assert_allclose(q1 - q0, dq, atol=1e-9)


def test_the_tiago_reference_lowers_the_hand_with_its_arm_clear_of_the_column(tmp_path):
    """The preset TIAGo reaching 0.3 m down: the reference (IK) posture keeps the torso within 4 cm
    of its start (unweighted it dropped 0.2 m, to its limit) and its meshes apart at every sample
    (unweighted, arm_1_link met the column's box at 13 of 21)."""
    task = _task("tiago", "down", 0.3, tmp_path)
    nominal = task.nominal()
    torso = nominal[:, N_BASE]
    assert torso[0] == pytest.approx(0.2) and torso.min() > 0.16
    geometry = arm_geometry(task.robot)
    assert [k for k, q in enumerate(nominal) if geometry.contact(q[N_BASE:]) is not None] == []
    drop = task.robot.ee_pose(nominal[0])[2, 3] - task.robot.ee_pose(nominal[-1])[2, 3]
    assert drop == pytest.approx(0.3, abs=1e-4)  # the reach is made, by the arm


def test_the_issue_start_cannot_reach_down_clear_of_the_column(tmp_path):
    """Why the raw TIAGo's 0.1 m down reach from the issue's start stays infeasible: below a torso
    lift of ~0.115 m its URDF's arm_1_link meets the column's box at any arm_1 angle, and the IK
    reaches the pose 0.1 m down (orientation held) with the torso lower, the wrist joint arm_6 (0.044
    rad from its upper limit at the start) on that limit, the arm unable to take more of the reach."""
    task = _task("tiago-urdf", "down", 0.1, tmp_path)
    robot, geometry = task.robot, arm_geometry(task.robot)
    arm = np.asarray(task.q_init[N_BASE:], dtype=float)
    for angle in np.linspace(robot.lower[1], robot.upper[1], 12):
        assert geometry.contact(np.r_[0.11, angle, arm[2:]]) is not None
    end = task.nominal()[-1]
    assert np.linalg.norm(pose_error(robot, end, task.targets[-1])[:3]) < 1e-4
    assert end[N_BASE] < 0.11 and end[N_BASE + 6] == pytest.approx(robot.upper[6], abs=1e-5)
    assert geometry.contact(end[N_BASE:]) is not None
