"""MuJoCo model vs Pinocchio, the Section 3.1 controllers, the verdict and ``forte simulate``."""

from __future__ import annotations

import json
from pathlib import Path

import mujoco
import numpy as np
import pytest

from forte.cli import main
from forte.exceptions import SimulationError, TaskFileError
from forte.robot import MobileManipulator, default_robot
from forte.simulation import (
    Thresholds,
    build_sim_model,
    combined_tool,
    simulate_plan,
    write_plan_dir,
)


def _interior_states(robot: MobileManipulator, n: int, seed: int = 0):
    """Random arm states strictly inside the joint ranges (MuJoCo adds limit forces outside)."""
    rng = np.random.default_rng(seed)
    span = robot.upper - robot.lower
    for _ in range(n):
        q = rng.uniform(robot.lower + 0.05 * span, robot.upper - 0.05 * span)
        yield q, rng.normal(size=robot.n_arm), 3 * rng.normal(size=robot.n_arm)


def test_mj_inverse_matches_rnea(robot: MobileManipulator) -> None:
    sim = build_sim_model(robot)
    worst = max(np.abs(sim.inverse_dynamics(q, dq, a) - robot.rnea(q, dq, a)).max()
                for q, dq, a in _interior_states(robot, 50))
    assert worst < 1e-6


def test_mj_inverse_matches_rnea_with_payload(robot: MobileManipulator) -> None:
    com = (0.01, 0.02, 0.05)
    sim = build_sim_model(robot, 2.5, payload_com=com)
    heavy = default_robot(tool=combined_tool(robot.tool, 2.5, com))
    worst = max(np.abs(sim.inverse_dynamics(q, dq, a) - heavy.rnea(q, dq, a)).max()
                for q, dq, a in _interior_states(robot, 50, seed=1))
    assert worst < 1e-6


def test_kinematics_match(robot: MobileManipulator) -> None:
    sim = build_sim_model(robot)
    q = robot.home((0.4, -1.0, 0.8))
    sim.set_state(q)
    assert np.allclose(sim.ee_pose(), robot.ee_pose(q), atol=1e-12)
    assert np.allclose(sim.ee_jacobian(), robot.arm_jacobian(q), atol=1e-12)


def test_static_hold_at_home(robot: MobileManipulator, tmp_path: Path) -> None:
    write_plan_dir(tmp_path, robot, [0.0], [robot.home()])
    res = simulate_plan(tmp_path, hold=1.0, write=False)
    assert res.success, res.detail
    # Exact model + gravity feed-forward: the start is an equilibrium; bound 1e-6 m / rad.
    assert res.summary["max_ee_error_m"] < 1e-6
    assert res.summary["max_arm_joint_error_rad"] < 1e-6


def test_static_hold_with_payload_uses_force_feedforward(robot: MobileManipulator, tmp_path: Path) -> None:
    write_plan_dir(tmp_path, robot, [0.0, 0.5], [robot.home()] * 2, mass=1.5)
    res = simulate_plan(tmp_path, hold=0.5, write=False)
    assert res.success, res.detail
    assert res.summary["max_ee_error_m"] < 1e-3  # tau_F = J^T m (a - g) carries the payload


def test_saturation_detected_with_low_limits(robot: MobileManipulator, tmp_path: Path) -> None:
    write_plan_dir(tmp_path, robot, [0.0], [robot.home()])
    th = Thresholds(max_ee_error=100.0, sag=100.0, drop_sag=100.0, drop_tilt=100.0)
    res = simulate_plan(tmp_path, torque_limits=1.0, thresholds=th, hold=0.5, write=False,
                        stop_on_failure=True)
    assert not res.success
    assert res.reason == "torque saturation"
    assert res.failure_time == pytest.approx(0.25, abs=0.01)
    assert res.log["sat2"].max() == 1.0  # gravity torque of joint 2 far above 1 Nm


def test_cli_simulate_writes_results(robot: MobileManipulator, tmp_path: Path) -> None:
    q0 = robot.home()
    q1 = robot.home((0.1, 0.0, 0.1))
    q1[4] += 0.2
    write_plan_dir(tmp_path, robot, [0.0, 1.0], [q0, q1], mass=1.0)
    assert main(["simulate", str(tmp_path), "--hold", "0.2", "--quiet"]) == 0
    verdict = json.loads((tmp_path / "sim.json").read_text())
    assert verdict["verdict"] == "success"
    assert verdict["max_ee_error_m"] < 0.01
    header = (tmp_path / "sim.csv").read_text().splitlines()[0].split(",")
    assert header[:2] == ["t", "e_x_b"] and "tau7" in header and "sat1" in header and "ee_err" in header
    assert not list(tmp_path.glob(".*.tmp"))


def test_cli_failure_exit_code(robot: MobileManipulator, tmp_path: Path) -> None:
    write_plan_dir(tmp_path, robot, [0.0], [robot.home()], mass=0.5)
    assert main(["simulate", str(tmp_path), "--mass", "30", "--hold", "1", "--stop-on-failure"]) == 1
    verdict = json.loads((tmp_path / "sim.json").read_text())
    assert verdict["verdict"] == "failure" and verdict["failure_time"] < 1.0


def test_missing_plan_dir(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["simulate", str(tmp_path / "nope")]) == 2
    assert "does not exist" in capsys.readouterr().err
    (tmp_path / "plan").mkdir()
    with pytest.raises(TaskFileError, match="plan.json: file missing"):
        simulate_plan(tmp_path / "plan")


def test_malformed_trajectory(robot: MobileManipulator, tmp_path: Path) -> None:
    write_plan_dir(tmp_path, robot, [0.0, 1.0], [robot.home()] * 2)
    path = tmp_path / "trajectory.csv"
    lines = path.read_text().splitlines()
    path.write_text("\n".join([lines[0], lines[1], lines[2].replace(lines[2].split(",")[5], "abc", 1)]))
    with pytest.raises(TaskFileError, match=r"trajectory.csv: line 3, column 'q2': expected a number"):
        simulate_plan(tmp_path, write=False)
    path.write_text("\n".join([lines[0], lines[1], ",".join(lines[2].split(",")[:-1])]))
    with pytest.raises(TaskFileError, match=r"trajectory.csv: line 3: expected 11 values, got 10"):
        simulate_plan(tmp_path, write=False)
    path.write_text("\n".join([lines[0].replace(",q7", ""), lines[1]]))
    with pytest.raises(TaskFileError, match=r"trajectory.csv: header: expected 11 columns"):
        simulate_plan(tmp_path, write=False)
    path.write_text("\n".join([lines[0], lines[2], lines[1]]))
    with pytest.raises(TaskFileError, match=r"trajectory.csv: column t\[1\]"):
        simulate_plan(tmp_path, write=False)


def test_malformed_plan_json(robot: MobileManipulator, tmp_path: Path) -> None:
    write_plan_dir(tmp_path, robot, [0.0], [robot.home()])
    meta = json.loads((tmp_path / "plan.json").read_text())
    meta["payload"]["mass"] = -1
    (tmp_path / "plan.json").write_text(json.dumps(meta))
    with pytest.raises(TaskFileError, match="plan.json: field payload.mass"):
        simulate_plan(tmp_path, write=False)


def test_rendering_failure_is_clear_and_keeps_results(
    robot: MobileManipulator, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    write_plan_dir(tmp_path, robot, [0.0], [robot.home()])
    (tmp_path / "sim.json").write_text('{"verdict": "success"}\n')

    def no_gl(*args: object, **kwargs: object) -> None:
        raise mujoco.FatalError("an OpenGL platform library has not been loaded")

    monkeypatch.setattr(mujoco, "Renderer", no_gl)
    with pytest.raises(SimulationError, match="offscreen rendering could not initialise"):
        simulate_plan(tmp_path, frames_dir=tmp_path / "frames", hold=0.1)
    assert (tmp_path / "sim.json").read_text() == '{"verdict": "success"}\n'  # untouched
    assert main(["simulate", str(tmp_path), "--frames", str(tmp_path / "frames"), "--hold", "0.1"]) == 2
