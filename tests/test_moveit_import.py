"""MoveIt's formats (issue 38, items 6 and 7): PlanningScene files as ``scene_file:``, ``forte import
moveit``, ``robot.locked_joints`` and ``forte robot pose``, checked against the YAML by hand and
against Pinocchio and MuJoCo directly."""

from __future__ import annotations

import json
import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
import yaml

from forte.cli.main import main
from forte.exceptions import RobotModelError, TaskFileError
from forte.io.moveit_import import MARKER, PANDA_ROBOT
from forte.model.description import resolve_urdf
from forte.model.moveit_scene import read_planning_scene
from forte.model.robot import MobileManipulator, robot_from_description
from forte.model.scene import Box, Cylinder, Mesh
from forte.model.scene_files import read_scene_file
from forte.model.urdf_loading import locked_configuration
from forte.planning.tasks.tasks import load_task, task_from_dict

MBM = Path(__file__).resolve().parent / "data" / "motionbenchmaker" / "box_panda"
needs_mbm = pytest.mark.skipif(not (MBM / "scene0001.yaml").is_file(), reason="MotionBenchMaker problems not here")
PANDA = "erd:panda_description/urdf/panda.urdf"
#: A valid task around a scene file (the built-in robot, a short relative path).
TASK = {"path": {"relative": True, "samples": 5, "waypoints": [{"t": 0.0, "position": [0, 0, 0]},
                                                               {"t": 1.0, "position": [0.05, 0, 0]}]},
        "payload": {"mass": 1.0}}


def rz(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])


def rx(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[1.0, 0, 0], [0, c, -s], [0, s, c]])


def write(path: Path, doc: object) -> Path:
    path.write_text(yaml.safe_dump(doc) if not isinstance(doc, str) else doc)
    return path


def one_line_error(capsys: pytest.CaptureFixture[str], argv: list[str]) -> str:
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("forte: error: "), err
    return err


# -- PlanningScene files ---------------------------------------------------------------------------
@needs_mbm
def test_a_motionbenchmaker_scene_reads_into_its_bodies():
    bodies = {b.name: b for b in read_scene_file(MBM / "scene0001.yaml")}
    assert sorted(bodies) == ["Can1", "base", "side_back", "side_cap", "side_front", "side_left", "side_right"]
    base = bodies["base"]  # box [0.7, 0.7, 0.04] at the YAML's position, turned about z by the quaternion
    assert base.shape == Box((0.7, 0.7, 0.04))
    qz, qw = 0.07406844364750123, 0.9972531602635496
    assert np.allclose(base.pose[:3, 3], [0.5699634262116842, 0.1630262043531711, -0.4862264457751538])
    assert np.allclose(base.pose[:3, :3], rz(2 * math.atan2(qz, qw)), atol=1e-12)
    can = bodies["Can1"]  # cylinder [height 0.14, radius 0.03]
    assert can.shape == Cylinder(radius=0.03, length=0.14)
    assert np.allclose(can.pose[:3, 3], [0.5408380884576693, 0.3580155146897772, -0.3762264457751537])
    cap = bodies["side_cap"]  # a general rotation: R v = q v q* for a vector, by quaternion algebra
    q = pin.Quaternion(0.9212477548743235, -0.0283616206065852, 0.3818591884381666, 0.06842333535374601)
    q.normalize()
    v = np.array([0.3, -0.2, 0.9])
    rotated = (q * pin.Quaternion(0.0, *v) * q.conjugate()).coeffs()[:3]
    assert np.allclose(cap.pose[:3, :3] @ v, rotated, atol=1e-12)


def test_object_pose_composes_with_primitive_poses(tmp_path):
    s45 = math.sin(math.pi / 4)
    scene = {"world": {"collision_objects": [{
        "id": "shelf", "pose": {"position": [1.0, 0.0, 0.0], "orientation": [0, 0, 2 * s45, 2 * s45]},  # scaled
        "primitives": [{"type": "box", "dimensions": [0.1, 0.2, 0.3]}, {"type": "sphere", "dimensions": [0.05]}],
        "primitive_poses": [{"position": [0.5, 0.0, 0.0], "orientation": [s45, 0, 0, s45]},
                            {"position": {"x": 0.0, "y": 0.0, "z": 0.2}}]}]}}
    bodies = read_planning_scene(write(tmp_path / "s.yaml", scene))
    assert [b.name for b in bodies] == ["shelf_0", "shelf_1"]
    # 90 deg about z, then 0.5 m along the object's x is world +y; the box turned 90 deg about its x
    assert np.allclose(bodies[0].pose[:3, 3], [1.0, 0.5, 0.0])
    assert np.allclose(bodies[0].pose[:3, :3], rz(math.pi / 2) @ rx(math.pi / 2), atol=1e-12)
    assert np.allclose(bodies[1].pose[:3, 3], [1.0, 0.0, 0.2])
    assert bodies[1].shape.radius == 0.05


def test_a_mesh_becomes_an_obj_file_coal_reads(tmp_path, monkeypatch):
    monkeypatch.setenv("FORTE_CACHE", str(tmp_path / "cache"))
    vertices = [[0, 0, 0], [0.2, 0, 0], [0, 0.1, 0], [0, 0, 0.3]]
    scene = {"world": {"collision_objects": [{
        "id": "wedge", "meshes": [{"vertices": [dict(zip("xyz", v, strict=True)) for v in vertices],
                                   "triangles": [{"vertex_indices": t} for t in
                                                 ([0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3])]}],
        "mesh_poses": [{"position": [1, 2, 3], "orientation": [0, 0, 0, 1]}]}]}}
    (body,) = read_planning_scene(write(tmp_path / "s.yaml", scene))
    assert isinstance(body.shape, Mesh) and body.shape.file.parent == tmp_path / "cache" / "meshes"
    assert body.collision_geometry().num_vertices == 4
    proxy = body.proxy()  # the vertices' bounding box, moved by the pose
    assert np.allclose(proxy.half, [0.1, 0.05, 0.15]) and np.allclose(proxy.pose[:3, 3], [1.1, 2.05, 3.15])


@needs_mbm
def test_a_task_takes_a_planning_scene_as_scene_file(tmp_path):
    task = load_task(write(tmp_path / "t.yaml", {**TASK, "scene_file": str(MBM / "scene0001.yaml"),
                                                  "floor": "none"}))
    assert len(task.scene.objects) == 7 and "Can1" in task.scene.names and task.scene.floor is None


BAD_SCENES = {
    "not yaml": ("world: [a", "cannot read it as YAML"),
    "no world": ({"robot_state": {}}, "s.yaml: world: required"),
    "world not a mapping": ({"world": [1]}, "s.yaml: world: expected a mapping"),
    "cylinder sizes": (None, "s.yaml: world.collision_objects[1].primitives[0].dimensions: expected 2 numbers "
                             "(height, radius) for a cylinder, got 3"),
    "zero quaternion": ({"orientation": [0, 0, 0, 0]},
                        "world.collision_objects[1].primitive_poses[0].orientation: a zero quaternion"),
    "unknown type": ({"type": "torus"}, "world.collision_objects[1].primitives[0].type: expected one of box, "
                                         "cylinder, sphere, got 'torus'"),
    "cone": ({"type": "cone"}, "world.collision_objects[1].primitives[0].type: a cone has no forte shape"),
    "remove": ({"operation": "REMOVE"}, "world.collision_objects[1].operation: only ADD is read"),
    "poses count": ({"primitive_poses": []}, "world.collision_objects[1].primitive_poses: expected 1 poses"),
}


def _bad_scene(case: str) -> object:
    doc, _ = BAD_SCENES[case]
    if isinstance(doc, str) or (isinstance(doc, dict) and ("world" in doc or "robot_state" in doc)):
        return doc
    good = {"id": "a", "primitives": [{"type": "box", "dimensions": [1, 1, 1]}],
            "primitive_poses": [{"position": [9, 9, 9], "orientation": [0, 0, 0, 1]}]}
    bad = {"id": "b", "primitives": [{"type": "cylinder", "dimensions": [0.1, 0.2, 0.3]}],
           "primitive_poses": [{"position": [9, 9, 9], "orientation": [0, 0, 0, 1]}]}
    if doc is not None:
        bad["primitives"][0]["dimensions"] = [0.1, 0.2]
        for key, value in doc.items():
            if key in ("type",):
                bad["primitives"][0][key] = value
            elif key == "orientation":
                bad["primitive_poses"][0][key] = value
            else:
                bad[key] = value
    return {"world": {"collision_objects": [good, bad]}}


@pytest.mark.parametrize("case", sorted(BAD_SCENES))
def test_a_bad_scene_file_is_one_line_naming_file_and_field(case, tmp_path, capsys):
    write(tmp_path / "s.yaml", _bad_scene(case))
    task = write(tmp_path / "t.yaml", {**TASK, "scene_file": "s.yaml"})
    with pytest.raises(TaskFileError) as info:
        load_task(task)
    assert str(info.value).startswith(f"{task}: scene_file: s.yaml: ") and BAD_SCENES[case][1] in str(info.value)
    err = one_line_error(capsys, ["plan", str(task), "--out", str(tmp_path / "out"), "--no-figures"])
    assert BAD_SCENES[case][1] in err


# -- robot.locked_joints ---------------------------------------------------------------------------
def test_locked_joints_reach_the_model_the_geometry_and_mujoco():
    robot = MobileManipulator(urdf=PANDA, ee_frame="panda_hand", base="fixed",
                              locked_joints={"panda_finger_joint1": 0.03, "panda_finger_joint2": 0.065})
    full = pin.buildModelFromUrdf(str(resolve_urdf(PANDA)))
    j1, j2 = (full.idx_qs[full.getJointId(f"panda_finger_joint{i}")] for i in (1, 2))
    # kept as given, 0.065 beyond the URDF's 0.04 too (geometry, as MotionBenchMaker states it)
    assert robot.locked_joints == {"panda_finger_joint1": 0.03, "panda_finger_joint2": 0.065}
    assert full.upperPositionLimit[j2] == pytest.approx(0.04)
    q_full = locked_configuration(full, robot.locked_joints)
    assert q_full[j1] == 0.03 and q_full[j2] == pytest.approx(0.065)
    # the left finger sits 0.03 m along the hand's y (URDF: axis 0 1 0, origin z 0.0584), in the
    # reduced model as in Pinocchio's full model at that configuration
    q_arm = np.array([0.1, -0.5, 0.2, -2.0, 0.1, 1.6, 0.7])
    q_full[:7] = q_arm
    data = full.createData()
    pin.framesForwardKinematics(full, data, q_full)
    expect = data.oMf[full.getFrameId("panda_hand")].inverse() * data.oMf[full.getFrameId("panda_leftfinger")]
    pin.framesForwardKinematics(robot.model, robot.data, q_arm)
    frame = robot.data.oMf
    got = frame[robot.model.getFrameId("panda_hand")].inverse() * frame[robot.model.getFrameId("panda_leftfinger")]
    assert np.allclose(got.translation, [0, 0.03, 0.0584], atol=1e-9)
    assert np.allclose(got.homogeneous, expect.homogeneous, atol=1e-12)
    from forte.model.self_collision import arm_geometry

    def left_finger(r: MobileManipulator) -> np.ndarray:  # in the hand frame, from the collision geometry
        g = arm_geometry(r)
        pin.updateGeometryPlacements(g.model, g.data, g.geom, g.geom_data, q_arm)
        names = [o.name for o in g.geom.geometryObjects]
        hand = g.geom_data.oMg[next(i for i, n in enumerate(names) if n.startswith("panda_hand"))]
        left = g.geom_data.oMg[next(i for i, n in enumerate(names) if n.startswith("panda_leftfinger"))]
        return (hand.inverse() * left).translation

    at_zero = MobileManipulator(urdf=PANDA, ee_frame="panda_hand", base="fixed")  # fingers at neutral (0)
    assert np.allclose(left_finger(robot) - left_finger(at_zero), [0, 0.03, 0], atol=1e-9)
    from forte.execution.arm_spec import load_arm_spec

    spec = load_arm_spec(robot, meshes=False, rotor=np.zeros(7))
    assert np.allclose(spec.body("panda_leftfinger").pos, [0, 0.03, 0.0584], atol=1e-12)
    assert robot.fingerprint != at_zero.fingerprint
    again = robot_from_description(robot.describe())  # plan.json keeps them
    assert again.locked_joints == robot.locked_joints and again.fingerprint == robot.fingerprint
    from forte.io.whole_body import portable_urdf

    joint = ET.fromstring(portable_urdf(robot)).find("joint[@name='panda_finger_joint1']")
    assert joint.get("type") == "fixed"
    assert np.allclose([float(v) for v in joint.find("origin").get("xyz").split()], [0, 0.03, 0.0584])


def test_locked_joints_errors_name_the_joint():
    with pytest.raises(RobotModelError, match="no joint 'panda_fnger_joint1' in panda.urdf; did you mean "
                                              "'panda_finger_joint1'"):
        MobileManipulator(urdf=PANDA, ee_frame="panda_hand", locked_joints={"panda_fnger_joint1": 0.01})
    with pytest.raises(RobotModelError, match="'panda_joint2' is a planned arm joint"):
        MobileManipulator(urdf=PANDA, ee_frame="panda_hand", locked_joints={"panda_joint2": 0.01})
    data = {**TASK, "robot": {"urdf": PANDA, "ee_frame": "panda_hand", "locked_joints": {"panda_finger_joint1": "x"}}}
    with pytest.raises(TaskFileError, match=r"robot\.locked_joints\.panda_finger_joint1: expected a finite number"):
        task_from_dict(data)
    data["robot"]["locked_joints"] = {"panda_finger_joit2": 0.01}
    with pytest.raises(TaskFileError, match="robot: locked_joints: no joint 'panda_finger_joit2'.*did you mean"):
        task_from_dict(data)


# -- forte import moveit ---------------------------------------------------------------------------
@needs_mbm
def test_import_moveit_writes_the_request_as_a_goal_task(tmp_path, capsys):
    out = tmp_path / "task.yaml"
    assert main(["import", "moveit", str(MBM / "request0001.yaml"), "--scene", str(MBM / "scene0001.yaml"),
                 "--out", str(out)]) == 0
    assert "panda_finger_joint1: 0.065 beyond the URDF's range [0, 0.04]; kept" in capsys.readouterr().err
    text = out.read_text()
    assert text.startswith(MARKER)
    doc = yaml.safe_load(text)
    request = yaml.safe_load((MBM / "request0001.yaml").read_text())
    start = dict(zip(request["start_state"]["joint_state"]["name"], request["start_state"]["joint_state"]["position"],
                     strict=True))
    goal = {c["joint_name"]: c["position"] for c in request["goal_constraints"][0]["joint_constraints"]}
    arm = [f"panda_joint{i}" for i in range(1, 8)]
    fingers = {"panda_finger_joint1": 0.065, "panda_finger_joint2": 0.065}  # the request's, beyond 0.04
    assert doc["robot"] == {**PANDA_ROBOT, "locked_joints": fingers}
    assert doc["initial_configuration"] == [0.0, 0.0, 0.0, *(start[j] for j in arm)]
    assert doc["path"] == {"kind": "goal", "configuration": [0.0, 0.0, 0.0, *(goal[j] for j in arm)]}
    assert (tmp_path / doc["scene_file"]).resolve() == (MBM / "scene0001.yaml").resolve()
    assert doc["floor"] == "none"  # the box's bottom lies at z = -0.49 m
    assert "payload" not in doc
    # forte's reader takes everything but the goal path (issue 38 item 1 adds path kind goal;
    # then this becomes a planning test: the imported task plans feasibly around the box)
    probe = {**doc, **TASK}
    task = task_from_dict(probe, out)
    assert task.robot.locked_joints == doc["robot"]["locked_joints"] and task.robot.base == "fixed"
    assert np.allclose(task.q_init, doc["initial_configuration"]) and len(task.scene.objects) == 7
    assert task.scene.floor is None
    # again over its own file: replaced; over a file it did not write: refused, untouched
    assert main(["import", "moveit", str(MBM / "request0001.yaml"), "--scene", str(MBM / "scene0001.yaml"),
                 "--out", str(out), "--quiet"]) == 0
    foreign = write(tmp_path / "mine.yaml", "name: mine\n")
    err = one_line_error(capsys, ["import", "moveit", str(MBM / "request0001.yaml"), "--scene",
                                  str(MBM / "scene0001.yaml"), "--out", str(foreign)])
    assert "was not written by 'forte import moveit'" in err and foreign.read_text() == "name: mine\n"


@needs_mbm
def test_import_moveit_writes_a_pose_goal(tmp_path):
    request = yaml.safe_load((MBM / "request0001.yaml").read_text())
    s = math.sin(0.3 / 2)
    request["goal_constraints"] = [{
        "position_constraints": [{"link_name": "panda_hand", "constraint_region": {
            "primitives": [{"type": "sphere", "dimensions": [0.01]}],
            "primitive_poses": [{"position": [0.4, 0.1, 0.5], "orientation": [0, 0, 0, 1]}]}}],
        "orientation_constraints": [{"link_name": "panda_hand", "orientation": [s, 0, 0, math.cos(0.3 / 2)],
                                     "absolute_x_axis_tolerance": 0.1, "absolute_y_axis_tolerance": 0.05,
                                     "absolute_z_axis_tolerance": 0.2}]}]
    out = tmp_path / "task.yaml"
    assert main(["import", "moveit", str(write(tmp_path / "r.yaml", request)), "--scene", str(MBM / "scene0001.yaml"),
                 "--out", str(out), "--payload", "1.5", "--floor", "keep", "--quiet"]) == 0
    doc = yaml.safe_load(out.read_text())
    assert "floor" not in doc  # kept: forte's floor at z = 0 although the box reaches below it
    assert doc["path"]["pose"]["position"] == [0.4, 0.1, 0.5]
    assert np.allclose(doc["path"]["pose"]["orientation"]["rpy"], [0.3, 0, 0])
    assert doc["path"]["tolerance"] == {"position": 0.01, "angle": 0.05}
    assert doc["payload"] == {"mass": 1.5}


@needs_mbm
@pytest.mark.parametrize(("change", "message"), [
    ({"goal_constraints": []}, "r.yaml: goal_constraints: required"),
    ({"start_state": {}}, "r.yaml: start_state.joint_state: required"),
    ({"goal_constraints": [{"joint_constraints": [{"joint_name": "panda_joint1", "position": 0.1}]}]},
     "r.yaml: goal_constraints[0].joint_constraints: has no goal for the arm joint 'panda_joint2'"),
])
def test_import_moveit_bad_requests_are_one_line(change, message, tmp_path, capsys):
    request = yaml.safe_load((MBM / "request0001.yaml").read_text()) | change
    err = one_line_error(capsys, ["import", "moveit", str(write(tmp_path / "r.yaml", request)), "--scene",
                                  str(MBM / "scene0001.yaml"), "--out", str(tmp_path / "t.yaml")])
    assert message in err and not (tmp_path / "t.yaml").exists()


# -- forte robot pose ------------------------------------------------------------------------------
def test_robot_pose_agrees_with_forte_and_pinocchio(tmp_path, capsys):
    q_arm = [0.3, -0.4, 0.2, -2.1, 0.1, 1.7, 0.5]
    assert main(["robot", "pose", "--urdf", PANDA, "--ee-frame", "panda_hand", "--q", *map(str, q_arm), "--json"]) == 0
    pose = json.loads(capsys.readouterr().out)
    robot = MobileManipulator(urdf=PANDA, ee_frame="panda_hand")
    assert np.allclose(pose["matrix"], robot.ee_pose([0, 0, 0, *q_arm]), atol=1e-12)
    full = pin.buildModelFromUrdf(str(resolve_urdf(PANDA)))  # Pinocchio alone: fingers at 0
    data = full.createData()
    pin.framesForwardKinematics(full, data, np.array([*q_arm, 0.0, 0.0]))
    T = data.oMf[full.getFrameId("panda_hand")].homogeneous
    assert np.allclose(pose["matrix"], T, atol=1e-12) and np.allclose(pose["position"], T[:3, 3])
    x, y, z, w = pose["quaternion"]
    assert np.allclose(pin.Quaternion(w, x, y, z).matrix(), T[:3, :3], atol=1e-12)
    assert np.allclose(pin.rpy.rpyToMatrix(*pose["rpy"]), T[:3, :3], atol=1e-12)
    # a task: its robot and its start (the base moved and turned)
    start = [0.5, -0.2, 0.7, *q_arm]
    task = write(tmp_path / "t.yaml", {"robot": {"urdf": PANDA, "ee_frame": "panda_hand"},
                                       "initial_configuration": start, "path": {"kind": "not read here"}})
    assert main(["robot", "pose", str(task), "--json"]) == 0
    moved = json.loads(capsys.readouterr().out)
    assert np.allclose(moved["matrix"], robot.ee_pose(start), atol=1e-12)
    assert main(["robot", "pose", "--robot", "authors"]) == 0
    assert "position" in capsys.readouterr().out
    err = one_line_error(capsys, ["robot", "pose", "--robot", "authors", "--q", "1", "2"])
    assert "--q: expected 10 values (x, y, yaw and 7 arm joints) or 7 (the arm joints), got 2" in err


def test_an_imported_motionbenchmaker_problem_plans_feasibly_and_executes(tmp_path):
    """``forte import moveit`` on a MotionBenchMaker pair (table_pick 0001: a grasp among cans) gives
    a goal task that plans feasibly among the cans (clearance 0 as the benchmark judges; the
    fingers at the request's 0.065 m, the straight line is free) and runs in MuJoCo without a touch."""
    import forte
    from forte.execution.run import simulate_plan
    from forte.io.plandir import write_plan
    from forte.planning.tasks.tasks import load_task

    pair = MBM.parent / "table_pick_panda"
    out = tmp_path / "task.yaml"
    assert main(["import", "moveit", str(pair / "request0001.yaml"), "--scene", str(pair / "scene0001.yaml"),
                 "--out", str(out), "--floor", "none", "--quiet"]) == 0
    out.write_text(out.read_text() + "clearance: 0.0\n")
    plan = forte.plan(load_task(out))
    assert plan.feasible, plan.verdict.reason()
    assert plan.verdict.clearance["min_m"] >= 0.0
    write_plan(plan, tmp_path / "plan")
    result = simulate_plan(tmp_path / "plan")
    assert result.success, result.detail
