"""Goal tasks through clutter (issue 38): a route found around what is in the way, timed, kept clear
by the NLP, and executed in MuJoCo; a goal that cannot be reached says which stage failed."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import forte
from forte.model.clearance import clearances
from forte.planning.rounds import judged
from forte.planning.search.route import arriving
from forte.planning.search.validity import StateChecker, segment_free
from forte.planning.tasks.tasks import task_from_dict

WALL = Path("examples/tasks/around-the-wall.yaml")
PANDA = {"urdf": "erd:panda_description/urdf/panda.urdf", "ee_frame": "panda_hand", "base": "fixed"}


def test_arriving_rests_over_the_last_two_samples_and_keeps_the_motion():
    dense_t = np.linspace(0.0, 2.0, 201)
    dense_q = np.column_stack([dense_t ** 2, np.sin(dense_t)])
    t = np.linspace(0.0, 3.0, 11)
    q = arriving(t, dense_t, dense_q)
    assert np.allclose(q[0], dense_q[0]) and np.allclose(q[-3:], dense_q[-1])
    s = t[:-2] * 2.0 / t[-3]  # the motion's own time at each sample before the rest
    assert np.allclose(q[:-2, 1], np.sin(s), atol=1e-4)


@pytest.mark.slow
def test_a_goal_behind_a_wall_is_reached_around_it_and_executes(tmp_path):
    task = forte.load_task(WALL)
    checker = StateChecker(task.robot, task.scene, task.clearance)
    assert not segment_free(checker, task.q_init, task.goal.q_end)  # the straight motion hits the wall
    plan = forte.plan(task)
    assert plan.feasible, plan.verdict.reason()
    search = plan.solver["search"]
    assert search["searched"] and search["toppra_duration_s"] <= plan.t[-1]
    assert np.allclose(plan.q[-1], task.goal.q_end, atol=1e-6)
    # the exact clearance at the waypoints and between them (an independent dense check)
    dense = np.vstack([plan.q[:-1] + s * np.diff(plan.q, axis=0) for s in np.linspace(0, 1, 5)])
    assert clearances(task.robot, task.scene, dense).distance.min() >= task.clearance - 1e-3
    from forte.execution.run import simulate_plan
    from forte.io.plandir import write_plan

    write_plan(plan, tmp_path / "wall")
    result = simulate_plan(tmp_path / "wall")
    assert result.success, result.detail


def test_a_goal_inside_a_body_fails_at_the_search_and_says_so():
    task = task_from_dict({
        "robot": PANDA, "initial_configuration": [0, 0, 0, -1.0, 0.3, 0.0, -1.8, 0.0, 2.1, 0.785],
        "path": {"kind": "goal", "configuration": [0, 0, 0, 1.0, 0.3, 0.0, -1.8, 0.0, 2.1, 0.785]},
        "scene": [{"name": "crate", "box": {"size": [0.4, 0.4, 0.8]}, "pose": [0.3, 0.55, 0.4, 0, 0, 0]}]})
    plan = forte.plan(task)
    assert not plan.feasible
    assert plan.status.startswith("search: goal configuration in collision: ") and "crate" in plan.status


def test_a_route_is_the_plan_when_the_nlp_does_not_converge_and_the_verdict_passes_it():
    """The NLP stopped after 3 iterations (solver-failed): the searched route, timed by toppra, is
    judged as it is; feasible here, it is the plan, and the plan says it is the route."""
    from dataclasses import replace

    task = forte.load_task(WALL)
    plan = forte.plan(replace(task, solver=replace(task.solver, max_iter=3, refine_rounds=0)))
    fallback = plan.solver["fallback"]
    assert fallback["optimized"]["verdict"] == "solver-failed" and fallback["kept"]
    assert plan.feasible and plan.status.startswith("route: the optimized plan was solver-failed")
    assert np.array_equal(plan.q, plan.task.goal.route)
    dense = np.vstack([plan.q[:-1] + s * np.diff(plan.q, axis=0) for s in np.linspace(0, 1, 5)])
    assert clearances(task.robot, task.scene, dense).distance.min() >= task.clearance - 1e-3
    # asked for 0 m, the motion still keeps the executor's margin where its ends do: a plan that
    # comes within it mid-motion fails clearance, one whose closest approach is at an end does not
    from forte.planning.verdict.margin import execution_margin, kept_clearance

    EXECUTION_MARGIN = execution_margin("fixed")  # noqa: N806 (the wall task's Panda is bolted down)
    assert kept_clearance(0.0, np.array([0.05, 0.001, 0.04]), "fixed") == EXECUTION_MARGIN
    assert kept_clearance(0.0, np.array([0.05, 0.001, 0.0005]), "fixed") == 0.0005  # the goal is that close
    assert kept_clearance(0.02, np.array([0.05, 0.03, 0.04]), "fixed") == 0.02  # an asked clearance above it
    closest = plan.verdict.clearance["min_m"]
    ends = clearances(task.robot, task.scene, plan.q[[0, -1]]).distance.min()
    assert ends > closest + EXECUTION_MARGIN
    lifted = judged(replace(plan.task, clearance=0.0), plan.q, plan.force)[0]
    assert "clearance" not in lifted.failed  # closest 0.05 m: far beyond the margin
    # the wall moved towards the plan's closest point until 1 mm is left there
    summary = plan.verdict.clearance
    shift = (np.array(summary["witness_robot"]) - np.array(summary["witness_body"])) * (1 - 0.001 / closest)
    moved = [o._replace(pose=o.pose.copy()) for o in task.scene.objects]
    for o in moved:
        o.pose[:3, 3] += shift
    near_task = replace(plan.task, clearance=0.0, scene=task.scene._replace(objects=tuple(moved)))
    d = clearances(task.robot, near_task.scene, plan.q[[0, -1]]).distance
    near = judged(near_task, plan.q, plan.force)[0]
    assert 0 < near.clearance["min_m"] < EXECUTION_MARGIN and d.min() > EXECUTION_MARGIN
    assert near.failed == ("clearance",) and "raised to what execution needs on a fixed base" in near.reason()


def test_route_first_returns_a_route_the_verdict_passes_without_the_nlp():
    """``solver.route_first``: the searched route, timed by toppra, is judged before any NLP; the
    verdict passes it here, so it is the plan (no IPOPT iterations) and the plan says so."""
    from dataclasses import replace

    task = forte.load_task(WALL)
    plan = forte.plan(replace(task, solver=replace(task.solver, route_first=True)))
    assert plan.feasible and plan.solver["route_first"]["kept"] and "iterations" not in plan.solver
    assert plan.status.startswith("route: the searched route") and "solver.route_first" in plan.status
    assert np.array_equal(plan.q, plan.task.goal.route)
    assert plan.solver["search"]["searched"] and plan.solver["search"]["toppra_duration_s"] <= plan.t[-1]
    verdict, _ = judged(plan.task, plan.q, plan.force)  # judged again: the same verdict
    assert verdict.feasible and verdict.clearance["min_m"] >= 0.002


def test_route_first_is_read_from_the_task_file_and_checked():
    from forte.exceptions import TaskFileError

    base = {"robot": PANDA, "initial_configuration": [0, 0, 0, -1.0, 0.3, 0.0, -1.8, 0.0, 2.1, 0.785],
            "path": {"kind": "goal", "configuration": [0, 0, 0, -0.6, 0.3, 0.0, -1.8, 0.0, 2.1, 0.785]}}
    assert task_from_dict(base | {"solver": {"route_first": True}}).solver.route_first
    assert not task_from_dict(base).solver.route_first
    with pytest.raises(TaskFileError, match="solver.route_first"):
        task_from_dict(base | {"solver": {"route_first": "maybe"}})


def _post_at_the_elbow() -> tuple:
    """A Panda pose goal whose reader IK configuration puts the arm through a sphere at the elbow
    of the configuration that defined the pose."""
    import pinocchio as pin

    q_start = [0, 0, 0, 0, -0.785, 0, -2.356, 0, 1.571, 0.785]
    q_pose = np.array([0, 0, 0, 0.6, 0.2, 0.0, -1.9, 0.0, 2.1, 0.785])
    robot = task_from_dict({"robot": PANDA, "initial_configuration": q_start,
                            "path": {"kind": "goal", "configuration": q_pose.tolist()}}).robot
    data = robot.model.createData()
    pin.forwardKinematics(robot.model, data, q_pose[3:])
    elbow = data.oMi[robot.model.getJointId("panda_joint4")].translation
    T = robot.ee_pose(q_pose)
    task = task_from_dict({
        "robot": PANDA, "initial_configuration": q_start, "clearance": 0.0,
        "path": {"kind": "goal", "pose": {"position": T[:3, 3].tolist(),
                                          "orientation": {"matrix": T[:3, :3].tolist()}}},
        "scene": [{"name": "post", "sphere": {"radius": 0.04}, "pose": [*elbow.tolist(), 0, 0, 0]}]})
    return task, T


def test_a_pose_goal_whose_ik_configuration_collides_gets_a_clear_one():
    from forte.planning.search.goal_ik import free_goal
    from forte.planning.search.route import clear_goal
    from forte.planning.tasks.ik import pose_error

    task, T = _post_at_the_elbow()
    checker = StateChecker(task.robot, task.scene, 0.0)
    assert not checker.valid(task.goal.q_end)  # the reader's IK runs the arm through the post
    found = free_goal(task.robot, task.scene, 0.0, task.q_init, task.goal.q_end, task.goal.pose)
    assert found.q is not None and checker.valid(found.q) and found.tried >= 1
    assert np.linalg.norm(pose_error(task.robot, found.q, T)) < 1e-3  # the same hand pose
    assert "post" in found.reason and "replaces it" in found.reason
    assert free_goal(task.robot, task.scene, 0.0, task.q_init, found.q, task.goal.pose).tried == 0  # kept
    cleared, said = clear_goal(task)
    assert checker.valid(cleared.goal.q_end) and said == found.reason
    # a pose inside the post has no clear IK: the reason says so
    inside = np.eye(4)
    inside[:3, 3] = task.scene.objects[0].pose[:3, 3]
    none = free_goal(task.robot, task.scene, 0.0, task.q_init, task.goal.q_end, inside)
    assert none.q is None and "none of" in none.reason


def test_a_mobile_goal_task_starts_the_nlp_from_its_route():
    """The route was searched clear on the exact model: the ring search of prescribed paths
    (``clear_start``) must not move its base."""
    from forte.planning.search.route import routed
    from forte.planning.solve import start_guess

    task = task_from_dict({
        "robot": PANDA | {"base": "holonomic", "mount": {"xyz": [0.2575, 0.0, 0.52]}},
        "initial_configuration": [0, 0, 0, -1.0, 0.3, 0.0, -1.8, 0.0, 2.1, 0.785],
        "path": {"kind": "goal", "configuration": [0.3, 0.2, 0.4, 1.0, 0.3, 0.0, -1.8, 0.0, 2.1, 0.785]},
        "scene": [{"name": "crate", "box": {"size": [0.3, 0.3, 0.3]}, "pose": [0.75, 0.0, 0.75, 0, 0, 0]}]})
    task, facts = routed(task)
    assert task.goal.route is not None and facts["searched"] and "reason" not in facts
    from forte.planning.scene.scene_guess import clear_start

    moved = clear_start(task, task.goal.route)  # on the covers it would move the base (by 1.27 m)
    assert moved is None or np.abs(moved - task.goal.route).max() > 0.1
    assert np.array_equal(start_guess(task), task.goal.route)


def _corner_task(samples: int) -> tuple[object, np.ndarray]:
    """A Panda swinging joint 1, then joint 2 (an L in configuration space); a post sits where the
    straight motion between the ends passes, not near the L. The route's law: the L timed by toppra."""
    from dataclasses import replace

    from forte.planning.search.route import on_samples
    from forte.planning.search.timing import retime

    start = np.array([0.0, 0.0, 0.0, 0.0, -0.785398, 0.0, -2.356194, 0.0, 1.570796, 0.785398])
    corner, goal = start.copy(), start.copy()
    corner[3] += 1.4
    goal[[3, 4]] += [1.4, 0.9]
    plain = task_from_dict({"robot": PANDA, "initial_configuration": start.tolist(),
                            "path": {"kind": "goal", "configuration": goal.tolist()}})
    polyline = np.vstack([start, corner, goal])
    post = plain.robot.ee_pose(0.5 * (start + goal))[:3, 3]
    task = task_from_dict({"robot": PANDA, "initial_configuration": start.tolist(), "clearance": 0.0, "floor": "none",
                           "path": {"kind": "goal", "configuration": goal.tolist(), "samples": samples},
                           "scene": [{"name": "post", "box": {"size": [0.06, 0.06, 0.06]},
                                      "pose": [*post.tolist(), 0, 0, 0]}]})
    law = retime(task.robot, polyline, samples=400, limits=task.limits)
    t = np.linspace(0.0, 1.5 * law.duration, samples)
    return on_samples(replace(task, goal=replace(task.goal, law=(law.t, law.q))), t), polyline


def _parabola(polyline: np.ndarray) -> np.ndarray:
    """The not-a-knot cubic spline through three states in their arc length (one parabola per
    joint), at 200 points: what toppra fitted through the search's states alone."""
    from forte.planning.search.timing import path_parameter

    _, s = path_parameter(polyline)
    coef = np.polyfit(s, polyline, 2)
    return np.array([np.polyval(coef[:, j], np.linspace(0, s[-1], 200)) for j in range(polyline.shape[1])]).T


def test_the_timed_law_follows_the_searched_segments_around_a_corner():
    """toppra's spline through the corner's three states alone is one parabola per joint, 0.15 rad
    and more off the L; through states every KNOT_STEP along the segments it keeps to the L."""
    from forte.planning.search.timing import KNOT_STEP, on_segments

    task, polyline = _corner_task(10)
    law_t, law_q = task.goal.law
    lin = np.vstack([np.linspace(a, b, 200) for a, b in zip(polyline[:-1], polyline[1:], strict=True)])
    off = np.array([np.min(np.linalg.norm(lin - q, axis=1)) for q in law_q])
    assert off.max() < 0.02  # rad, from the nearest state of the L
    parabola = _parabola(polyline)
    assert max(np.min(np.linalg.norm(lin - q, axis=1)) for q in parabola) > 0.15
    assert np.linalg.norm(parabola[[0, -1]] - polyline[[0, -1]]) < 1e-9  # the same ends
    straight = np.linspace(polyline[0], polyline[-1], 50)
    assert clearances(task.robot, task.scene, straight).distance.min() < 0  # the post is in the way
    assert clearances(task.robot, task.scene, law_q).distance.min() > 0.02  # the law goes round it
    dense = on_segments(polyline)
    assert np.max(np.linalg.norm(np.diff(dense, axis=0), axis=1)) <= KNOT_STEP + 1e-12
    assert len(dense) == 1 + int(np.ceil(1.4 / KNOT_STEP)) + int(np.ceil(0.9 / KNOT_STEP))


def test_a_route_fails_as_a_plan_on_few_waypoints_and_passes_on_more():
    """The executed spline through 10 samples of the route misses what the law keeps between
    them (accelerations past a limit); on 20 samples of the same law, the same time span, it
    passes, and the route is the plan on the task's new waypoints."""
    from forte.planning.nlp.solvers.result import SolverResult
    from forte.planning.rounds import judged_route, route_as_plan

    task, _ = _corner_task(10)
    force = task.following(task.goal.route).force()
    coarse = judged(task, task.goal.route, force)[0]
    assert coarse.failed == ("acceleration",) and not any(v.waypoints for v in coarse.violations)
    on_more, verdict, _, tries = judged_route(task, force)
    assert [t["waypoints"] for t in tries] == [10, 20] and verdict.feasible
    assert on_more.n == 20 and on_more.t[-1] == task.t[-1]
    assert verdict.clearance["min_m"] > 0.02  # the post: cleared by the L's own margin
    failed = SolverResult(q=task.goal.route, success=False, status="Maximum_Iterations_Exceeded", iterations=3,
                          objective=0.0, constraint_violation=1.0, build_time=0.0, solve_time=0.0, codegen="cached")
    kept_task, q, solved, status, info, kept, _ = route_as_plan(task, failed, {}, coarse, force)
    assert solved and kept.feasible and kept_task.n == 20 and np.array_equal(q, kept_task.goal.route)
    assert info["fallback"]["waypoints"] == 20 and "on 20 waypoints" in status


def _rows_at(robot: object, q: np.ndarray, slots: object) -> np.ndarray:
    """The NLP's clearance rows (the CasADi kernels, uncompiled) of ``slots`` at the motion ``q``."""
    from forte.planning.nlp.collision_kernels import build_collision_kernels

    rows = []
    for fs in slots.frames:
        rows_of = build_collision_kernels(robot, fs.frame, fs.slots, fs.other)["clear_rows"]
        for k in range(1, len(q)):
            z = np.r_[q[max(k - 2, 0)], q[k - 1], q[k]]
            rows.append(np.asarray(rows_of(z, fs.values[k])).ravel()[fs.keep[k]])
    return np.concatenate(rows)


def test_a_route_close_to_a_body_meets_the_nlps_rows_it_starts_from():
    """A body within 1 cm of the route (exact meshes) where the route moves several cm per waypoint: with
    the clearance alone its rows (cover distance >= m + |step| / 2 at the chord's midpoint) are broken at
    the route, so IPOPT would start outside them; with the margins from the route's own distances
    and steps (``clear``) every row holds there, by the slack."""
    from forte.planning.nlp.collision_slots import START_OVERLAP_SLACK, assign_slots

    task, _ = _corner_task(10)
    route, robot = task.goal.route, task.robot
    near = clearances(robot, task.scene, route)
    k = int(np.argmax(np.abs(np.diff(route[:, 3:], axis=0)).sum(axis=1))) + 1  # the fastest interval's end
    exact = clearances(robot, task.scene, route[k:k + 1])
    away = exact.witness_body[0] - exact.witness_robot[0]
    centre = exact.witness_robot[0] + away / np.linalg.norm(away) * (0.006 + 0.01)
    from forte.model.scene import Box, Scene, SceneObject, pose_matrix

    scene = Scene((SceneObject("block", Box((0.02, 0.02, 0.02)), pose_matrix([*centre, 0, 0, 0])),), None)
    d = clearances(robot, scene, route).distance
    assert 0 < d.min() < 0.01 and near.distance.min() > 0.02  # the block within 1 cm, clear of it
    plain = assign_slots(robot, route, scene, 0.0, True)
    assert _rows_at(robot, route, plain).min() < -0.01  # broken by centimetres
    relaxed = assign_slots(robot, route, scene, 0.0, True, clear=route)
    assert _rows_at(robot, route, relaxed).min() >= START_OVERLAP_SLACK - 1e-6
