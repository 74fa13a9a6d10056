"""Goal tasks (issue 38, items 1 and 4): ``path: {kind: goal, configuration | pose}``, a free path
planned by the NLP from a straight-line guess, judged at the goal and with the force of its own
motion; an empty hand."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin
import pytest
import yaml

from forte.capability.metrics import capability_cost, capability_margin, normalization
from forte.cli.main import main
from forte.exceptions import InvalidInputError, TaskFileError
from forte.io.plandir import read_plan_dir
from forte.planning.nlp.optimizer import TrajectoryOptimizer
from forte.planning.planner import plan
from forte.planning.solve import goal_guess
from forte.planning.tasks.tasks import task_from_dict
from forte.planning.verdict.verdict import judge_plan
from forte.settings import SolverOptions

ROOT = Path(__file__).resolve().parents[1]
PANDA = {"urdf": "erd:panda_description/urdf/panda.urdf", "ee_frame": "panda_hand", "base": "fixed"}
#: The Panda's home posture (forte's default for it) and a goal 0.5-0.8 rad away at four joints.
START = [0.0, 0.0, 0.0, 0.0, -0.785398, 0.0, -2.356194, 0.0, 1.570796, 0.785398]
GOAL = [0.0, 0.0, 0.0, 0.5, -0.3, 0.0, -2.0, 0.0, 1.8, 0.785398]


def panda_task(path: dict[str, Any], **extra: Any) -> Any:
    return task_from_dict({"robot": PANDA, "path": {"samples": 12, **path}, **extra})


def test_a_configuration_goal_reads_its_fields_and_the_rule_duration():
    """The goal, the straight-line targets, the rule's duration (recorded as not given); the URDF's
    finger joints are not planned (nq = 3 + 7)."""
    task = panda_task({"kind": "goal", "configuration": GOAL}, payload={"mass": 1.5})
    assert task.robot.nq == 10 and task.goal.kind == "configuration" and not task.goal.duration_given
    np.testing.assert_allclose(task.goal.configuration, GOAL)
    assert task.n == 12 and task.t[-1] >= 1.0
    np.testing.assert_allclose(task.targets[-1], task.robot.ee_pose(np.array(GOAL)), atol=1e-12)
    guess = goal_guess(task)
    np.testing.assert_allclose(guess[0], START, atol=1e-6)
    np.testing.assert_allclose(guess[-3:], np.tile(GOAL, (3, 1)), atol=1e-12)  # rests over the last two samples
    # a straight line: every sample on the segment from the start to the goal
    q0 = task.q_init
    s = (guess[:, 3] - q0[3]) / (GOAL[3] - q0[3])
    assert np.all(np.diff(s) >= 0) and s[0] == 0 and s[-1] == 1
    np.testing.assert_allclose(guess, q0 + s[:, None] * (np.array(GOAL) - q0), atol=1e-12)
    given = panda_task({"kind": "goal", "configuration": GOAL, "duration": 2.5}, payload={"mass": 1.5})
    assert given.goal.duration_given and given.t[-1] == 2.5


def test_a_goal_task_stops_its_nlp_sooner_unless_the_file_says():
    from forte.planning.tasks.goals import GOAL_MAX_ITER

    assert panda_task({"kind": "goal", "configuration": GOAL}).solver.max_iter == GOAL_MAX_ITER < 500
    given = panda_task({"kind": "goal", "configuration": GOAL}, solver={"max_iter": 500})
    assert given.solver.max_iter == 500
    path = {"kind": "waypoints", "relative": True, "samples": 12,
            "waypoints": [{"t": 0.0, "position": [0.0, 0.0, 0.0]}, {"t": 2.0, "position": [0.1, 0.0, 0.0]}]}
    assert task_from_dict({"robot": PANDA, "path": path, "payload": {"mass": 1.0}}).solver.max_iter == 500


def test_the_nlp_poses_only_the_goal():
    """A pose goal has one pose equality (the last waypoint), a configuration goal none (the last
    configuration bounded to the goal)."""
    task = panda_task({"kind": "goal", "configuration": GOAL})
    pose = TrajectoryOptimizer(task.robot, task.n, goal="pose")
    assert pose._pose_steps.tolist() == [task.n - 1]
    conf = TrajectoryOptimizer(task.robot, task.n, goal="configuration")
    assert conf._pose_steps.size == 0
    lbx, ubx, _, _ = conf.bounds(task.t, task.q_init, q_goal=np.array(GOAL))
    last = slice((task.n - 1) * 10, task.n * 10)
    np.testing.assert_array_equal(lbx[last], GOAL)
    np.testing.assert_array_equal(ubx[last], GOAL)
    path = TrajectoryOptimizer(task.robot, task.n)
    assert path._pose_steps.size == task.n - 1 - 2  # a path: every waypoint but the first and the held ones


def test_a_configuration_goal_plans_feasible_and_ends_at_the_goal():
    task = panda_task({"kind": "goal", "configuration": GOAL}, payload={"mass": 1.5})
    result = plan(task)
    assert result.verdict.feasible, result.verdict.reason()
    np.testing.assert_allclose(result.q[-1], GOAL, atol=1e-9)
    np.testing.assert_allclose(result.q[0], task.q_init, atol=1e-9)
    # the duration forte chose: toppra's along the route, with its margin (the plan's own time span)
    assert result.solver["goal"] == {"kind": "configuration", "duration_s": float(result.t[-1]),
                                     "duration_given": False}
    assert result.t[-1] >= result.solver["search"]["toppra_duration_s"] > 0


def test_a_pose_goal_ends_within_its_tolerance():
    target = np.array([0.45, -0.25, 0.45])
    # a quaternion [x, y, z, w]: the hand pointing down, turned 0.3 rad about the vertical
    R = pin.rpy.rpyToMatrix(np.pi, 0.0, 0.3)
    q = pin.Quaternion(R)
    task = panda_task({"kind": "goal", "pose": {"position": target.tolist(),
                                                "orientation": {"quaternion": [q.x, q.y, q.z, q.w]}},
                       "tolerance": {"position": 0.005, "angle": 0.02}})
    np.testing.assert_allclose(task.goal.pose[:3, :3], R, atol=1e-9)
    result = plan(task)
    assert result.verdict.feasible, result.verdict.reason()
    end = task.robot.ee_pose(result.q[-1])
    assert np.linalg.norm(end[:3, 3] - target) <= 0.005
    assert np.linalg.norm(pin.log3(R.T @ end[:3, :3])) <= 0.02


def test_tracking_fails_naming_the_joint_or_the_goal_when_a_plan_misses_it():
    task = panda_task({"kind": "goal", "configuration": GOAL}, payload={"mass": 0.5})
    q = goal_guess(task)
    assert "tracking" not in judge_plan(task, q, task.force()).failed
    missed = q.copy()
    missed[-3:, 6] += 1e-3  # panda_joint4, the arm's 4th joint
    verdict = judge_plan(task, missed, task.force())
    found = next(v for v in verdict.violations if v.requirement == "tracking")
    assert "goal configuration" in found.detail and "(panda_joint4)" in found.detail
    assert found.waypoints == (task.n - 1,) and found.worst == pytest.approx(1e-3)
    pose_task = panda_task({"kind": "goal", "pose": {"position": task.targets[-1][:3, 3].tolist()},
                            "tolerance": {"position": 0.002}}, payload={"mass": 0.5})
    q = goal_guess(pose_task)
    assert "tracking" not in judge_plan(pose_task, q, pose_task.force()).failed
    missed = q.copy()
    missed[-3:, 3] += 0.02  # the hand swings about panda_joint1 by ~1 cm
    found = next(v for v in judge_plan(pose_task, missed, pose_task.force()).violations
                 if v.requirement == "tracking")
    assert "goal position" in found.detail and found.limit == 0.002 and found.worst > 0.002


def test_an_empty_hand_plans_with_the_tool_load_only():
    """No payload section: mass 0, radius 0, the built-in robot's tool load (1.146 kg) as the force."""
    task = task_from_dict({"path": {"kind": "goal", "samples": 12, "duration": 2.0,
                                    "pose": {"position": [0.85, 0.1, 0.9], "orientation": {"rpy": [np.pi, 0, 0]}}}})
    assert task.payload.mass == 0.0 and task.radius == 0.0
    force = task.force()
    assert np.all(force.r == 0.0)
    np.testing.assert_allclose(force.f[0], [0, 0, task.robot.tool_force_mass * task.robot.gravity])
    result = plan(task)
    assert result.verdict.feasible, result.verdict.reason()


def test_an_empty_panda_hand_has_no_force_and_a_finite_capability():
    """``payload: {mass: 0}`` on the Panda (no tool load): f = 0, r = 0; the metric and J1 stay finite."""
    task = panda_task({"kind": "goal", "configuration": GOAL}, payload={"mass": 0})
    force = task.force()
    assert np.all(force.f == 0.0) and np.all(force.r == 0.0)
    result = plan(task)
    assert result.verdict.feasible, result.verdict.reason()
    d = result.metrics["d"]
    assert np.all(np.isfinite(d)) and np.all(d > 0)
    A = np.array([[1.0, 0, 0], [-1.0, 0, 0], [0, 0, 0]])  # a zero normal too
    b = np.array([2.0, 2.0, 1.0])
    assert capability_margin(A, b, np.zeros(3), 0.0) == pytest.approx(2.0)
    assert np.all(normalization(np.zeros((2, 3)), np.zeros(2)) > 0)
    outside = np.array([-1.0, 2.0, 1.0])  # d = -1: the penalty's exponent kappa (-d) / rho capped, not inf
    assert 0 < capability_cost(A[None], outside[None], np.zeros((1, 3)), np.zeros(1)) < np.inf


def _backward_force(task: Any, q: np.ndarray, mass: float, t: np.ndarray | None = None) -> np.ndarray:
    """``m (p'' - g)`` from the plan's forward kinematics at its times ``t`` (default the task's),
    second differences from rest (own code)."""
    p = np.array([task.robot.ee_pose(qk)[:3, 3] for qk in q])
    padded = np.vstack([p[:1], p[:1], p])
    t = task.t if t is None else t
    dt = t[1] - t[0]
    acc = (padded[2:] - 2 * padded[1:-1] + padded[:-2]) / dt**2
    acc[0] = 0.0
    return mass * (acc - np.array([0.0, 0.0, -task.robot.gravity]))


def test_a_goal_task_is_judged_with_the_force_of_its_own_motion():
    task = panda_task({"kind": "goal", "configuration": GOAL}, payload={"mass": 1.5})
    result = plan(task)
    own = _backward_force(result.task, result.q, 1.5)  # on the plan's own times (forte chose its duration)
    np.testing.assert_allclose(result.force.f, own, atol=1e-6)
    guess = _backward_force(result.task, goal_guess(result.task), 1.5)
    assert np.max(np.abs(own - guess)) > 0.05  # the plan's motion is not the guess's
    np.testing.assert_allclose(result.force.f, result.task.force().f, atol=1e-12)
    again = judge_plan(result.task, result.q, result.force, result.solver)
    assert again.label == result.verdict.label and again.failed == result.verdict.failed


def _cli(tmp_path: Path, capsys: Any, doc: dict[str, Any], *args: str) -> tuple[int, str]:
    path = tmp_path / "goal.yaml"
    path.write_text(yaml.safe_dump(doc))
    code = main(["plan", str(path), "--no-figures", "--quiet", "--out", str(tmp_path / "out"), *args])
    return code, capsys.readouterr().err


@pytest.mark.parametrize(("path", "message"), [
    ({"kind": "goal", "configuration": START[3:]},
     "path.configuration: expected 10 numbers (base x, y, yaw, then the arm), got 7"),
    ({"kind": "goal", "configuration": [*START[:6], 3.5, *START[7:]]},
     "path.configuration[6]: joint panda_joint4 = 3.5 is outside its limits"),
    ({"kind": "goal", "configuration": [0.1, *START[1:]]}, "path.configuration: base entries"),
    ({"kind": "goal", "configuration": GOAL, "pose": {"position": [0.4, 0, 0.4]}},
     "path.configuration: give exactly one of configuration (whole-body) and pose"),
    ({"kind": "goal", "configuration": GOAL, "tolerance": {"position": 0.01}}, "path.tolerance: applies to a pose"),
    ({"kind": "goal", "configuration": GOAL, "orientation": {"rpy": [0, 0, 0]}}, "path.orientation: unknown field"),
    ({"kind": "goal", "pose": {"position": [3.0, 0, 0.4]}}, "path.pose: unreachable from the start"),
    ({"kind": "goal", "pose": {"position": [0.4, 0, 0.4], "orientation": {"quaternion": [1, 1, 0, 0]}}},
     "path.pose.orientation.quaternion: expected a unit quaternion"),
    ({"kind": "goal", "pose": {"position": [0.4, 0, 0.4]}, "tolerance": {"angle": -1}},
     "path.tolerance.angle: expected a number > 0"),
    ({"kind": "goal", "configuration": GOAL, "samples": 3}, "path.samples"),
])
def test_bad_goal_fields_exit_2_with_one_line(tmp_path, capsys, path, message):
    code, err = _cli(tmp_path, capsys, {"robot": PANDA, "path": path})
    assert code == 2
    assert len(err.strip().splitlines()) == 1 and message in err, err
    with pytest.raises(TaskFileError, match=message.replace("(", r"\(").replace(")", r"\)").replace("[", r"\[")):
        task_from_dict({"robot": PANDA, "path": path})


def test_the_example_plans_and_simulates_end_to_end(tmp_path, capsys):
    """``forte plan examples/tasks/goal.yaml`` then ``forte simulate`` of its folder."""
    out = tmp_path / "out"
    code = main(["plan", str(ROOT / "examples" / "tasks" / "goal.yaml"), "--no-figures", "--quiet", "--waypoints",
                 "16", "--out", str(out)])
    assert code == 0, capsys.readouterr().err
    doc = json.loads((out / "plan.json").read_text())
    assert doc["verdict"]["label"] == "feasible"
    assert doc["solver"]["goal"]["kind"] == "pose" and not doc["solver"]["goal"]["duration_given"]
    written = read_plan_dir(out)  # plan.json's force is the force of the written motion
    task = task_from_dict(yaml.safe_load((ROOT / "examples" / "tasks" / "goal.yaml").read_text()), waypoints=16)
    np.testing.assert_allclose(written.force.f, _backward_force(task, written.q, 1.0, written.t), atol=1e-6)
    assert main(["simulate", str(out), "--quiet"]) == 0, capsys.readouterr().err
    sim = json.loads((out / "sim.json").read_text())
    assert sim["verdict"] == "success" and sim["payload_mass"] == 1.0


def test_the_stagewise_solver_leaves_goal_tasks_to_ipopt():
    task = panda_task({"kind": "goal", "configuration": GOAL})
    opt = TrajectoryOptimizer(task.robot, task.n, goal="configuration", options=SolverOptions(backend="stagewise"))
    assert opt.stagewise() is None
    with pytest.raises(InvalidInputError, match="q_goal"):
        opt.solve(task.t, task.targets, np.zeros((task.n, 3)), np.zeros(task.n), task.q_init, goal_guess(task))


def test_a_plan_that_fails_with_its_own_force_is_solved_once_more_with_it():
    """3 kg on the built-in robot in 1.5 s: the plan made with the straight line's force fails a force
    requirement with its own motion's force; it is solved again with that force, and judged
    with the force of the new motion."""
    task = task_from_dict({"path": {"kind": "goal", "samples": 20, "duration": 1.5, "pose": {
        "position": [0.9, 0.3, 0.85], "orientation": {"rpy": [np.pi, 0, 0]}}}, "payload": {"mass": 3.0}})
    result = plan(task)
    own = result.solver["own_force"]  # the first plan failed a force requirement with its own force
    assert own["kept"] and own["verdict"] == result.verdict.label, result.verdict.reason()
    total = 3.0 + task.robot.tool_force_mass
    np.testing.assert_allclose(result.force.f, _backward_force(task, result.q, total, result.t), atol=1e-6)
