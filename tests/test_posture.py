"""Poor start postures (near a joint limit, near a singularity, in self-collision) are reported with
the nearest better posture of the same end-effector pose; a user's ``home_arm`` is the start
(issue 36, item 5)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml

import forte
from forte.cli.main import main
from forte.model.presets import ROBOT_PRESETS, preset_robot
from forte.model.robot import N_BASE
from forte.model.self_collision import arm_geometry
from forte.planning.tasks.ik import pose_error
from forte.planning.tasks.posture import LIMIT_FRACTION, SINGULAR_SIGMA, assess, sigma_min, start_posture

ROOT = Path(__file__).resolve().parents[1]
KINOVA_HOME = np.array([1.09, 3.67, 2.38, 3.33, 2.35, 1.49])


def _not_poor_independently(robot, q):
    """The criteria recomputed here: every joint 5 % of its range off its limits, the arm Jacobian's
    smallest singular value (numpy's SVD of the 6 x n block) above the threshold, no mesh contact."""
    q_a = q[N_BASE:]
    gap = np.minimum(q_a - robot.lower, robot.upper - q_a)
    J = robot.whole_body_jacobian(q)[:, N_BASE:]
    geometry = arm_geometry(robot)
    return (bool(np.all(gap >= LIMIT_FRACTION * (robot.upper - robot.lower)))
            and float(np.linalg.svd(J, compute_uv=False)[-1]) >= SINGULAR_SIGMA
            and (geometry is None or geometry.contact(q_a) is None))


@pytest.mark.parametrize("name", list(ROBOT_PRESETS))
def test_no_preset_home_is_poor(name):
    robot = preset_robot(name)
    report = assess(robot, robot.home())
    assert not report.poor, report.reasons
    assert _not_poor_independently(robot, robot.home())


def test_no_shipped_trajectory_example_starts_poor():
    for path in sorted((ROOT / "examples" / "tasks").glob("*.yaml")):
        task = forte.load_task(path)
        report = start_posture(task)
        assert report is None or not report.poor, (path.name, report.reasons)


@pytest.mark.parametrize("arm, why", [
    (np.r_[KINOVA_HOME[0], 0.85, KINOVA_HOME[2:]], "j2s6s200_joint_2"),  # 0.03 rad above its lower limit
    (np.r_[KINOVA_HOME[:2], np.pi, KINOVA_HOME[3:]], "singularity"),  # the elbow straight
])
def test_a_poor_kinova_start_gets_a_better_posture_with_the_same_pose(arm, why):
    robot = preset_robot("kinova")
    q = np.r_[0.0, 0.0, 0.0, arm]
    report = assess(robot, q)
    assert report.poor and any(why in r for r in report.reasons), report.reasons
    assert not _not_poor_independently(robot, q)
    better = np.asarray(report.better)
    err = pose_error(robot, better, robot.ee_pose(q))
    assert np.linalg.norm(err[:3]) < 1e-3 and np.linalg.norm(err[3:]) < 1e-3, err
    assert _not_poor_independently(robot, better)
    assert not assess(robot, better).poor
    assert report.better_sigma_min == pytest.approx(sigma_min(robot, better))
    assert "initial_configuration: [" in report.warning()


def _kinova_task(tmp_path, robot_fields, **extra):
    data = {"name": "reach", "mode": "trajectory", "robot": {"preset": "kinova", **robot_fields},
            "path": {"kind": "waypoints", "relative": True, "samples": 11, "waypoints": [
                {"t": 0.0, "position": [0.0, 0.0, 0.0]}, {"t": 5.0, "position": [0.1, 0.0, 0.05]}]},
            "payload": {"mass": 0.5}} | extra
    path = tmp_path / "reach.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


@pytest.mark.slow
def test_a_poor_start_is_a_warning_and_a_record_in_plan_json(tmp_path, capsys):
    start = [0.0, 0.0, 0.0, 1.09, 3.67, np.pi - 0.05, 3.33, 2.35, 1.49]  # nearly straight elbow
    path = _kinova_task(tmp_path, {}, initial_configuration=start)
    main(["plan", str(path), "--out", str(tmp_path / "out"), "--no-figures", "--allow-infeasible"])
    err = capsys.readouterr().err
    assert "forte: warning: the start posture is poor: near a singularity" in err, err
    record = json.loads((tmp_path / "out" / "plan.json").read_text())["start_posture"]
    assert record["poor"] and record["sigma_min"] < SINGULAR_SIGMA and len(record["better"]) == 9


@pytest.mark.slow
def test_a_user_s_home_arm_is_the_start_of_the_plan(tmp_path, capsys):
    home = [1.2, 3.5, 2.2, 3.3, 2.3, 1.4]  # not the preset's
    task = forte.load_task(_kinova_task(tmp_path, {"home_arm": home}))
    assert np.allclose(task.q_init[N_BASE:], home) and np.allclose(task.robot.home_arm, home)
    assert np.allclose(task.nominal()[0, N_BASE:], home)
    plan = forte.plan(task, "forte")
    assert np.allclose(plan.q[0, N_BASE:], home, atol=1e-9), plan.q[0]
    assert not np.allclose(home, preset_robot("kinova").home_arm)
    assert not start_posture(task).poor
