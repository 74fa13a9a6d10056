"""Via poses and pick and place on goal tasks (issue 38, items 1 and 5): a via pose is passed
within its tolerance at the waypoint its rule gives; a pick-and-place plan carries the payload's
mass only from the grasp on (its force, the torques against Pinocchio's RNEA with and without the
payload, the verdict, and MuJoCo's payload body); bad input is one line and exit 2."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import pinocchio as pin
import pytest
import yaml

import forte
from forte.capability.polytope import nominal_torques
from forte.cli.main import main
from forte.exceptions import InvalidInputError, TaskFileError
from forte.execution.grasp import Attach, grasp_time
from forte.execution.model import build_sim_model
from forte.planning.nlp.optimizer import TrajectoryOptimizer
from forte.planning.tasks.tasks import task_from_dict
from forte.planning.verdict.verdict import judge_plan

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples/tasks/pick-and-place.yaml"
PANDA = {"urdf": "erd:panda_description/urdf/panda.urdf", "ee_frame": "panda_hand", "base": "fixed"}
DOWN = {"rpy": [np.pi, 0.0, 0.0]}


def backward(x: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The paper's backward differences, starting at rest (written out here, not forte's)."""
    v, a = np.zeros_like(x), np.zeros_like(x)
    for k in range(1, len(t)):
        v[k] = (x[k] - x[k - 1]) / (t[k] - t[k - 1])
        a[k] = (v[k] - v[k - 1]) / (t[k] - t[k - 1])
    return v, a


@pytest.fixture(scope="module")
def picked(tmp_path_factory: pytest.TempPathFactory) -> tuple[Any, Path]:
    """The example planned once, and its plan directory."""
    plan = forte.plan(forte.load_task(EXAMPLE))
    out = tmp_path_factory.mktemp("pick") / "plan"
    from forte.io.plandir import write_plan

    write_plan(plan, out, figures=False)
    return plan, out


def test_pick_and_place_carries_the_mass_only_after_the_grasp(picked):
    """The planned force is zero before the grasp's waypoint and ``m (p'' - g)`` from it (the
    Panda has no tool load); the torques the plan is judged with, ``RNEA + J^T f``, are Pinocchio's
    RNEA of the bare arm before the grasp and of the arm with a point mass at the hand after it
    (the only difference: the hand's analytic acceleration instead of the backward difference)."""
    plan, _ = picked
    task, robot, m = plan.task, plan.robot, 1.0
    assert plan.feasible, plan.verdict.reason()
    assert robot.tool_force_mass == 0.0 and task.payload.mass == m
    k = task.goal.grasp_step(plan.t)
    assert plan.solver["goal"]["grasp_time_s"] == pytest.approx(plan.t[k]) and 0 < k < plan.t.size - 3
    p = np.array([robot.ee_position(q) for q in plan.q])
    a_fd = backward(p, plan.t)[1]
    g = np.array([0.0, 0.0, -robot.gravity])
    loaded = np.arange(plan.t.size) >= k
    np.testing.assert_allclose(plan.force.f, np.where(loaded[:, None], m * (a_fd - g), 0.0), atol=1e-9)
    np.testing.assert_array_equal(plan.force.r, np.where(loaded, 10.0, 0.0))
    # the torques: forte's against Pinocchio's RNEA without and with the payload
    qa = plan.q[:, 3:]
    dq, ddq = backward(qa, plan.t)
    J = robot.arm_jacobians(plan.q)
    tau = nominal_torques(robot, plan.q, plan.t) + np.einsum("kij,ki->kj", J, plan.force.f)
    bare, data = robot.model, robot.model.createData()
    heavy = robot.model.copy()
    frame = heavy.frames[robot.ee_frame_id]
    heavy.appendBodyToJoint(frame.parentJoint, pin.Inertia(m, np.zeros(3), np.zeros((3, 3))), frame.placement)
    heavy_data = heavy.createData()
    tau_0 = np.array([pin.rnea(bare, data, *x) for x in zip(qa, dq, ddq, strict=True)])
    tau_m = np.array([pin.rnea(heavy, heavy_data, *x) for x in zip(qa, dq, ddq, strict=True)])
    a_hand = []
    for x in zip(qa, dq, ddq, strict=True):
        pin.forwardKinematics(bare, data, *x)
        a_hand.append(pin.getFrameClassicalAcceleration(bare, data, robot.ee_frame_id, pin.LOCAL_WORLD_ALIGNED).linear)
    swap = np.einsum("kij,ki->kj", J, m * (np.array(a_hand) - a_fd))
    np.testing.assert_allclose(tau[:k], tau_0[:k], atol=1e-9)
    np.testing.assert_allclose(tau[k:] + swap[k:], tau_m[k:], atol=1e-8)
    assert np.abs(tau_m - tau_0).max(axis=1).min() > 1.0  # the payload's torque is not small anywhere


def test_the_verdict_judges_the_payload_only_after_the_grasp():
    """5 kg from an outstretched start: the route judged with the payload from the grasp on is
    feasible; the same motion carrying it from t = 0 fails capacity and torque at t = 0."""
    doc = yaml.safe_load(EXAMPLE.read_text())
    doc |= {"initial_configuration": [0, 0, 0, 0.0, 1.1, 0.0, -0.4, 0.0, 1.6, 0.785], "payload": {"mass": 5.0}}
    task = task_from_dict(doc)
    q = task.nominal()
    own = task.following(q)
    verdict = judge_plan(own, q, own.force())
    assert verdict.feasible, verdict.reason()
    carried = replace(own, goal=replace(own.goal, grasp=None))
    early = judge_plan(carried, q, carried.force())
    assert {"capacity", "torque"} <= set(early.failed)
    assert all(v.first_time == 0.0 for v in early.violations)


def _via_task(**path: Any) -> Any:
    return task_from_dict({"robot": PANDA, "payload": {"mass": 0.5}, "path": {
        "kind": "goal", "samples": 20, "pose": {"position": [0.45, -0.3, 0.45], "orientation": DOWN},
        "tolerance": {"position": 0.005, "angle": 0.02}, **path}})


VIA = {"position": [0.35, 0.1, 0.7], "orientation": DOWN, "tolerance": {"position": 0.003, "angle": 0.01}}


def test_a_via_pose_is_passed_within_its_tolerance():
    """The via's waypoint comes from the distance rule; the plan passes the via there (exact
    forward kinematics) and ends at the goal; the plan without the via never comes near it, and
    judged against the via task it fails tracking, naming the via."""
    task = _via_task(via=[VIA])
    start, via, goal = task.robot.ee_position(task.q_init), np.array(VIA["position"]), np.array([0.45, -0.3, 0.45])
    s = np.linalg.norm(via - start) / (np.linalg.norm(via - start) + np.linalg.norm(goal - via))
    result = forte.plan(task)
    assert result.feasible, result.verdict.reason()
    k = int(result.task.goal.steps(result.t)[0])
    assert k == int(np.argmin(np.abs(result.t - s * result.t[-3])))
    T = result.robot.ee_pose(result.q[k])
    assert np.linalg.norm(T[:3, 3] - via) <= 0.003
    assert np.linalg.norm(pin.log3(pin.rpy.rpyToMatrix(np.pi, 0.0, 0.0).T @ T[:3, :3])) <= 0.01
    assert np.linalg.norm(result.robot.ee_position(result.q[-1]) - goal) <= 0.005
    direct = forte.plan(_via_task())
    gaps = [np.linalg.norm(direct.robot.ee_position(q) - via) for q in direct.q]
    assert min(gaps) > 0.05
    routed = result.task  # the via task on the direct plan's times
    missed = judge_plan(replace(routed, t=direct.t).following(direct.q), direct.q, direct.force)
    assert "tracking" in missed.failed and "via 0" in missed.reason()


def test_via_times_given_and_the_nlp_rows():
    """``time:`` places a via at the nearest waypoint; the NLP poses the vias' waypoints and the goal."""
    task = _via_task(via=[VIA | {"time": 1.0}], duration=3.0)
    k = task.goal.steps(task.t)
    assert k.tolist() == [int(np.argmin(np.abs(task.t - 1.0)))]
    np.testing.assert_allclose(task.targets[k[0]][:3, 3], VIA["position"])
    opt = TrajectoryOptimizer(task.robot, task.n, goal="pose", via_steps=tuple(k))
    assert opt._pose_steps.tolist() == [k[0], task.n - 1]
    with pytest.raises(InvalidInputError, match="via_steps"):
        TrajectoryOptimizer(task.robot, task.n, goal="pose", via_steps=(task.n - 1,))


def test_forte_simulate_attaches_the_payload_at_the_grasp(picked):
    """The run succeeds with the payload body massless before the grasp and full after it; the
    attachment leaves the simulated state where it was (``mj_setConst`` on scratch data)."""
    plan, out = picked
    t_grasp = grasp_time(out)
    assert t_grasp == pytest.approx(plan.solver["goal"]["grasp_time_s"])
    result = forte.simulate(out, write=False)
    assert result.success, result.detail
    assert result.summary["grasp_time_s"] == pytest.approx(t_grasp)
    sim = build_sim_model(plan.robot, 1.0)
    sim.set_state(plan.q[5])
    qpos = sim.data.qpos.copy()
    attach = Attach(sim, 0.01, 0.0)
    assert sim.model.body_mass[sim.payload_body] == 0.0 and not np.any(sim.model.body_inertia[sim.payload_body])
    attach(5, None, None)  # t = 6 ms: not yet
    assert sim.model.body_mass[sim.payload_body] == 0.0
    attach(9, None, None)  # t = 10 ms
    assert sim.model.body_mass[sim.payload_body] == pytest.approx(1.0)
    np.testing.assert_array_equal(sim.data.qpos, qpos)
    mujoco.mj_forward(sim.model, sim.data)
    assert np.isclose(sim.model.body_subtreemass[sim.payload_body], 1.0)


GOALS = [{"pose": {"position": [0.5, 0.2, 0.35], "orientation": DOWN}},
         {"pose": {"position": [0.5, 0.2, 0.25], "orientation": DOWN}},
         {"pose": {"position": [0.45, -0.3, 0.4], "orientation": DOWN}}]


@pytest.mark.parametrize(("path", "extra", "message"), [
    ({"goals": []}, {}, "path.goals: expected a list of 2 to 20 goals"),
    ({"goals": GOALS, "grasp": 2}, {}, "path.grasp: expected the index of a goal before the last (0 to 1"),
    ({"goals": GOALS, "grasp": True}, {}, "path.grasp: expected the index of a goal before the last"),
    ({"goals": GOALS, "grasp": 1, "pose": GOALS[2]["pose"]}, {}, "path.pose: give goals"),
    ({"goals": [*GOALS[:2], {"pose": GOALS[2]["pose"], "time": 2.0}], "duration": 3.0}, {},
     "path.goals[2].time: the last goal is reached at the end of the motion"),
    ({"goals": [GOALS[0], {}, GOALS[2]]}, {}, "path.goals[1].pose: give exactly one of pose and configuration"),
    ({"pose": GOALS[2]["pose"], "grasp": 0}, {}, "path.grasp: applies to a goal list"),
    ({"pose": GOALS[2]["pose"], "via": [{"orientation": DOWN}]}, {}, "path.via[0].position: required field is missing"),
    ({"pose": GOALS[2]["pose"], "via": []}, {}, "path.via: expected a list of 1 to 20 via poses"),
    ({"pose": GOALS[2]["pose"], "via": [{"position": [0.4, 0, 0.5], "time": 1.0}]}, {},
     "path.via[0].time: a via's time is on the task's clock: give path.duration too"),
    ({"pose": GOALS[2]["pose"], "via": [{"position": [3.0, 0, 0.5]}]}, {}, "path.via[0].position: unreachable"),
    ({"pose": GOALS[2]["pose"], "duration": 2.0, "via": [{"position": [0.4, 0, 0.5], "time": 1.9}]}, {},
     "path.via[0].time: expected a time before the motion arrives"),
    ({"pose": GOALS[2]["pose"], "samples": 5, "via": [{"position": [0.4, 0, 0.5]}, {"position": [0.4, 0.1, 0.5]}]},
     {}, "path.samples: 2 via poses need a waypoint each"),
    ({"goals": GOALS}, {"force": {"kind": "constant", "vector": [0, 0, 5]}}, "force: a pick-and-place task"),
])
def test_bad_pick_and_via_fields_exit_2_with_one_line(tmp_path, capsys, path, extra, message):
    doc = {"robot": PANDA, "payload": {"mass": 1.0}, "path": {"kind": "goal", **path}, **extra}
    if "force" in extra:
        doc.pop("payload")
    file = tmp_path / "task.yaml"
    file.write_text(yaml.safe_dump(doc))
    code = main(["plan", str(file), "--no-figures", "--quiet", "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 2
    assert len(err.strip().splitlines()) == 1 and message in err, err
    with pytest.raises(TaskFileError):
        task_from_dict(doc)


def test_the_rule_the_legs_and_the_attached_force_on_their_own():
    """``s_i = L_i / L`` by hand; the legs stretched onto their knot times reach each knot there
    and rest after the last; ``attached_from`` keeps the tool's share and drops ball and moment
    before the grasp's waypoint only."""
    from forte.force.taskforce import TaskForce, attached_from
    from forte.planning.search.route import through_legs
    from forte.planning.search.timing import Timed
    from forte.planning.tasks.goal_poses import distance_fractions

    points = np.array([[0.0, 0, 0], [3.0, 0, 0], [3.0, 4.0, 0], [3.0, 4.0, 1.0]])
    np.testing.assert_allclose(distance_fractions(points), [3 / 8, 7 / 8])
    np.testing.assert_allclose(distance_fractions(np.zeros((4, 3))), [1 / 3, 2 / 3])
    leg_t = np.linspace(0.0, 1.0, 11)
    legs = [Timed(leg_t, np.column_stack([leg_t, leg_t ** 2]), 1.0, ""),
            Timed(2 * leg_t, np.column_stack([1 + leg_t, 1 - leg_t]), 2.0, "")]
    t = np.linspace(0.0, 3.0, 13)
    q = through_legs(t, np.array([0.0, 1.0, 2.5]), legs)
    np.testing.assert_allclose(q[[0, 4, 10, 12]], [[0, 0], [1, 1], [2, 0], [2, 0]])
    np.testing.assert_allclose(q[2], [0.5, 0.25])  # the first leg at half its time
    f = np.tile([0.0, 0.0, 30.0], (4, 1))
    force = TaskForce(np.arange(4.0), f, np.full(4, 10.0), np.ones((4, 3)), 0.2, 0.1)
    out = attached_from(force, f * (2.0 / 3.0), 2)
    np.testing.assert_allclose(out.f[:, 2], [10.0, 10.0, 30.0, 30.0])
    np.testing.assert_allclose(out.r, [0, 0, 10, 10])
    np.testing.assert_allclose(out.m, [[0, 0, 0]] * 2 + [[1, 1, 1]] * 2)
    assert (out.lever, out.moment_scale) == (0.2, 0.1)
