"""The exact robot-scene clearance (coal): closed forms, coal's own collide, the requirement, the outputs."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
import yaml

import forte
from forte.cli.main import main
from forte.exceptions import InvalidInputError
from forte.force.taskforce import given_force
from forte.io.plandir import LEGACY_METRIC_COLUMNS, METRIC_COLUMNS, read_metrics, read_plan_dir, write_plan
from forte.model.clearance import BASE_PART, ClearanceChecker, clearances
from forte.model.description import BASE_BOX_HALF_XY
from forte.model.scene import Box, Cylinder, Mesh, Scene, SceneObject, Sphere, pose_matrix
from forte.planning.verdict.verdict import judge

ROOT = Path(__file__).resolve().parents[1]
LIFT = ROOT / "examples" / "tasks" / "lift.yaml"


def _scene(*objects: tuple[str, object, list[float]]) -> Scene:
    """The bodies alone, without the floor (tests/test_floor.py checks it)."""
    return Scene(tuple(SceneObject(name, shape, pose_matrix(pose)) for name, shape, pose in objects), None)


def _box_sdf(p: np.ndarray, half: np.ndarray) -> float:
    """Signed distance from ``p`` to the axis-aligned box of half extents ``half`` at the origin."""
    q = np.abs(p) - half
    return float(np.linalg.norm(np.maximum(q, 0)) + min(q.max(), 0.0))


def test_sphere_against_the_base_box_matches_the_closed_form(robot):
    """A sphere beside the base, low (the arm far above): the base box's exact signed distance,
    outside and overlapping (EPA's penetration depth), for random base poses."""
    rng = np.random.default_rng(3)
    height = robot.mount[2, 3]
    half = np.array([*BASE_BOX_HALF_XY, height / 2])
    checked = 0
    for _ in range(40):
        qb = np.array([rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-np.pi, np.pi)])
        local = np.array([rng.uniform(-0.5, 0.5), rng.uniform(-0.45, 0.45), rng.uniform(0.05, 0.2)])
        radius = rng.uniform(0.03, 0.1)
        base = robot.base_transform(qb)
        centre = base[:3, :3] @ local + base[:3, 3]
        scene = _scene(("ball", Sphere(radius), [*centre, 0, 0, 0]))
        got = clearances(robot, scene, np.r_[qb, robot.home_arm][None])
        expected = _box_sdf(local - [0, 0, height / 2], half) - radius
        if got.robot[0] != BASE_PART:  # the sphere came nearer an arm link than the base
            continue
        checked += 1
        assert got.distance[0] == pytest.approx(expected, abs=1e-6)
        assert np.linalg.norm(got.witness_body[0] - centre) == pytest.approx(radius, abs=1e-6)
        assert np.linalg.norm(got.witness_robot[0] - got.witness_body[0]) == pytest.approx(abs(expected), abs=1e-6)
    assert checked >= 30


def test_penetration_agrees_with_coals_collide_and_the_broad_phase_is_exact(robot):
    """Boxes and spheres thrown around the arm: the checker's minimum equals the brute-force
    minimum over every pair (no broad phase), is negative exactly when coal's collide finds a
    contact, and then equals collide's signed penetration depth."""
    import coal

    rng = np.random.default_rng(7)
    q = np.r_[0.3, -0.2, 0.4, robot.home_arm]
    ee = robot.ee_pose(q)[:3, 3]
    overlapping = 0
    for _ in range(30):
        objects = [(f"box{i}", Box(tuple(rng.uniform(0.05, 0.3, 3))),
                    [*(ee + rng.uniform(-0.4, 0.4, 3)), *rng.uniform(-np.pi, np.pi, 3)]) for i in range(3)]
        objects.append(("ball", Sphere(0.08), [*(ee + rng.uniform(-0.3, 0.3, 3)), 0, 0, 0]))
        checker = ClearanceChecker(robot, _scene(*objects))
        got = checker.evaluate(q[None])
        T = checker.placements(q)
        brute, contact = np.inf, None
        for g, part in enumerate(checker.parts):
            tf_part = coal.Transform3s(T[g, :3, :3], T[g, :3, 3])
            for obj, body in zip(checker.scene.objects, checker.bodies, strict=True):
                tf_body = coal.Transform3s(obj.pose[:3, :3], obj.pose[:3, 3])
                brute = min(brute, coal.distance(part.geometry, tf_part, body.geometry, tf_body,
                                                 coal.DistanceRequest(), coal.DistanceResult()))
                if part.name == got.robot[0] and obj.name == got.body[0]:
                    result = coal.CollisionResult()
                    if coal.collide(part.geometry, tf_part, body.geometry, tf_body, coal.CollisionRequest(), result):
                        contact = result.getContact(0).penetration_depth
        assert got.distance[0] == pytest.approx(brute, abs=1e-9)
        if got.distance[0] < -1e-6:
            overlapping += 1
            assert contact == pytest.approx(got.distance[0], abs=1e-5)
        elif got.distance[0] > 1e-6:
            assert contact is None
    assert overlapping >= 5


def test_the_broad_phase_bounds_never_exceed_a_pairs_distance_and_prune_long_boards(robot, tmp_path):
    """Every (part, body) lower bound of the broad phase (sphere and oriented box) is at most
    coal's signed distance of that pair, apart and overlapping, for tilted boxes, cylinders,
    spheres and a triangle mesh; and against long thin boards (a shelf's, whose bounding spheres
    contain the arm) the box bound leaves a few coal calls where the spheres alone leave most pairs."""
    import coal

    cube = tmp_path / "cube.obj"
    corners = [[x, y, z] for x in (-0.1, 0.1) for y in (-0.1, 0.1) for z in (-0.1, 0.1)]
    faces = [(0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1), (2, 3, 7), (2, 7, 6),
             (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3)]
    cube.write_text("".join(f"v {x} {y} {z}\n" for x, y, z in corners)
                    + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in faces))
    rng = np.random.default_rng(11)
    q = np.r_[0.0, 0.0, 0.0, robot.home_arm]
    ee = robot.ee_pose(q)[:3, 3]
    overlapping = 0
    for _ in range(12):
        place = lambda: [*(ee + rng.uniform(-0.5, 0.5, 3)), *rng.uniform(-np.pi, np.pi, 3)]  # noqa: E731
        checker = ClearanceChecker(robot, _scene(("board", Box((1.2, 0.02, 0.3)), place()),
                                                 ("can", Cylinder(0.05, 0.4), place()),
                                                 ("ball", Sphere(0.1), place()), ("cube", Mesh(cube), place())))
        T = checker.placements(q)
        centres = np.einsum("gij,gj->gi", T[:, :3, :3], checker._part_centres) + T[:, :3, 3]
        bound = checker.bounds(centres, np.arange(len(checker.parts)))
        for g, part in enumerate(checker.parts):
            for b, (obj, body) in enumerate(zip(checker.scene.objects, checker.bodies, strict=True)):
                d = coal.distance(part.geometry, coal.Transform3s(T[g, :3, :3], T[g, :3, 3]), body.geometry,
                                  coal.Transform3s(obj.pose[:3, :3], obj.pose[:3, 3]), coal.DistanceRequest(),
                                  coal.DistanceResult())
                assert bound[g, b] <= d + 1e-9, (part.name, obj.name)
                overlapping += d < 0
    assert overlapping >= 5

    boards = _scene(*((f"board{i}", Box((1.5, 0.02, 1.5)), [ee[0] + 0.25 + 0.2 * i, 0, ee[2], 0, 0, np.pi / 2])
                      for i in range(3)))
    checker = ClearanceChecker(robot, boards)
    T = checker.placements(q)
    centres = np.einsum("gij,gj->gi", T[:, :3, :3], checker._part_centres) + T[:, :3, 3]
    exact = checker.evaluate(q[None]).distance[0]
    spheres = np.linalg.norm(centres[:, None] - checker._body_centres[None], axis=-1) \
        - checker._scene_radii - checker._part_radii[:, None]
    assert np.count_nonzero(checker.bounds(centres, np.arange(len(checker.parts))) < exact) <= 4
    assert np.count_nonzero(spheres < exact) >= 3 * len(checker.parts)


def test_arm_parts_follow_the_planners_kinematics_and_the_panda_meshes_are_convex(robot):
    """Each link's collision geometry sits where the kinematic model (mount folded in) puts its
    joint, and the Panda's meshes equal their convex hulls (so the hull is the exact mesh)."""
    import coal

    checker = ClearanceChecker(robot, Scene())
    q = np.r_[0.4, -0.3, 0.9, robot.home_arm + 0.2]
    T = checker.placements(q)
    model, data = robot.model, robot.model.createData()
    pin.forwardKinematics(model, data, q[3:])
    base = robot.base_transform(q[:3])
    for i, obj in enumerate(checker._arm.geom.geometryObjects):
        joint = checker._arm.model.names[obj.parentJoint]
        placed = data.oMi[model.getJointId(joint)] if obj.parentJoint else pin.SE3(robot.mount)
        np.testing.assert_allclose(T[i], base @ placed.homogeneous @ obj.placement.homogeneous, atol=1e-12)
    height = robot.mount[2, 3]
    np.testing.assert_allclose(T[-2][:3, 3], base[:3, :3] @ [0, 0, height / 2] + base[:3, 3], atol=1e-12)
    np.testing.assert_allclose(T[-1], robot.ee_pose(q), atol=1e-12)  # the payload sphere, at the end effector
    assert [p.name for p in checker.parts[-2:]] == ["base", "payload"]
    assert max(checker.hull_excess.values()) < 1e-3
    mesh = checker._arm.geom.geometryObjects[4].geometry  # panda_link4's triangle mesh
    rng = np.random.default_rng(0)
    for _ in range(50):
        pose = coal.Transform3s(pin.rpy.rpyToMatrix(*rng.uniform(-3, 3, 3)), rng.uniform(-0.4, 0.4, 3))
        d_mesh = coal.distance(mesh, coal.Transform3s(), coal.Box(0.1, 0.2, 0.1), pose,
                               coal.DistanceRequest(), coal.DistanceResult())
        d_hull = coal.distance(checker.parts[4].geometry, coal.Transform3s(), coal.Box(0.1, 0.2, 0.1), pose,
                               coal.DistanceRequest(), coal.DistanceResult())
        if d_mesh > 0:
            assert d_hull == pytest.approx(d_mesh, abs=1e-4)
        else:
            assert d_hull <= d_mesh + 1e-9  # the solid's depth, at least a triangle's


def test_the_payload_sits_at_ee_pose_to_the_bit_and_a_bad_configuration_is_refused_as_it_refuses(robot):
    """The payload's placement is :meth:`ee_pose`'s (the same products, its base transform shared
    with the arm's parts), and a configuration ``ee_pose`` refuses is refused with its error."""
    checker = ClearanceChecker(robot, Scene((), 0.0))
    rng = np.random.default_rng(8)
    for _ in range(20):
        q = np.r_[rng.uniform(-2, 2, 3), rng.uniform(robot.lower, robot.upper)]
        assert checker.placements(q)[-1].tobytes() == robot.ee_pose(q).tobytes()
    bad = np.r_[0.0, 0.0, 0.0, robot.home_arm]
    bad[5] = np.nan
    with pytest.raises(InvalidInputError) as expected:
        robot.ee_pose(bad)
    with pytest.raises(InvalidInputError) as refused:
        checker.placements(bad)
    assert str(refused.value) == str(expected.value)


def _drive(robot, x_end: float, n: int = 11, duration: float = 5.0):
    """The base drives straight ahead from x = 0 to ``x_end``, the arm at home."""
    t = np.linspace(0, duration, n)
    q = np.tile(np.r_[0.0, 0.0, 0.0, robot.home_arm], (n, 1))
    q[:, 0] = np.linspace(0, x_end, n)
    return t, q


def test_a_drive_through_a_box_is_infeasible_and_names_the_pair(robot):
    t, q = _drive(robot, 1.0)
    force = given_force(t, np.zeros((len(t), 3)), 0.0)
    table = _scene(("table", Box((0.8, 1.2, 0.75)), [1.4, 0.0, 0.375, 0, 0, 0]))
    verdict = judge(robot, t, q, force, 0.9, scene=table, clearance=0.02)
    assert verdict.label == "infeasible" and "clearance" in verdict.failed
    v = verdict.violations[verdict.failed.index("clearance")]
    assert v.worst < 0 and v.limit == 0.02 and v.units == "m" and v.waypoints
    assert " vs table " in v.detail and v.detail.split(" vs ")[0] in {"base", *(f"panda_link{i}" for i in range(8)),
                                                                        "panda_hand", "panda_leftfinger",
                                                                        "panda_rightfinger"}
    assert f"clearance: {v.detail}" in verdict.reason()
    assert verdict.clearance["body"] == "table" and verdict.clearance["min_m"] == v.worst
    # the same drive with the table far away: no clearance violation, the closest approach recorded
    far = _scene(("table", Box((0.8, 1.2, 0.75)), [11.4, 0.0, 0.375, 0, 0, 0]))
    verdict = judge(robot, t, q, force, 0.9, scene=far, clearance=0.02)
    assert "clearance" not in verdict.failed and "clearance" in verdict.checked
    assert verdict.clearance["body"] == "table" and 8.0 < verdict.clearance["min_m"] < 10.0 - BASE_BOX_HALF_XY[0]


def test_between_waypoints_only_is_caught(robot):
    """A post the base passes between two waypoints (5 waypoints, 1 m apart)."""
    t, q = _drive(robot, 4.0, n=5)
    post = _scene(("post", Sphere(0.1), [1.5, 0.0, 0.2, 0, 0, 0]))
    verdict = judge(robot, t, q, given_force(t, np.zeros((5, 3)), 0.0), 0.9, scene=post)
    v = verdict.violations[verdict.failed.index("clearance")]
    assert v.waypoints == () and "between waypoints only" in v.detail and v.detail.startswith("base vs post ")


def test_a_world_without_bodies_or_floor_adds_nothing_and_computes_nothing(robot, monkeypatch):
    def refuse(*_args, **_kw):
        raise AssertionError("clearance computed without bodies or floor")

    monkeypatch.setattr("forte.planning.verdict.verdict.clearances", refuse)
    monkeypatch.setattr("forte.planning.verdict.requirements.clearances", refuse)
    monkeypatch.setattr("forte.model.clearance.ClearanceChecker._closest", refuse)
    t, q = _drive(robot, 1.0)
    verdict = judge(robot, t, q, given_force(t, np.zeros((len(t), 3)), 0.0), 0.9, scene=Scene((), None))
    assert "clearance" not in verdict.failed and verdict.clearance is None


def _wall_task(tmp_path: Path) -> Path:
    """The lift with a wall (0.1 m thick, 3 m wide and high) through the end effector's goal."""
    goal = forte.load_task(LIFT).targets[-1][:3, 3]
    data = yaml.safe_load(LIFT.read_text())
    data["scene"] = [{"name": "wall", "box": {"size": [0.1, 3.0, 3.0]}, "pose": [float(goal[0]), 0.0, 1.5, 0, 0, 0]}]
    path = tmp_path / "lift-wall.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def test_outputs_record_the_clearance_and_read_back(robot, tmp_path):
    task = forte.load_task(_wall_task(tmp_path))
    result = forte.plan(task, "quintic")  # interpolated: the scene is ignored, the verdict judges it
    assert "clearance" in result.verdict.failed
    out = write_plan(result, tmp_path / "plan", figures=False)
    doc = json.loads((out / "plan.json").read_text())
    block = doc["clearance"]
    assert block["body"] == "wall" and block["min_m"] < 0 and block["required_m"] == 0.02
    assert block["min_m"] == result.verdict.clearance["min_m"] and 0 <= block["t"] <= 10.0
    metrics = read_metrics(out)
    assert list(metrics) == [*METRIC_COLUMNS, "tipover_margin"]  # the MOCA base states its support polygon
    assert np.min(metrics["clearance"]) >= block["min_m"] - 1e-12  # the waypoints are among the samples
    assert read_plan_dir(out).verdict.clearance == block
    # without a scene: the column holds the distance to the floor, and so does plan.json's block
    plain = write_plan(forte.plan(forte.load_task(LIFT), "quintic"), tmp_path / "plain", figures=False)
    floor = json.loads((plain / "plan.json").read_text())["clearance"]
    assert floor["body"] == "floor" and np.min(read_metrics(plain)["clearance"]) >= floor["min_m"] - 1e-12 > 0.3
    # a metrics.csv written before the clearance column is still read
    lines = (plain / "metrics.csv").read_text().splitlines()
    keep = len(LEGACY_METRIC_COLUMNS)  # the columns before clearance (and the tip-over margin after it)
    (plain / "metrics.csv").write_text("\n".join(",".join(line.split(",")[:keep]) for line in lines) + "\n")
    assert list(read_metrics(plain)) == list(LEGACY_METRIC_COLUMNS)


def test_a_wall_through_the_goal_is_never_a_success(tmp_path, capsys):
    """Planned with forte (the optimizer does not avoid the scene, and could not here): the
    verdict is not feasible and names the wall, and ``forte plan`` exits 1."""
    path = _wall_task(tmp_path)
    result = forte.plan(forte.load_task(path, waypoints=21), "forte")
    assert not result.feasible and "clearance" in result.verdict.failed
    detail = result.verdict.violations[result.verdict.failed.index("clearance")].detail
    assert " vs wall " in detail
    assert main(["plan", str(path), "--waypoints", "21", "--out", str(tmp_path / "out"), "--no-figures",
                 "--no-bound"]) == 1
    err = capsys.readouterr().err
    assert "min clearance = " in err and " vs wall" in err
    last = err.splitlines()[-1]  # a plan that runs into the scene is reported for that first
    assert last.startswith("forte: error: forte: infeasible: clearance: ") and " vs wall " in last


def test_a_scene_mesh_measures_like_its_primitive_when_apart(robot, tmp_path):
    """A cube as a triangle mesh (OBJ) and as a box: equal distances when apart; overlapping, the
    mesh reads a triangle's depth, never deeper than the solid's (module docstring)."""
    corners = np.array([[x, y, z] for x in (-0.1, 0.1) for y in (-0.1, 0.1) for z in (-0.1, 0.1)])
    faces = [(0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1), (2, 3, 7), (2, 7, 6),
             (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3)]
    obj = tmp_path / "cube.obj"
    obj.write_text("".join(f"v {x} {y} {z}\n" for x, y, z in corners) + "".join(f"f {a + 1} {b + 1} {c + 1}\n"
                                                                                   for a, b, c in faces))
    from forte.model.scene import Mesh

    q = np.r_[0.0, 0.0, 0.0, robot.home_arm]
    ee = robot.ee_pose(q)[:3, 3]
    for dx, apart in ((0.35, True), (0.2, True), (0.05, False)):
        pose = [ee[0] + dx, ee[1], ee[2], 0.3, 0.2, 0.1]
        as_mesh = clearances(robot, _scene(("cube", Mesh(obj), pose)), q[None])
        as_box = clearances(robot, _scene(("cube", Box((0.2, 0.2, 0.2)), pose)), q[None])
        if apart:
            assert as_box.distance[0] > 0
            assert as_mesh.distance[0] == pytest.approx(as_box.distance[0], abs=1e-6)
        else:
            assert as_box.distance[0] <= as_mesh.distance[0] < 0


def test_a_self_pair_overlapping_at_the_start_keeps_its_start_distance():
    from forte.planning.nlp.collision_slots import self_margins
    from forte.planning.nlp.self_pairs import SELF_MARGIN, SELF_START_SLACK

    S = np.array([[0.05, -0.03, 0.001], [0.02, -0.01, 0.0]])  # 2 waypoints x 3 pairs
    np.testing.assert_allclose(self_margins(S, True), [SELF_MARGIN, -0.03 - SELF_START_SLACK,
                                                       min(SELF_MARGIN, 0.001 - SELF_START_SLACK)])
    np.testing.assert_allclose(self_margins(S, False), SELF_MARGIN)  # no fixed start (a hold): the margin


def test_a_bare_arm_at_its_base_frame_has_no_base_box_and_a_mobile_base_has_one():
    """forte's base box stands for a mobile base under the arm's mount: a fixed arm mounted at its
    base frame's origin (a MoveIt scene's Panda) has none, in the exact check and in the planner's cover."""
    from forte.model.body_spheres import robot_primitives
    from forte.model.clearance import BASE_PART, ClearanceChecker
    from forte.model.robot import MobileManipulator, default_robot
    from forte.model.scene import Scene

    bare = MobileManipulator(urdf="erd:panda_description/urdf/panda.urdf", ee_frame="panda_hand", base="fixed")
    for robot, has_box in ((bare, False), (default_robot(), True)):
        checker = ClearanceChecker(robot, Scene(objects=()))
        assert (BASE_PART in [p.name for p in checker.parts]) == has_box
        assert any(p.piece == "base" for p in robot_primitives(robot)) == has_box
        assert len(checker.placements(robot.home())) == len(checker.parts)
        import mujoco

        from forte.execution.model import build_sim_model

        sim = build_sim_model(robot)
        sim = getattr(sim, "model", sim)
        base = mujoco.mj_name2id(sim, mujoco.mjtObj.mjOBJ_BODY, "base")
        boxes = [g for g in range(sim.ngeom)
                 if sim.geom_bodyid[g] == base and sim.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX]
        assert bool(boxes) == has_box  # MuJoCo's base touches what the clearance check sees
