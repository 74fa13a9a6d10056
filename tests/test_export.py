"""Exports read back with the libraries (numpy, csv, mcap / mcap-ros2-support, Pinocchio, MuJoCo)."""

from __future__ import annotations

import csv
from pathlib import Path

import mujoco
import numpy as np
import pinocchio as pin
import pytest

from forte.cli.main import main
from forte.io.export import BASE_JOINTS, whole_body_urdf
from forte.io.mcap_export import TRAJECTORY_TOPIC as MCAP_TOPIC
from forte.io.plandir import METRIC_COLUMNS, read_plan_dir, write_plan, write_plan_dir
from forte.model.description import mesh_package_dirs
from forte.model.robot import MOCA_TOOL, MobileManipulator, default_robot
from forte.planning.planner import plan
from forte.planning.tasks.tasks import load_task

LIFT = Path(__file__).resolve().parents[1] / "examples" / "tasks" / "lift.yaml"


@pytest.fixture(scope="module")
def plan_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The authors' lift (built-in robot: ``ee_offset``, hand mass) at 12 waypoints (quintic: fast,
    with force and metrics)."""
    return write_plan(plan(load_task(LIFT, waypoints=12), "quintic"), tmp_path_factory.mktemp("p") / "lift",
                      figures=False)


def _differences(q: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    v = np.vstack([np.zeros(q.shape[1]), np.diff(q, axis=0) / np.diff(t)[:, None]])
    a = np.vstack([np.zeros(q.shape[1]), np.diff(v, axis=0) / np.diff(t)[:, None]])
    return v, a


def test_npz_round_trip(plan_dir: Path, tmp_path: Path) -> None:
    out = tmp_path / "lift.npz"
    assert main(["export", str(plan_dir), str(out), "--quiet"]) == 0
    ref = read_plan_dir(plan_dir)
    with np.load(out) as d:
        names = d["joint_names"].tolist()
        assert names == [*BASE_JOINTS, *(f"panda_joint{i}" for i in range(1, 8))]
        assert d["position_units"].tolist() == ["m", "m"] + ["rad"] * 8
        assert d["velocity_units"][0] == "m/s" and d["acceleration_units"][-1] == "rad/s^2"
        np.testing.assert_array_equal(d["t"], ref.t)
        np.testing.assert_array_equal(d["q"], ref.q)
        v, a = _differences(d["q"], d["t"])
        np.testing.assert_allclose(d["qd"], v, atol=1e-9, rtol=0)
        np.testing.assert_allclose(d["qdd"], a, atol=1e-9, rtol=0)
        assert d["t"][-1] == pytest.approx(load_task(LIFT, waypoints=12).t[-1])  # the task's duration
        np.testing.assert_allclose(d["force_f"], ref.force.f)
        assert {f"metric_{c}" for c in METRIC_COLUMNS} <= set(d.files)
        assert d["metric_d"].shape == d["t"].shape
        assert str(d["method"]) == "quintic"


def test_csv_has_named_columns_and_units(plan_dir: Path, tmp_path: Path) -> None:
    out = tmp_path / "lift.csv"
    assert main(["export", str(plan_dir), str(out), "--quiet"]) == 0
    lines = out.read_text().splitlines()
    comments = [line for line in lines if line.startswith("#")]
    rows = list(csv.reader(line for line in lines if not line.startswith("#")))
    header, body = rows[0], np.array(rows[1:], dtype=float)
    units = next(c for c in comments if c.startswith("# units: "))[len("# units: "):].split(",")
    assert len(units) == len(header) == 1 + 3 * 10
    assert header[:2] == ["t", "base_x"] and "panda_joint7.velocity" in header
    assert units[header.index("base_yaw.acceleration")] == "rad/s^2"
    assert units[header.index("base_x.velocity")] == "m/s"
    q = body[:, 1:11]
    v, _ = _differences(q, body[:, 0])
    np.testing.assert_allclose(body[:, 11:21], v, atol=1e-9, rtol=0)


def test_mcap_joint_trajectory_round_trip(plan_dir: Path, tmp_path: Path) -> None:
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    out = tmp_path / "lift.mcap"
    assert main(["export", str(plan_dir), str(out), "--quiet"]) == 0
    with open(out, "rb") as fh:
        reader = make_reader(fh, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        decoded = [m.decoded_message for m in reader.iter_decoded_messages(topics=[MCAP_TOPIC])]
    (channel,) = [c for c in summary.channels.values() if c.topic == MCAP_TOPIC]  # the other topics: test_mcap_topics
    schema = summary.schemas[channel.schema_id]
    assert (schema.name, schema.encoding) == ("trajectory_msgs/msg/JointTrajectory", "ros2msg")
    assert channel.message_encoding == "cdr"
    (msg,) = decoded
    ref = read_plan_dir(plan_dir)
    assert list(msg.joint_names) == [*BASE_JOINTS, *ref.robot.arm_joints]
    t = np.array([p.time_from_start.sec + 1e-9 * p.time_from_start.nanosec for p in msg.points])
    np.testing.assert_allclose(t, ref.t - ref.t[0], atol=1e-9, rtol=0)
    q = np.array([p.positions for p in msg.points])
    np.testing.assert_array_equal(q, ref.q)
    v, a = _differences(q, ref.t)
    np.testing.assert_allclose([p.velocities for p in msg.points], v, atol=1e-9, rtol=0)
    np.testing.assert_allclose([p.accelerations for p in msg.points], a, atol=1e-9, rtol=0)
    assert msg.points[0].velocities == [0.0] * 10


def test_export_rejects_unknown_format(plan_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    assert main(["export", str(plan_dir), str(tmp_path / "x.bag")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "unknown export format .bag" in err[0] and ".mcap" in err[0]
    assert main(["export", str(tmp_path / "missing"), str(tmp_path / "x.npz")]) == 2


def _check_urdf(robot: MobileManipulator, path: Path, q: np.ndarray) -> None:
    model = pin.buildModelFromUrdf(str(path))
    assert [model.names[j] for j in range(1, model.njoints)] == [*BASE_JOINTS, *robot.arm_joints]
    model.gravity = pin.Motion(np.array([0, 0, -robot.gravity, 0, 0, 0]))
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    ee_name = robot.model.frames[robot.ee_frame_id].name  # ee_frame, or forte_ee with an ee_offset
    np.testing.assert_allclose(data.oMf[model.getFrameId(ee_name)].homogeneous, robot.ee_pose(q), atol=1e-12)
    # the tool load and the locked joints: the arm's gravity torques are the planner's
    tau = pin.rnea(model, data, q, np.zeros(model.nv), np.zeros(model.nv))
    n = robot.n_arm
    np.testing.assert_allclose(tau[3:], robot.rnea(q[3:], np.zeros(n), np.zeros(n)), atol=1e-9)
    geom = pin.buildGeomFromUrdf(model, str(path), pin.GeometryType.VISUAL,  # mesh files resolve
                                 package_dirs=mesh_package_dirs())
    assert geom.ngeoms > 0


def test_robot_urdf_is_the_planner_model(plan_dir: Path, tmp_path: Path) -> None:
    out = tmp_path / "robot.urdf"
    assert main(["robot", "export", str(out), "--plan", str(plan_dir), "--quiet"]) == 0
    ref = read_plan_dir(plan_dir)
    for q in ref.q[[0, 6, 11]] + np.array([0.3, -0.2, 2.5] + [0.0] * 7):
        _check_urdf(ref.robot, out, q)
    # a tool load in the arm dynamics: the moca-like preset, and on the ee_offset end effector
    for robot in (default_robot(variant="moca-like"), default_robot(tool=MOCA_TOOL)):
        out.write_text(whole_body_urdf(robot))
        for q in ref.q[[0, 11]]:
            _check_urdf(robot, out, q)


def test_robot_urdf_of_a_ur5(ur5: MobileManipulator, tmp_path: Path) -> None:
    out = tmp_path / "ur5.urdf"
    out.write_text(whole_body_urdf(ur5))
    _check_urdf(ur5, out, np.array([0.5, 0.1, -1.0, 0.0, -1.2, 1.5, -1.9, -1.57, 0.0]))
    # a plan of that robot exports with its joint names
    plan_dir = write_plan_dir(tmp_path / "ur5plan", ur5, [0.0, 0.5, 1.0], [ur5.home()] * 3)
    assert main(["export", str(plan_dir), str(tmp_path / "ur5.npz"), "--quiet"]) == 0
    with np.load(tmp_path / "ur5.npz") as d:
        assert d["joint_names"].tolist()[3:] == list(ur5.arm_joints)


def test_robot_mjcf_loads_elsewhere(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    out = tmp_path / "robot.xml"
    assert main(["robot", "export", str(out), "--quiet"]) == 0
    monkeypatch.chdir(tmp_path.parent)
    model = mujoco.MjModel.from_xml_path(str(out))
    names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) for j in range(model.njnt)]
    assert names[:3] == list(BASE_JOINTS) and names[3:] == [f"arm/panda_joint{i}" for i in range(1, 8)]
    assert model.nmesh > 0 and model.nu == 10
    assert main(["robot", "export", str(tmp_path / "robot.sdf")]) == 2
