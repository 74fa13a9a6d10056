"""``path.keep_level`` (issue 38, item 1): a tool axis kept near a world axis along the whole plan
(NLP rows at the waypoints, the verdict on the executed spline), and orientations on the timed
waypoints of a Cartesian path (slerp between them)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin
import pytest
import yaml

from forte.cli.main import main
from forte.exceptions import TaskFileError
from forte.model.robot import default_robot
from forte.planning.nlp.keep_level_rows import keep_steps, level_cosines
from forte.planning.nlp.optimizer import TrajectoryOptimizer
from forte.planning.planner import plan
from forte.planning.tasks.keep_level import KeepLevel, axis_vector, tilt_angles
from forte.planning.tasks.tasks import task_from_dict
from forte.planning.verdict.motion_samples import sample_motion
from forte.planning.verdict.verdict import judge_plan

ROOT = Path(__file__).resolve().parents[1]
PANDA = {"urdf": "erd:panda_description/urdf/panda.urdf", "ee_frame": "panda_hand", "base": "fixed"}
#: The Panda's home and a goal both with the hand within 5 deg of pointing down, whose free path
#: (the NLP's without keep_level) tilts the hand by about 33 deg on the way.
GOAL = [0.0, 0.0, 0.0, -0.96, 1.064, -2.173, -1.952, 0.862, 1.229, 1.999]
#: The Panda's hand points down (its z along world -z): upright is world -z.
LEVEL = {"axis": "-z", "max_tilt_deg": 10}


def goal_task(keep: dict[str, Any] | None, **path: Any) -> Any:
    spec = {"kind": "goal", "configuration": GOAL, "samples": 20, **path}
    if keep is not None:
        spec["keep_level"] = keep
    return task_from_dict({"robot": PANDA, "path": spec})


def spline_tilt(task: Any, keep: KeepLevel, t: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The exact tilt (deg) on the executed spline (the verdict's dense samples) and its times."""
    samples = sample_motion(task.robot, t, q)
    return np.degrees(tilt_angles(keep, samples.ee[:, :3, :3])), samples.t


def test_the_row_is_the_cosine_of_the_exact_tilt():
    """``h(q) = w . R(q) a`` on the CasADi twin against the angle of Pinocchio's rotation, on random
    whole-body configurations (base yaw included), for several axis pairs."""
    robot = default_robot()
    rng = np.random.default_rng(3)
    q = np.column_stack([rng.uniform(-1, 1, (25, 2)), rng.uniform(-np.pi, np.pi, 25),
                         rng.uniform(robot.lower, robot.upper, (25, robot.n_arm))])
    for world, tool in (("z", "z"), ("-z", "z"), ("x", "-y"), ("y", "x")):
        keep = KeepLevel(axis_vector(world), axis_vector(tool), np.radians(10), world, tool)
        h = level_cosines(robot, keep, q)
        R = np.array([robot.ee_pose(qk)[:3, :3] for qk in q])
        exact = np.array([np.arccos(np.clip(axis_vector(world) @ Rk @ axis_vector(tool), -1, 1)) for Rk in R])
        np.testing.assert_allclose(np.arccos(np.clip(h, -1, 1)), exact, atol=1e-7)
        np.testing.assert_allclose(tilt_angles(keep, R), exact, atol=1e-12)
        # the row's bound and the angle's limit say the same thing, for every limit
        for limit in np.radians([5, 30, 90, 150]):
            np.testing.assert_array_equal(h >= np.cos(limit), exact <= limit)


def test_the_rows_derivatives_match_finite_differences():
    """The assembled Jacobian and Lagrangian Hessian of the keep_level rows (the NLP's last rows)
    against central differences of the Pinocchio cosine."""
    task = goal_task(LEVEL, samples=8)
    opt = TrajectoryOptimizer(task.robot, task.n, goal="configuration", keep_level=task.keep_level)
    steps = opt._keep_steps
    assert steps.tolist() == keep_steps(8, 1, np.array([], int), True, "configuration").tolist() == [1, 2, 3, 4]
    lbx, ubx, lbg, ubg = opt.bounds(task.t, task.q_init, q_goal=task.goal.q_end)
    assert np.all(lbg[-4:] == np.cos(np.radians(10))) and np.all(np.isinf(ubg[-4:]))
    rng = np.random.default_rng(0)
    q = task.goal.motion(task.q_init, task.t) + rng.normal(0, 0.05, (task.n, task.robot.nq))
    x = opt.full_x(q)
    p = opt.parameters(task.t, task.targets, np.zeros((task.n, 3)), np.zeros(task.n))
    g, jac = (np.array(v) for v in opt._nlp_options["jac_g"](x, p))
    keep = task.keep_level
    cos = lambda qk: float(axis_vector("-z") @ task.robot.ee_pose(qk)[:3, :3] @ axis_vector("z"))  # noqa: E731
    np.testing.assert_allclose(g.ravel()[-4:], [cos(q[k]) for k in steps], atol=1e-12)
    assert keep.min_cosine == pytest.approx(np.cos(np.radians(10)))
    nq, eps = task.robot.nq, 1e-6
    for row, k in enumerate(steps):
        fd = np.array([(cos(q[k] + eps * e) - cos(q[k] - eps * e)) / (2 * eps) for e in np.eye(nq)])
        dense = jac[-4 + row].ravel()
        np.testing.assert_allclose(dense[k * nq:(k + 1) * nq], fd, atol=1e-7)
        assert np.count_nonzero(np.delete(dense, np.arange(k * nq, (k + 1) * nq))) == 0
    lam = np.zeros(g.size)
    lam[-4 + 1] = 1.0  # the row of waypoint steps[1]
    H = np.array(opt._nlp_options["hess_lag"](x, p, 0.0, lam))
    k = int(steps[1])
    block = np.triu(H[k * nq:(k + 1) * nq, k * nq:(k + 1) * nq])
    fd = np.zeros((nq, nq))
    for i in range(nq):
        for j in range(nq):
            ei, ej = eps * 10 * np.eye(nq)[i], eps * 10 * np.eye(nq)[j]
            fd[i, j] = (cos(q[k] + ei + ej) - cos(q[k] + ei - ej) - cos(q[k] - ei + ej) + cos(q[k] - ei - ej)) / (
                4 * (eps * 10) ** 2)
    np.testing.assert_allclose(block, np.triu(fd), atol=1e-5)
    H[k * nq:(k + 1) * nq, k * nq:(k + 1) * nq] = 0.0
    assert np.count_nonzero(H) == 0


def test_keep_level_holds_on_the_executed_spline_where_the_free_path_tilts():
    """The same goal without and with ``keep_level``: the free path tilts the hand far beyond 10 deg,
    the constrained plan stays within it at every sample of the executed spline and is feasible;
    the verdict of the free plan against the limit names the worst tilt, its time and the limit."""
    keep = KeepLevel(axis_vector("-z"), axis_vector("z"), np.radians(10), "-z", "z")
    free_task, kept_task = goal_task(None), goal_task(LEVEL)
    assert free_task.keep_level is None and kept_task.keep_level.max_tilt == pytest.approx(np.radians(10))
    free, kept = plan(free_task), plan(kept_task)
    assert free.verdict.feasible, free.verdict.reason()
    free_tilt, times = spline_tilt(free_task, keep, free.t, free.q)
    assert free_tilt.max() > 20.0  # measured: 32.7 deg
    assert kept.verdict.feasible, kept.verdict.reason()
    kept_tilt, _ = spline_tilt(kept_task, keep, kept.t, kept.q)
    assert kept_tilt.max() <= 10.0 + 1e-4
    np.testing.assert_allclose(kept.q[-1], GOAL, atol=1e-9)
    # the free plan judged against the limit: the violation names the worst tilt, its time, the limit
    judged = replace(free.task, keep_level=kept_task.keep_level)  # the free plan's own times and motion
    verdict = judge_plan(judged, free.q, judged.force())
    found = next(v for v in verdict.violations if v.requirement == "keep_level")
    worst = int(np.argmax(free_tilt))
    assert found.worst == pytest.approx(free_tilt[worst]) and found.units == "deg"
    assert found.limit == pytest.approx(10.0, abs=1e-3)
    assert f"worst {free_tilt[worst]:.4g} deg" in found.detail and f"at t = {times[worst]:.3g} s" in found.detail
    assert "(limit 10)" in found.detail and "-z" in found.detail


def _cli(tmp_path: Path, capsys: Any, task: dict[str, Any]) -> tuple[int, str]:
    path = tmp_path / "task.yaml"
    path.write_text(yaml.safe_dump(task))
    code = main(["plan", str(path), "--no-figures", "--quiet", "--out", str(tmp_path / "out")])
    return code, capsys.readouterr().err


@pytest.mark.parametrize("keep, message", [
    ({"axis": "-z", "max_tilt_deg": -5}, "path.keep_level.max_tilt_deg: expected an angle in degrees > 0 and < 180"),
    ({"axis": "-z", "max_tilt_deg": 180}, "path.keep_level.max_tilt_deg: expected an angle in degrees > 0 and < 180"),
    ({"axis": "-z", "max_tilt_deg": 0}, "path.keep_level.max_tilt_deg: expected an angle"),
    ({"axis": "up", "max_tilt_deg": 10}, "path.keep_level.axis: expected one of x, y, z, -x, -y, -z, got 'up'"),
    ({"axis": "z", "tool_axis": "w", "max_tilt_deg": 10}, "path.keep_level.tool_axis: expected one of"),
    ({"axis": "z"}, "path.keep_level.max_tilt_deg: required field is missing"),
    ({"axis": "z", "max_tilt_deg": "ten"}, "path.keep_level.max_tilt_deg: expected a finite number"),
    ({"axis": "z", "max_tilt": 10}, "path.keep_level.max_tilt: unknown field"),
    ({"axis": "z", "max_tilt_deg": 10}, "path.keep_level: the start (the end effector at initial_configuration) "
     "tilts 180 deg from world z (tool axis z); expected at most max_tilt_deg 10; a tool axis that points the "
     "other way is written with a sign (tool_axis: -z)"),
    ({"axis": "-z", "max_tilt_deg": 2}, "path.keep_level: the end effector at the goal configuration tilts 3.454 deg "
     "from world -z (tool axis z); expected at most max_tilt_deg 2"),
])
def test_bad_keep_level_exits_2_with_one_line(tmp_path, capsys, keep, message):
    task = {"robot": PANDA, "path": {"kind": "goal", "configuration": GOAL, "samples": 8, "keep_level": keep}}
    code, err = _cli(tmp_path, capsys, task)
    assert code == 2
    assert len(err.strip().splitlines()) == 1 and message in err, err
    with pytest.raises(TaskFileError, match=r"^<task>: path\.keep_level"):
        task_from_dict(task)


def test_a_goal_or_a_given_path_that_tilts_too_far_is_refused():
    """Orientations the task fixes (a goal, a given path's samples) are checked by the reader."""
    with pytest.raises(TaskFileError, match="the end effector at the goal configuration tilts"):
        goal_task({"axis": "-z", "max_tilt_deg": 3})  # the start is 0 deg, the goal 3.45 deg from down
    pose = {"position": [0.45, -0.3, 0.45], "orientation": {"rpy": [np.pi - 0.3, 0.0, 0.0]}}
    with pytest.raises(TaskFileError, match=r"path\.keep_level: the goal pose tilts 17\.19 deg"):
        task_from_dict({"robot": PANDA, "path": {"kind": "goal", "pose": pose, "keep_level": LEVEL}})
    turned = waypoint_task([None, {"rpy": [np.pi - 0.3, 0.0, 0.0]}], keep_level=LEVEL)
    with pytest.raises(TaskFileError, match=r"path\.keep_level: the given path at t = \S+ s tilts"):
        task_from_dict(turned)


# -- orientations on timed waypoints ---------------------------------------------------------------

def waypoint_task(orientations: list[Any], **path: Any) -> dict[str, Any]:
    """A Panda waypoint path (relative positions) with ``orientations`` on its waypoints (None: none)."""
    points = [{"t": 0.0, "position": [0, 0, 0]}, {"t": 2.0, "position": [0.05, 0.05, 0]},
              {"t": 3.0, "position": [0.05, 0.05, -0.05]}][:len(orientations)]
    for point, orientation in zip(points, orientations, strict=True):
        if orientation is not None:
            point["orientation"] = orientation
    return {"robot": PANDA, "path": {"relative": True, "samples": 16, "waypoints": points, **path}}


def test_waypoint_orientations_are_met_at_the_waypoints_and_slerped_between():
    """The targets' rotations at the waypoint times are the given ones (rpy or quaternion, read as the
    goal pose's); between them the turn is about one axis, monotone, at rest at the waypoints."""
    R0 = panda_start_rotation()
    turn = pin.rpy.rpyToMatrix(0.0, 0.0, np.radians(45))  # 45 deg about the vertical
    R1 = turn @ R0
    quat = pin.Quaternion(R1)
    for given in ({"rpy": pin.rpy.matrixToRpy(R1).tolist()}, {"quaternion": [quat.x, quat.y, quat.z, quat.w]}):
        task = task_from_dict(waypoint_task([None, given, None]), waypoints=None)
        at = task.targets_at(np.array([0.0, 2.0, 3.0]))
        np.testing.assert_allclose(at[0, :3, :3], R0, atol=1e-9)
        np.testing.assert_allclose(at[1, :3, :3], R1, atol=1e-9)
        np.testing.assert_allclose(at[2, :3, :3], R1, atol=1e-9)  # no orientation: the waypoint before's held
    ts = np.linspace(0.0, 2.0, 41)
    R = task.targets_at(ts)[:, :3, :3]
    angles = np.array([np.linalg.norm(pin.log3(R0.T @ Rk)) for Rk in R])
    axes = np.array([pin.log3(R0.T @ Rk) / max(a, 1e-12) for Rk, a in zip(R, angles, strict=True)])
    assert np.all(np.diff(angles) >= -1e-12) and angles[-1] == pytest.approx(np.radians(45))
    np.testing.assert_allclose(axes[5:], np.tile(axes[-1], (len(axes) - 5, 1)), atol=1e-9)  # one axis
    assert angles[1] < 1e-3 * angles[-1]  # at rest at the waypoint (the quintic blend)


def panda_start_rotation() -> np.ndarray:
    task = task_from_dict(waypoint_task([None, None]))
    return task.robot.ee_pose(task.q_init)[:3, :3]


def test_without_orientations_the_path_holds_the_start_orientation():
    task = task_from_dict(waypoint_task([None, None, None]))
    R0 = task.robot.ee_pose(task.q_init)[:3, :3]
    np.testing.assert_allclose(task.targets[:, :3, :3], np.tile(R0, (task.n, 1, 1)), atol=1e-12)


def test_a_plan_that_turns_the_hand_45_degrees_is_feasible():
    R0 = panda_start_rotation()
    R1 = pin.rpy.rpyToMatrix(0.0, 0.0, np.radians(45)) @ R0
    spec = waypoint_task([None, {"rpy": pin.rpy.matrixToRpy(R1).tolist()}, None], keep_level=LEVEL)
    task = task_from_dict(spec)
    result = plan(task)
    assert result.verdict.feasible, result.verdict.reason()
    ends = np.array([task.robot.ee_pose(q) for q in result.q])
    turned = np.linalg.norm(pin.log3(R0.T @ ends[-1, :3, :3]))
    assert turned == pytest.approx(np.radians(45), abs=0.05)


def test_a_bad_waypoint_orientation_exits_2_with_one_line(tmp_path, capsys):
    spec = waypoint_task([None, {"quaternion": [1, 1, 0, 0]}])
    code, err = _cli(tmp_path, capsys, spec)
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert "path.waypoints[1].orientation.quaternion: expected a unit quaternion" in err, err
    code, err = _cli(tmp_path, capsys, waypoint_task([{"rpy": [0.0, 0.0, 0.0]}, None]))
    assert code == 2 and "path.waypoints[0].orientation: differs by" in err, err


def test_a_failed_solve_names_the_tilt_it_could_not_keep():
    """The failure diagnosis of a last iterate that tilts: the waypoint with the largest excess over
    max_tilt (deg), from the rows, against the exact tilt of Pinocchio's rotation there."""
    from types import SimpleNamespace

    from forte.planning.scene.diagnosis import failed_rows

    free_task, kept_task = goal_task(None), goal_task(LEVEL)
    q = free_task.goal.motion(free_task.q_init, free_task.t)  # the straight line: it tilts on the way
    opt = TrajectoryOptimizer(kept_task.robot, kept_task.n, goal="configuration", keep_level=kept_task.keep_level)
    failed = failed_rows(opt, SimpleNamespace(q=q), kept_task, kept_task.force())
    tilt = np.degrees(tilt_angles(kept_task.keep_level, np.array([kept_task.robot.ee_pose(qk)[:3, :3] for qk in q])))
    k = int(np.argmax(np.where(np.isin(np.arange(len(q)), opt._keep_steps), tilt, -np.inf)))
    assert tilt[k] > 10.0
    assert failed.kind == "keep_level" and failed.waypoint == k
    assert failed.short == pytest.approx(tilt[k] - 10.0, abs=1e-6)
    assert failed.sentence().startswith(f"tilted: the end effector {tilt[k] - 10.0:.3g} deg beyond keep_level's")


def test_around_a_wall_the_hand_stays_level_with_the_clearance_rows():
    """examples/tasks/around-the-wall.yaml (the route found by the search, the wall's clearance rows)
    with ``keep_level``: the free plan tilts the hand far beyond 12 deg on its way round; the kept one
    stays within on the executed spline, clear of the wall, feasible."""
    spec = yaml.safe_load((ROOT / "examples" / "tasks" / "around-the-wall.yaml").read_text())
    keep = KeepLevel(axis_vector("-z"), axis_vector("z"), np.radians(12), "-z", "z")
    free = plan(task_from_dict(spec))
    spec["path"]["keep_level"] = {"axis": "-z", "max_tilt_deg": 12}
    task = task_from_dict(spec)
    kept = plan(task)
    assert free.verdict.feasible and kept.verdict.feasible, (free.verdict.reason(), kept.verdict.reason())
    assert spline_tilt(task, keep, free.t, free.q)[0].max() > 30.0  # measured: 62.6 deg
    assert spline_tilt(task, keep, kept.t, kept.q)[0].max() <= 12.0 + 1e-4  # measured: 11.95 deg
    assert "keep_level" in kept.verdict.checked and kept.verdict.clearance["min_m"] >= task.clearance
