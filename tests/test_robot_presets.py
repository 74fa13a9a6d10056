"""Robot presets (a registry like the methods'): each plans a short path and runs it in MuJoCo; an
arm of another size gets the per-joint defaults derived from it; continuous joints are planned
within two turns; the self-collision pairs of a URDF without an SRDF leave out adjacent links."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import forte
from forte.exceptions import TaskFileError
from forte.model.presets import ROBOT_PRESETS, preset_robot
from forte.model.self_collision import ArmGeometry
from forte.model.urdf_loading import CONTINUOUS_RANGE
from forte.planning.tasks.tasks import task_from_dict


def _reach(preset: str, forward: float = 0.1, **extra) -> dict:
    return {"name": f"{preset}-reach", "robot": {"preset": preset},
            "path": {"kind": "waypoints", "relative": True, "samples": 41,
                     "waypoints": [{"t": 0.0, "position": [0.0, 0.0, 0.0]},
                                   {"t": 8.0, "position": [forward, 0.0, 0.05]}]},
            "payload": {"mass": 0.5}} | extra


def test_the_registry_lists_the_presets_and_refuses_an_unknown_one(tmp_path):
    assert {"authors", "moca-like", "ur5", "kinova", "tiago"} <= set(ROBOT_PRESETS)
    with pytest.raises(TaskFileError, match="robot.preset: expected one of authors, moca-like, ur5"):
        task_from_dict(_reach("abb-yumi"), tmp_path / "t.yaml")


@pytest.mark.slow
@pytest.mark.parametrize("preset", ["ur5", "kinova", "tiago"])
def test_each_preset_plans_feasibly_and_executes_in_mujoco(preset, tmp_path):
    from forte.execution.run import simulate_plan
    from forte.io.plandir import write_plan

    # TIAGo on its differential base drives 0.6 m: on a 0.1 m reach its base barely moves and the
    # executed spline (which does not know the wheels) slides 1.9 cm/s sideways between waypoints
    task = task_from_dict(_reach(preset, forward=0.6 if preset == "tiago" else 0.1), tmp_path / "task.yaml")
    plan = forte.plan(task)
    assert plan.feasible, plan.verdict
    directory = write_plan(plan, tmp_path / preset, figures=False)
    result = simulate_plan(directory, hold=0.3, write=False)
    assert result.success, result.detail
    assert result.summary["max_ee_error_m"] < 0.03  # the arm follows the plan (measured: 13, 1.5, 24 mm)


def test_an_arm_of_another_size_gets_its_own_defaults_and_a_wrong_list_names_the_field(tmp_path):
    task = task_from_dict(_reach("ur5"), tmp_path / "task.yaml")  # the weight set's lists are the Panda's
    assert task.robot.n_arm == 6
    from forte.planning.terms.capability_terms import JointLimits

    w = JointLimits.from_settings(task.settings).weights_for(task.robot.n_arm)
    dof = JointLimits.setting_values(task.settings)["dof_weights"]
    np.testing.assert_array_equal(w, np.r_[np.asarray(dof)[:3], np.ones(6)])
    assert task.robot.describe()["hand_link"] is None  # no Panda hand named for a UR5
    with pytest.raises(TaskFileError, match=r"weights.joint_dof_weights: expected 9 values \(x, y, yaw and the 6 arm "):
        task_from_dict(_reach("ur5", weights={"joint_dof_weights": [0, 0, 0, 1, 1, 1]}), tmp_path / "task.yaml")
    assert preset_robot("authors").describe()["hand_link"] == "panda_hand"  # the authors' hand mass names it


def test_continuous_joints_are_planned_within_two_turns():
    robot = preset_robot("kinova")
    text = Path(robot.urdf_path).read_text()
    continuous = [j for j in robot.arm_joints if f'name="{j}" type="continuous"' in text]
    assert continuous  # the Jaco's joints 1, 4 and 6
    for name in continuous:
        i = robot.arm_joints.index(name)
        assert robot.lower[i] == pytest.approx(-CONTINUOUS_RANGE) and robot.upper[i] == pytest.approx(CONTINUOUS_RANGE)
    q = robot.home()
    J = robot.whole_body_jacobian(q)
    assert J.shape == (6, robot.nq) and np.linalg.matrix_rank(J) == 6


@pytest.mark.parametrize("preset", ["ur5", "kinova", "tiago"])
def test_without_an_srdf_adjacent_links_are_never_a_pair(preset):
    """(A pair view held across removals pointed at shifted entries: some adjacent pairs stayed.)"""
    robot = preset_robot(preset)
    geometry = ArmGeometry(Path(robot.urdf_path), tuple(robot.arm_joints))
    objs, parents = geometry.geom.geometryObjects, geometry.model.parents
    for pair in geometry.geom.collisionPairs:
        a, b = objs[pair.first].parentJoint, objs[pair.second].parentJoint
        assert a != b and parents[a] != b and parents[b] != a, (objs[pair.first].name, objs[pair.second].name)
    assert geometry.contact(robot.home_arm) is None  # the home posture is free of self-collision


def test_per_joint_fields_by_joint_name(tmp_path):
    """``{joint: value}`` for the per-joint fields: in the robot's order, the rest at their default;
    a joint the robot lacks is named in the error; the task as written is recorded unchanged."""
    data = _reach("ur5", weights={"joint_dof_weights": {"shoulder_lift_joint": 2.0, "base_y": 0.5}},
                  limits={"arm_velocity": {"wrist_3_joint": 1.0}})
    task = task_from_dict(data, tmp_path / "task.yaml")
    np.testing.assert_array_equal(task.settings["joint_limits"]["dof_weights"], [0, 0.5, 0, 1, 2, 1, 1, 1, 1])
    np.testing.assert_array_equal(task.limits.arm_velocity, [*task.robot.model.velocityLimit[:5], 1.0])
    assert data["weights"]["joint_dof_weights"] == {"shoulder_lift_joint": 2.0, "base_y": 0.5}
    with pytest.raises(TaskFileError, match="weights.joint_dof_weights: no joint named 'panda_joint2'"):
        task_from_dict(_reach("ur5", weights={"joint_dof_weights": {"panda_joint2": 1.0}}), tmp_path / "t.yaml")


def _own_posture(centre: str | None = None) -> dict:
    """The Kinova preset from the user's own start posture, a 0.3 m reach to the side with 1 kg."""
    task = {"name": "kinova-own-posture", "robot": {"preset": "kinova"},
            "initial_configuration": [0, 0, 0, 0.0, 3.6, 1.2, 0.0, 1.5, 0.0],
            "path": {"kind": "waypoints", "relative": True, "samples": 31,
                     "waypoints": [{"t": 0.0, "position": [0.0, 0.0, 0.0]}, {"t": 5.0, "position": [0.0, 0.3, 0.0]}]},
            "payload": {"mass": 1.0}}
    return task | ({"terms": {"joint_limits": {"centre": centre}}} if centre else {})


@pytest.mark.slow
def test_a_preset_plans_from_the_users_own_start_posture(tmp_path):
    """J3's quadratic centres on the task's nominal (its own posture) where the weight set's list is
    the Panda's, not the Kinova's: from [0, 3.6, 1.2, 0, 1.5, 0] joint 3 stays near its start; pulled to the middle
    of its range (3.14 rad, the elbow straight) the plan swings it there from the first step and,
    without the executed spline's rows (``limits.on_spline: false``, as the failure was reported),
    breaks the velocity limit at any duration; with them (the default) it keeps the limit and swings."""
    from forte.planning.terms.capability_terms import JointLimits

    task = task_from_dict(_own_posture(), tmp_path / "task.yaml")
    assert JointLimits.from_settings(task.settings).centre_for(task.robot.n_arm) == "nominal"
    plan = forte.plan(task)
    assert plan.feasible, plan.verdict
    assert np.max(np.abs(plan.q[:, 5] - 1.2)) < 0.5  # joint 3 (index 3 + 2) near its start (measured: 0.22)
    # without the refinement rounds and the spline's rows (either bounds the executed velocity)
    unbounded = {"solver": {"refine_rounds": 0}, "limits": {"on_spline": False}}
    ranged = forte.plan(task_from_dict(_own_posture("range") | unbounded, tmp_path / "task.yaml"))
    assert "velocity" in ranged.verdict.failed
    assert np.max(ranged.q[:, 5]) > 2.0  # towards the range's middle, (0.33 + 5.95) / 2 = 3.14 rad (measured: 2.20)
    kept = forte.plan(task_from_dict(_own_posture("range") | {"solver": {"refine_rounds": 0}}, tmp_path / "task.yaml"))
    assert "velocity" not in kept.verdict.failed and np.max(kept.q[:, 5]) > 2.0  # (measured: feasible, 2.19)
