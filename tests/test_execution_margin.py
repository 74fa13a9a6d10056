"""The executor's clearance margin per base kind (forte.planning.verdict.margin): one table, read by
the verdict's clearance, the search's kept clearance and the goal IK alike. The mobile kinds keep
the fixed base's 2 mm at present (the module's measurements); the tests set a larger mobile margin
(:data:`MOBILE`, the paper's controllers' measured bound) to show that each user reads its robot's
kind: a mobile base's motion closer than its margin is not called feasible where a fixed base's is."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import forte
from forte.exceptions import InvalidInputError
from forte.model.clearance import clearances
from forte.model.robot import MobileManipulator
from forte.model.scene import Box, Scene, SceneObject
from forte.planning.rounds import judged
from forte.planning.verdict.margin import EXECUTION_MARGINS, execution_margin, kept_clearance

pytest.importorskip("ompl")
pytest.importorskip("toppra")

WALL = Path("examples/tasks/around-the-wall.yaml")
URDF = {"urdf": "erd:panda_description/urdf/panda.urdf", "ee_frame": "panda_hand"}
#: The plan's closest approach after the wall is moved toward it: between the two margins.
BETWEEN = 0.010
#: A mobile margin set for the tests (m): the hand's tracking bound under the paper's controllers.
MOBILE = 0.025


@pytest.fixture
def mobile_margin(monkeypatch):
    """The mobile kinds' margin raised to :data:`MOBILE` for one test."""
    for kind in ("holonomic", "differential"):
        monkeypatch.setitem(EXECUTION_MARGINS, kind, MOBILE)


def test_the_margins_now():
    assert set(EXECUTION_MARGINS) == {"fixed", "holonomic", "differential"}
    assert execution_margin("fixed") == 0.002
    assert execution_margin("holonomic") >= execution_margin("fixed")
    assert execution_margin("differential") >= execution_margin("holonomic")


def test_the_margin_is_per_base_kind_and_the_ends_still_lower_it(mobile_margin):
    assert execution_margin("fixed") == 0.002 and execution_margin("holonomic") == MOBILE > BETWEEN
    far_ends = np.array([0.05, 0.001, 0.04])
    assert kept_clearance(0.0, far_ends, "fixed") == 0.002
    assert kept_clearance(0.0, far_ends, "holonomic") == execution_margin("holonomic")
    assert kept_clearance(0.0, np.array([0.05, 0.001, 0.015]), "holonomic") == 0.015  # a goal that close
    assert kept_clearance(0.03, far_ends, "holonomic") == 0.03  # an asked clearance above the margin
    with pytest.raises(InvalidInputError, match="base: expected one of fixed, holonomic, differential"):
        execution_margin("tracked")


@pytest.fixture(scope="module")
def wall_plan():
    """The around-the-wall route (the fixed Panda, its base at rest) and the wall moved toward its
    closest approach until :data:`BETWEEN` is left there; the ends stay farther than either margin."""
    task = forte.load_task(WALL)
    plan = forte.plan(replace(task, solver=replace(task.solver, route_first=True)))
    assert plan.feasible and np.all(plan.q[:, :3] == plan.q[0, :3])
    summary = plan.verdict.clearance
    closest = summary["min_m"]
    shift = (np.array(summary["witness_robot"]) - np.array(summary["witness_body"])) * (1 - BETWEEN / closest)
    moved = [o._replace(pose=o.pose.copy()) for o in task.scene.objects]
    for o in moved:
        o.pose[:3, 3] += shift
    near = replace(plan.task, clearance=0.0, scene=task.scene._replace(objects=tuple(moved)))
    return plan, near


def test_a_mobile_base_motion_closer_than_its_margin_is_not_feasible_where_a_fixed_one_is(wall_plan, mobile_margin):
    """The same motion (the base at rest throughout, a motion either base kind may make) 10 mm from
    the wall: on the fixed base it keeps the fixed margin (2 mm), on the holonomic base it does not
    keep that base's margin, and the verdict says whose margin raised the asked 0 m."""
    plan, near = wall_plan
    ends = clearances(near.robot, near.scene, plan.q[[0, -1]]).distance
    assert ends.min() > execution_margin("holonomic")
    fixed = judged(near, plan.q, plan.force)[0]
    assert fixed.clearance["min_m"] == pytest.approx(BETWEEN, abs=1e-3)
    assert "clearance" not in fixed.failed and fixed.clearance["required_m"] == execution_margin("fixed")
    mobile_robot = MobileManipulator(**URDF, base="holonomic")
    mobile = judged(replace(near, robot=mobile_robot), plan.q, plan.force)[0]
    assert mobile.clearance["min_m"] == pytest.approx(fixed.clearance["min_m"], abs=1e-6)  # the same motion
    assert "clearance" in mobile.failed and mobile.clearance["required_m"] == execution_margin("holonomic")
    assert "raised to what execution needs on a holonomic base" in mobile.reason()


def test_the_search_keeps_the_mobile_margin_plus_the_slip(mobile_margin):
    from forte.planning.search.sampling import SLIP, kept, wanted

    pose = np.eye(4)
    pose[:3, 3] = [0.6, 0.0, 0.3]
    wall = Scene((SceneObject("wall", Box((0.5, 0.02, 0.6)), pose),), None)
    arm = (0.6, 0.0, -1.8, 0.0, 2.4, 0.785)
    start, goal = np.r_[0.0, 0.0, 0.0, -0.7, arm], np.r_[0.0, 0.0, 0.0, 0.7, arm]
    for base in ("fixed", "holonomic"):
        robot = MobileManipulator(**URDF, base=base)
        assert clearances(robot, wall, np.array([start, goal])).distance.min() > wanted(0.0, base)
        assert wanted(0.0, base) == pytest.approx(execution_margin(base) + SLIP)
        assert kept(robot, wall, 0.0, start, goal) == pytest.approx(execution_margin(base) + SLIP)


def test_the_goal_ik_asks_the_margin_at_rest_on_every_base_kind(wall_plan, mobile_margin):
    """A goal configuration 10 mm from the wall is where the robot stops: the goal IK keeps it on the
    fixed and on the holonomic base alike (the margin at rest, 2 mm plus the slip), and replaces
    one 1 mm from the wall by an IK solution of the same pose that keeps the margin at rest."""
    from forte.planning.search.goal_ik import free_goal
    from forte.planning.search.sampling import wanted
    from forte.planning.verdict.margin import REST_MARGIN

    plan, near = wall_plan
    distance = clearances(near.robot, near.scene, plan.q).distance
    q_goal = plan.q[int(np.argmin(distance))]  # the plan's closest state, as if it were the goal
    pose = near.robot.ee_pose(q_goal)
    mobile_robot = MobileManipulator(**URDF, base="holonomic")
    assert wanted(0.0, None) == wanted(0.0, "fixed") < distance.min() < wanted(0.0, "holonomic")
    for robot in (near.robot, mobile_robot):
        kept = free_goal(robot, near.scene, 0.0, plan.q[0], q_goal, pose)
        assert kept.tried == 0 and np.array_equal(kept.q, q_goal)
    summary = clearances(near.robot, near.scene, q_goal)
    shift = (summary.witness_robot[0] - summary.witness_body[0]) * (1 - 0.001 / summary.distance[0])
    closer = near.scene._replace(objects=tuple(o._replace(pose=o.pose.copy()) for o in near.scene.objects))
    for o in closer.objects:
        o.pose[:3, 3] += shift
    moved = free_goal(mobile_robot, closer, 0.0, plan.q[0], q_goal, pose)
    assert moved.tried > 0 and moved.q is not None
    assert clearances(mobile_robot, closer, moved.q).distance.min() >= wanted(0.0, None) > REST_MARGIN
    assert np.allclose(mobile_robot.ee_pose(moved.q)[:3, 3], pose[:3, 3], atol=1e-3)
