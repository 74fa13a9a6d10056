"""The payload's force fed forward along the executed reference (:mod:`forte.execution.reference_force`)."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pinocchio as pin

import forte
from forte.execution.reference_force import along_reference, carried_mass
from forte.execution.run import simulate_plan
from forte.io.plandir import write_plan
from forte.planning.solve import goal_guess
from forte.planning.tasks.tasks import task_from_dict

ROOT = Path(__file__).resolve().parents[1]
PANDA = {"urdf": "erd:panda_description/urdf/panda.urdf", "ee_frame": "panda_hand", "base": "fixed"}
GOAL = [0.0, 0.0, 0.0, 0.5, -0.3, 0.0, -2.0, 0.0, 1.8, 0.785398]


def _goal_task(**extra):
    return task_from_dict({"robot": PANDA, "path": {"kind": "goal", "configuration": GOAL, "samples": 16}, **extra})


def test_the_carried_mass_is_found_for_a_payloads_force_and_not_for_a_given_profile():
    task = _goal_task(payload={"mass": 1.5})
    q = goal_guess(task)
    own = task.following(q).force()
    m = carried_mass(task.robot, task.t, q, own.f)
    assert m is not None and abs(m - (1.5 + task.robot.tool_force_mass)) < 1e-9
    given = np.tile([0.0, 0.0, 10.0], (task.n, 1))
    given[5:] = [0.0, 5.0, 10.0]  # a force profile: no mass times the hand's acceleration
    assert carried_mass(task.robot, task.t, q, given) is None


def test_along_the_reference_is_the_mass_times_pinocchios_hand_acceleration_less_gravity():
    """On a smooth reference (sines on every arm joint, 1 kHz) the second differences of the hand's
    positions equal Pinocchio's classical acceleration of the end-effector frame."""
    robot = _goal_task().robot
    t = np.arange(0.0, 0.6, 1e-3)
    q0 = np.array(GOAL)
    amp, w = np.array([0.3, 0.2, 0.25, 0.3, 0.4, 0.2, 0.5]), np.array([3.0, 4.0, 2.5, 5.0, 3.5, 6.0, 2.0])
    Q = np.tile(q0, (t.size, 1))
    Q[:, 3:] += amp * np.sin(w * t[:, None])
    f = along_reference(robot, t, Q, 2.0)
    frame = robot.model.getFrameId("panda_hand")
    data = robot.model.createData()
    assert np.allclose(robot.mount, np.eye(4))  # the arm's base is the world here
    for i in (50, 250, 420):
        v, a = amp * w * np.cos(w * t[i]), -amp * w**2 * np.sin(w * t[i])
        pin.forwardKinematics(robot.model, data, Q[i, 3:], v, a)
        pin.updateFramePlacements(robot.model, data)
        acc = pin.getFrameClassicalAcceleration(robot.model, data, frame, pin.LOCAL_WORLD_ALIGNED).linear
        np.testing.assert_allclose(f[i], 2.0 * (acc - np.array([0.0, 0.0, -robot.gravity])), atol=1e-4)


def test_a_fast_route_with_a_payload_tracks_in_mujoco_only_with_the_force_along_the_reference(tmp_path):
    """MotionBenchMaker's table_under_pick 0049 with 1.5 kg: its feasible plan keeps 2.8 mm from the
    table; fed the waypoints' forces, the arm lags by the payload's late inertial force and touches."""
    bench = ROOT / "benchmarks" / "motionbenchmaker.py"
    spec = importlib.util.spec_from_file_location("motionbenchmaker_reference_force", bench)
    mbm = importlib.util.module_from_spec(spec)
    sys.modules["motionbenchmaker_reference_force"] = mbm
    spec.loader.exec_module(mbm)
    data = ROOT / "tests" / "data" / "motionbenchmaker" / "table_under_pick_panda"
    plan = forte.plan(mbm.load(data / "request0049.yaml", data / "scene0049.yaml", tmp_path, 1.5))
    assert plan.feasible
    write_plan(plan, tmp_path / "plan")
    along = simulate_plan(tmp_path / "plan")
    assert along.success and along.summary["max_ee_error_m"] < 0.003
    lagging = simulate_plan(tmp_path / "plan", gains={"force_along_reference": False})
    assert lagging.summary["max_ee_error_m"] > 3 * along.summary["max_ee_error_m"]
