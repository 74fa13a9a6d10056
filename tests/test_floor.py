"""The floor is part of every world (issue 36, item 2): the exact check, the optimizer's rows and
MuJoCo share it; the parts rigid with the base rest on it; an arm mounted in it is refused."""

from __future__ import annotations

import json
from pathlib import Path

import mujoco
import numpy as np
import pytest
import yaml

import forte
from forte.cli.main import main
from forte.exceptions import TaskFileError
from forte.execution.contact import ARM, BASE
from forte.execution.model import build_sim_model
from forte.execution.run import simulate_plan
from forte.io.plandir import read_plan_dir, write_plan, write_plan_dir
from forte.model.body_spheres import BASE_FRAME, primitive_centres, robot_primitives
from forte.model.clearance import ClearanceChecker
from forte.model.description import PAYLOAD_RADIUS
from forte.model.presets import preset_robot
from forte.model.scene import Scene
from forte.model.self_collision import ArmGeometry
from forte.planning.nlp.collision_slots import scene_distances
from forte.planning.tasks.tasks import task_from_dict

ROOT = Path(__file__).resolve().parents[1]
LIFT = ROOT / "examples" / "tasks" / "lift.yaml"


def _ur5(tmp_path: Path, mount_z: float = 0.0, **extra) -> Path:
    """The UR5 on the base with its mount at ``mount_z``, reaching 0.1 m forward and 0.25 m down."""
    data = {"name": "ur5-low", "robot": {"preset": "ur5", "mount": {"xyz": [0.0, 0.0, mount_z]}},
            "path": {"kind": "waypoints", "relative": True, "samples": 21,
                     "waypoints": [{"t": 0.0, "position": [0, 0, 0]}, {"t": 8.0, "position": [0.1, 0, -0.25]}]},
            "payload": {"mass": 0.5}} | extra
    path = tmp_path / "ur5.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def _lift(**extra) -> forte.Task:
    return task_from_dict(yaml.safe_load(LIFT.read_text()) | extra, LIFT)


def _lowest_vertex(geometry, T: np.ndarray) -> float:
    """The lowest world z of a coal mesh's vertices (or a box's corners) placed at ``T``."""
    if hasattr(geometry, "num_vertices"):
        v = np.asarray(geometry.vertices(), dtype=float).reshape(-1, 3)
    else:
        v = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * np.asarray(geometry.halfSide)
    return float(np.min(v @ T[:3, :3].T[:, 2] + T[2, 3]))


def test_a_ur5_without_a_mount_is_one_line_naming_the_link_in_the_floor(tmp_path, capsys):
    assert main(["plan", str(_ur5(tmp_path)), "--out", str(tmp_path / "o"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "robot: base_link, rigid with the base, reaches 0.003 m below the floor at z = 0 m" \
        in err[0] and "Traceback" not in err[0]
    # the number: the lowest vertex of base_link's collision mesh, at the mount (no joint moves it)
    ur5 = preset_robot("ur5", mount=np.eye(4))
    arm = ArmGeometry(ur5.urdf_path, tuple(ur5.arm_joints))
    obj = next(o for o in arm.geom.geometryObjects if o.parentJoint == 0)
    assert _lowest_vertex(obj.geometry, obj.placement.homogeneous) == pytest.approx(-0.003, abs=5e-4)
    # with the floor 1 cm lower or none, the same robot loads (the floor rules are the floor's)
    assert task_from_dict(yaml.safe_load(_ur5(tmp_path, floor={"height": -0.01}).read_text())).scene.floor == -0.01
    assert task_from_dict(yaml.safe_load(_ur5(tmp_path, floor="none").read_text())).scene.floor is None
    # a start that puts a moving link within the clearance: the line names it and the start's field
    with pytest.raises(TaskFileError, match=r"robot.home_arm: puts shoulder_link 0.034 m from the floor at "
                                            r"z = -0.01 m, closer than the clearance 0.05 m"):
        task_from_dict(yaml.safe_load(_ur5(tmp_path, floor={"height": -0.01}, clearance=0.05).read_text()))


def test_the_floor_field_moves_disables_and_refuses_bad_values(tmp_path, capsys):
    assert _lift().scene.floor == 0.0 and _lift(floor={"height": 0.3}).scene.floor == 0.3
    assert _lift(floor="none").scene.floor is None
    bad = {3: "floor: expected {height: h} (m) or none, got 3", "off": "got 'off'", None: "got None",
           "{heigth: 0}": None}
    for value, message in bad.items():
        value = yaml.safe_load(value) if isinstance(value, str) and value.startswith("{") else value
        with pytest.raises(TaskFileError, match="floor") as info:
            _lift(floor=value)
        assert message is None or message in str(info.value)
    with pytest.raises(TaskFileError, match=r"floor.height: expected a height within 100 m"):
        _lift(floor={"height": 1e3})
    with pytest.raises(TaskFileError, match=r"floor.height: expected a finite number, got 'x'"):
        _lift(floor={"height": "x"})
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(yaml.safe_load(LIFT.read_text()) | {"floor": [0.1]}))
    assert main(["plan", str(path), "--out", str(tmp_path / "o"), "--quiet"]) == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1


def test_the_exact_floor_distance_is_the_lowest_moving_vertex_and_skips_the_base(robot):
    """Random configurations: the checker's clearance to a floor at h equals the lowest vertex of
    every arm mesh that moves (hulls: a half-space's distance is at a vertex) and the payload's
    ``z - r - h``; the base box and panda_link0 (on the floor, rigid with the base) never count."""
    rng = np.random.default_rng(5)
    h = 0.3
    checker = ClearanceChecker(robot, Scene((), h))
    objs = checker._arm.geom.geometryObjects
    assert checker.grounded.tolist() == [o.parentJoint == 0 for o in objs] + [True, False]
    for _ in range(20):
        q = np.r_[rng.uniform(-1, 1, 2), rng.uniform(-np.pi, np.pi), rng.uniform(robot.lower, robot.upper)]
        T = checker.placements(q)
        lowest = {objs[i].name: _lowest_vertex(objs[i].geometry, T[i]) - h
                  for i in range(len(objs)) if objs[i].parentJoint != 0}
        lowest["payload"] = robot.ee_pose(q)[2, 3] - PAYLOAD_RADIUS - h
        got = checker.evaluate(q[None])
        assert got.body == ("floor",) and got.robot[0] not in ("base", "panda_link0")
        assert got.distance[0] == pytest.approx(min(lowest.values()), abs=1e-6)
        assert got.witness_body[0, 2] == pytest.approx(h, abs=1e-9)


def test_the_optimizer_floor_is_height_minus_radius_and_skips_the_base_frame(robot):
    """The rows' floor (a box whose top face is the floor): ``z - r - h`` for every primitive off
    the base frame, ``inf`` on it, above and below the floor alike."""
    primitives = robot_primitives(robot)
    q = np.r_[0.2, -0.1, 0.5, robot.home_arm]
    centres = primitive_centres(robot, q, primitives)
    radius = np.array([p.radius for p in primitives])
    on_base = np.array([p.frame == BASE_FRAME for p in primitives])
    for h in (0.0, 0.7, 1.2):  # 0.7, 1.2: arm spheres inside the floor (negative distances)
        D = scene_distances(centres[None], primitives, Scene((), h), 0.2)[0, :, -1]
        assert np.all(np.isinf(D[on_base]))
        np.testing.assert_allclose(D[~on_base], centres[~on_base, 2] - radius[~on_base] - h, atol=1e-9)


def test_a_far_floor_changes_no_plan_and_a_near_one_gets_rows(tmp_path):
    free = forte.plan(_lift(floor="none"))
    far = forte.plan(_lift())
    assert free.feasible and far.feasible and "clearance_rows" not in far.solver
    np.testing.assert_allclose(far.q, free.q, rtol=0, atol=1e-9)
    assert far.verdict.clearance["body"] == "floor" and far.verdict.clearance["robot"] == "payload"
    low = far.verdict.clearance["min_m"]  # the payload's lowest approach (0.351 m)
    near = forte.plan(_lift(floor={"height": low - 0.1}))  # within the clearance + 0.1 m: rows for it
    assert near.feasible and near.solver["clearance_rows"]["rounds"][0]["rows"] > 0
    assert near.verdict.clearance["min_m"] >= 0.02


def test_a_path_into_the_floor_is_infeasible_naming_it_and_mujoco_agrees(tmp_path):
    blocked = forte.plan(_lift(floor={"height": 0.4}))  # the lift's payload goes down to 0.351 m
    assert blocked.status.startswith("path blocked") and "floor" in blocked.status
    first = blocked.verdict.violations[0]
    assert first.requirement == "clearance" and first.detail.startswith("payload vs floor -0.0491 m < 0.02 m")
    # the same path with the floor at z = 0: feasible, and MuJoCo runs it touching nothing
    plan = forte.plan(_lift())
    out = write_plan(plan, tmp_path / "lift", figures=False)
    assert json.loads((out / "plan.json").read_text())["floor"] == 0.0
    result = simulate_plan(out, hold=0.2, write=False)
    assert result.success and result.summary["contacts"] == []
    # the plan's own motion under a floor at 0.4 m: the verdict and MuJoCo both find the payload in it
    raised = write_plan_dir(tmp_path / "raised", plan.robot, plan.t, plan.q, mass=2.7, scene=Scene((), 0.4))
    assert read_plan_dir(raised).scene.floor == 0.4
    doc = json.loads((raised / "plan.json").read_text())
    (raised / "plan.json").write_text(json.dumps(doc | {"floor": "high"}))
    with pytest.raises(TaskFileError, match=r"field 'floor': expected the floor forte wrote"):
        read_plan_dir(raised)
    (raised / "plan.json").write_text(json.dumps({k: v for k, v in doc.items() if k != "floor"}))
    assert read_plan_dir(raised).scene.floor == 0.0  # written before the floor: z = 0, MuJoCo's
    (raised / "plan.json").write_text(json.dumps(doc))
    assert "payload vs floor" in read_plan_dir(raised).verdict.reason()
    sim = simulate_plan(raised, hold=0.2, write=False, stop_on_failure=True)
    assert not sim.success and ("payload", "floor") in {(c["robot"], c["world"]) for c in sim.summary["contacts"]}


def test_mujoco_puts_the_floor_at_its_height_and_the_base_parts_off_it():
    """The UR5 with base_link 1 mm into a floor at -2 mm (within the tolerance): base_link belongs
    to the base (no floor contact, BASE bit), the shoulder and the payload do not; ``floor: none``
    leaves the plane without contacts."""
    ur5 = preset_robot("ur5", mount=np.eye(4))
    sim = build_sim_model(ur5, 0.5, scene=Scene((), -0.002))
    m, d = sim.model, sim.data
    plane = next(g for g in range(m.ngeom) if m.geom_type[g] == mujoco.mjtGeom.mjGEOM_PLANE)
    assert m.geom_pos[plane][2] == -0.002 and m.geom_conaffinity[plane] == ARM
    bits = {m.body(m.geom_bodyid[g]).name: int(m.geom_contype[g]) for g in range(m.ngeom) if g != plane}
    assert bits["arm/base_link"] == BASE and bits["base"] == BASE
    assert bits["arm/shoulder_link"] == ARM and bits["payload"] == ARM
    d.qpos[sim.qpos_idx] = np.r_[0.0, 0.0, 0.0, ur5.home_arm]
    mujoco.mj_forward(m, d)
    assert d.ncon == 0  # base_link reaches 1 mm below the plane: no contact, it rests on it
    none = build_sim_model(ur5, 0.5, scene=Scene((), None)).model
    assert none.geom_conaffinity[plane] == 0
