"""MuJoCo model vs Pinocchio, the Section 3.1 controllers, the verdict and ``forte simulate``."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest

from forte.cli.main import main
from forte.exceptions import SimulationError, TaskFileError
from forte.execution.control import DEFAULT_D_A, DEFAULT_K_A, sampled_loop_spectral_radius
from forte.execution.judge import Thresholds
from forte.execution.model import ARM_ARMATURE, build_sim_model, combined_tool
from forte.execution.run import simulate_plan
from forte.force.taskforce import payload_force
from forte.io.plandir import read_plan_dir, write_plan, write_plan_dir
from forte.model.robot import MOCA_MOUNT, MOCA_TOOL, MobileManipulator, default_robot
from forte.model.trajectory import quintic_path
from forte.planning.planner import plan
from forte.planning.tasks.tasks import load_task

# The 6 s waypoint lift on the moca-like robot (lift.yaml is now the authors' 10 s taught lift).
LIFT = Path(__file__).resolve().parents[1] / "examples" / "tasks" / "lift-path.yaml"


def _interior_states(robot: MobileManipulator, n: int, seed: int = 0):
    """Random arm states strictly inside the joint ranges (MuJoCo adds limit forces outside)."""
    rng = np.random.default_rng(seed)
    span = robot.upper - robot.lower
    for _ in range(n):
        q = rng.uniform(robot.lower + 0.05 * span, robot.upper - 0.05 * span)
        yield q, rng.normal(size=robot.n_arm), 3 * rng.normal(size=robot.n_arm)


def _planned_force(robot: MobileManipulator, t: list[float], q: list[np.ndarray], mass: float) -> np.ndarray:
    """The planner's required force ``(m_payload + robot.tool_force_mass)(a - g)`` (as a task's).

    ``write_plan_dir(..., mass=m)`` alone gives ``m (a - g)``, while the simulation carries the
    payload *and* ``tool_force_mass`` (:func:`forte.execution.run.simulate_plan`).
    """
    positions = np.array([robot.ee_position(qk) for qk in q])
    return payload_force(t, positions, mass + robot.tool_force_mass, gravity=robot.gravity).f


def test_mj_inverse_matches_rnea(robot: MobileManipulator) -> None:
    sim = build_sim_model(robot, armature=0.0)  # rigid bodies only: exactly Pinocchio's model
    worst = max(np.abs(sim.inverse_dynamics(q, dq, a) - robot.rnea(q, dq, a)).max()
                for q, dq, a in _interior_states(robot, 50))
    assert worst < 1e-6


def test_mj_inverse_is_rnea_plus_rotor_inertia(robot: MobileManipulator) -> None:
    sim = build_sim_model(robot)
    assert np.allclose(sim.armature, ARM_ARMATURE)
    worst = max(np.abs(sim.inverse_dynamics(q, dq, a) - robot.rnea(q, dq, a) - sim.armature * a).max()
                for q, dq, a in _interior_states(robot, 20, seed=2))
    assert worst < 1e-6


def test_mj_inverse_matches_rnea_with_payload(robot: MobileManipulator) -> None:
    com = (0.01, 0.02, 0.05)
    sim = build_sim_model(robot, 2.5, payload_com=com)
    heavy = default_robot(tool=combined_tool(robot.tool, 2.5, com))
    worst = max(np.abs(sim.inverse_dynamics(q, dq, a) - heavy.rnea(q, dq, a) - sim.armature * a).max()
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
    t, q = [0.0, 0.5], [robot.home()] * 2
    write_plan_dir(tmp_path, robot, t, q, mass=1.5, force=_planned_force(robot, t, q, 1.5))
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
    write_plan_dir(tmp_path, robot, [0.0, 1.0], [q0, q1], mass=1.0,
                   force=_planned_force(robot, [0.0, 1.0], [q0, q1], 1.0))
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


def _arm_inertia(robot: MobileManipulator, q_a: np.ndarray, armature: float) -> np.ndarray:
    """Joint-space arm inertia of the simulated arm (tool included) from ``mj_inverse``."""
    sim = build_sim_model(robot, armature=armature)
    g = sim.inverse_dynamics(q_a, np.zeros(robot.n_arm), np.zeros(robot.n_arm))
    return np.column_stack([sim.inverse_dynamics(q_a, np.zeros(robot.n_arm), e) - g
                            for e in np.eye(robot.n_arm)])


def test_sampled_impedance_loop_needs_rotor_inertia_at_wrist_alignment(robot: MobileManipulator) -> None:
    # The quintic lift's low point: q6 close to pi (joint axes 5 and 7 nearly parallel). Without
    # rotor inertia the mode q5 = -q7 has ~0.007 kg m^2 and the 1 kHz damping D_a is unstable
    # there (the original bug: joints 5/7 and 1/3 saturating against each other at t ~ 2 s).
    q_a = np.array([0.0, 0.186, 0.0, -2.92, 0.0, 3.109, 0.785])
    bare = sampled_loop_spectral_radius(_arm_inertia(robot, q_a, 0.0), DEFAULT_K_A, DEFAULT_D_A, 1e-3)
    geared = sampled_loop_spectral_radius(_arm_inertia(robot, q_a, ARM_ARMATURE), DEFAULT_K_A, DEFAULT_D_A, 1e-3)
    assert bare > 1.5
    assert geared < 1.0


def test_quintic_lift_tracks_with_and_without_payload(tmp_path: Path) -> None:
    # Regression: a smooth 6 s lift (0.45 m down and back up, base moving 0.23 m) at its planned
    # 2.7 kg payload used to fail with torque saturation at t = 2.17 s.
    res = plan(load_task(LIFT, mass=2.7), "quintic")
    assert res.success
    plan_dir = write_plan(res, tmp_path / "quintic", figures=False)
    loaded = simulate_plan(plan_dir, hold=0.5, write=False)
    assert loaded.success, loaded.detail
    assert loaded.summary["max_ee_error_m"] < 0.01
    assert loaded.summary["max_arm_joint_error_rad"] < 0.01
    assert max(loaded.summary["max_torque_ratio"]) < 0.9
    assert loaded.summary["force_feedforward"]
    # mass 0 = no payload: no payload body and (this robot's force includes no tool) no force
    # feedforward, so it tracks as well.
    assert res.task.robot.tool_force_mass == 0.0
    empty = simulate_plan(plan_dir, 0.0, hold=0.5, write=False)
    assert empty.success, empty.detail
    assert not empty.summary["force_feedforward"] and empty.summary["force_feedforward_share"] == 0.0
    assert empty.summary["max_ee_error_m"] < 0.01
    # The feedforward of the planned 26 N without anything to carry lifts the arm ~2 cm.
    pushed = simulate_plan(plan_dir, 0.0, force_feedforward=True, hold=0.5, write=False)
    assert pushed.summary["max_ee_error_m"] > 0.01


# -- any arm, gains, sim.csv state columns, viewer -----------------------------------------------
def _ur5_on_base() -> MobileManipulator:
    """A UR5 on the default robot's base (same mount and tool as the built-in Panda)."""
    return MobileManipulator("erd:ur_description/urdf/ur5_robot.urdf", "tool0", name="ur5",
                             mount=np.array(MOCA_MOUNT), tool=MOCA_TOOL)


def _ur5_plan(plan_dir: Path) -> None:
    """A slow 2 s rest-to-rest joint-space motion of base and arm, carrying 1 kg."""
    ur5 = _ur5_on_base()
    q0 = np.array([0.0, 0.0, 0.0, 0.0, -1.2, 1.5, -1.9, -1.57, 0.0])
    q1 = q0 + np.array([0.1, 0.05, 0.1, 0.3, -0.2, 0.2, 0.2, 0.3, 0.3])
    t = np.linspace(0.0, 2.0, 21)
    write_plan_dir(plan_dir, ur5, t, quintic_path([0.0, 2.0], [q0, q1], t), mass=1.0)


def test_ur5_model_matches_pinocchio() -> None:
    ur5 = _ur5_on_base()
    sim = build_sim_model(ur5)
    q = np.concatenate([[0.3, -0.2, 0.7], [0.2, -1.0, 1.2, -1.5, -1.4, 0.4]])
    sim.set_state(q)
    assert np.allclose(sim.ee_pose(), ur5.ee_pose(q), atol=1e-12)
    assert np.allclose(sim.ee_jacobian(), ur5.arm_jacobian(q), atol=1e-12)
    worst = max(np.abs(sim.inverse_dynamics(qa, dqa, a) - ur5.rnea(qa, dqa, a) - sim.armature * a).max()
                for qa, dqa, a in _interior_states(ur5, 10, seed=4))
    assert worst < 1e-6


def test_ur5_plan_simulates_with_default_gains(tmp_path: Path) -> None:
    _ur5_plan(tmp_path)
    assert main(["simulate", str(tmp_path), "--hold", "0.5", "--quiet"]) == 0
    verdict = json.loads((tmp_path / "sim.json").read_text())
    assert verdict["verdict"] == "success"
    assert verdict["max_ee_error_m"] < 0.01
    assert len(verdict["gains"]["K_a"]) == 6  # the rule, not the Panda's 7 gains
    assert verdict["sampled_loop_radius_start"] < 1.0
    # sim.csv: simulated positions and velocities, whole body, planner order, named columns.
    header = (tmp_path / "sim.csv").read_text().splitlines()[0].split(",")
    names = ["x_b", "y_b", "yaw", *(f"q{i}" for i in range(1, 7))]
    assert header[-18:] == names + [f"d{n}" for n in names]
    table = np.loadtxt(tmp_path / "sim.csv", delimiter=",", skiprows=1)
    col = {n: table[:, i] for i, n in enumerate(header)}
    q_sim = np.column_stack([col[n] for n in names])
    plan_q = read_plan_dir(tmp_path).q
    assert np.allclose(q_sim[0], plan_q[0]) and np.allclose(q_sim[-1], plan_q[-1], atol=5e-3)
    errors = np.column_stack([col[f"e_{n}"] for n in names])
    dq_sim = np.column_stack([col[f"d{n}"] for n in names])
    assert np.abs(dq_sim[0]).max() == 0.0 and np.abs(dq_sim[-1]).max() < 1e-2
    assert np.abs(errors).max() < 0.01


def test_gains_mapping_and_cli_flags(robot: MobileManipulator, tmp_path: Path,
                                     capsys: pytest.CaptureFixture[str]) -> None:
    write_plan_dir(tmp_path, robot, [0.0], [robot.home()])
    res = simulate_plan(tmp_path, gains={"bandwidth_hz": 3.0, "damping_ratio": 0.9}, hold=0.2, write=False)
    assert res.success and res.summary["gains"]["K_a"] != list(DEFAULT_K_A)
    assert main(["simulate", str(tmp_path), "--hold", "0.2", "--quiet", "--bandwidth", "3",
                 "--damping-ratio", "0.9"]) == 0
    assert json.loads((tmp_path / "sim.json").read_text())["gains"] == res.summary["gains"]
    gains_file = tmp_path / "gains.yaml"
    gains_file.write_text("controller:\n  K_a: [100, 200, 200, 100, 30, 30, 30]\n  damping_ratio: 1\n")
    assert main(["simulate", str(tmp_path), "--hold", "0.2", "--quiet", "--gains", str(gains_file)]) == 0
    assert json.loads((tmp_path / "sim.json").read_text())["gains"]["K_a"] == [100, 200, 200, 100, 30, 30, 30]
    capsys.readouterr()
    for text, message in (("controller:\n  K_a: [1, 2]\n", "controller.K_a: expected 7 numbers >= 0"),
                          ("K_a: [1, 2\n", "line 2: not valid YAML"),
                          ("- 1\n", "expected a mapping of gains"),
                          ("controller:\n  stiffness: 3\n", "controller.stiffness: unknown field")):
        gains_file.write_text(text)
        assert main(["simulate", str(tmp_path), "--gains", str(gains_file)]) == 2
        err = capsys.readouterr().err.strip()
        assert err.startswith(f"forte: error: {gains_file}") and message in err and "\n" not in err
    assert main(["simulate", str(tmp_path), "--bandwidth", "0"]) == 2
    assert "--bandwidth: expected a finite number > 0" in capsys.readouterr().err


def test_viewer_without_display_exits_2(robot: MobileManipulator, tmp_path: Path,
                                        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    if not sys.platform.startswith("linux"):
        pytest.skip("the DISPLAY check is Linux-only")
    write_plan_dir(tmp_path, robot, [0.0], [robot.home()])
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    assert main(["simulate", str(tmp_path), "--viewer"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("forte: error: --viewer: no display") and "\n" not in err
    assert not (tmp_path / "sim.json").exists()


def test_viewer_is_synced_in_real_time(robot: MobileManipulator, tmp_path: Path,
                                       monkeypatch: pytest.MonkeyPatch) -> None:
    import mujoco.viewer

    import forte.execution.render as render

    class FakeHandle:  # the user closes the window after 5 frames
        def __init__(self) -> None:
            self.syncs = 0

        def is_running(self) -> bool:
            return self.syncs < 5

        def sync(self) -> None:
            self.syncs += 1

        def close(self) -> None:
            pass

    handle = FakeHandle()
    monkeypatch.setattr(render, "check_display", lambda: None)
    monkeypatch.setattr(mujoco.viewer, "launch_passive", lambda model, data: handle)
    write_plan_dir(tmp_path, robot, [0.0], [robot.home()])
    res = simulate_plan(tmp_path, hold=0.3, viewer=True, write=False)
    assert res.success and res.summary["steps"] == 301
    assert handle.syncs == 5
    assert res.summary["wall_time_s"] > 4 * 0.017  # paced: 4 frame periods of 17 ms before the 5th


def test_unloaded_run_keeps_the_tool_s_share_of_the_force(tmp_path: Path) -> None:
    # The authors' robot adds its 1.146 kg end-effector load to the required force. Without the
    # beverage the tool is still carried, so the feedforward keeps m_tool / (m_payload + m_tool)
    # of the planned force: the hold tracks as well as with the payload and its full force.
    hold = Path(__file__).resolve().parents[1] / "examples" / "tasks" / "hold.yaml"
    res = plan(load_task(hold, mass=2.7), "forte")
    plan_dir = write_plan(res, tmp_path / "hold", figures=False)
    tool = res.task.robot.tool_force_mass
    assert tool > 1.0
    empty = simulate_plan(plan_dir, 0.0, hold=1.0, write=False)
    assert empty.success, empty.detail
    assert empty.summary["force_feedforward_share"] == pytest.approx(tool / (2.7 + tool))
    assert empty.summary["max_ee_error_m"] < 0.01
    # without that share the tool's weight is not compensated: the end effector sags more
    bare = simulate_plan(plan_dir, 0.0, force_feedforward=False, hold=1.0, write=False)
    assert bare.summary["max_ee_error_m"] > 2 * empty.summary["max_ee_error_m"]


def test_the_plan_s_own_derivatives_as_reference(tmp_path: Path) -> None:
    res = plan(load_task(LIFT, mass=0.35, waypoints=15), "quintic")
    plan_dir = write_plan(res, tmp_path / "quintic", figures=False)
    own = simulate_plan(plan_dir, hold=0.3, write=False, reference="plan")
    assert own.success, own.detail
    assert own.summary["reference"] == "plan" and own.summary["max_ee_error_m"] < 0.01
