"""The scene in planning: proxies against coal, the robot's sphere cover, the clearance kernels
against their numpy twin, and a plan that drives around a crate (issue 24)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import coal
import numpy as np
import pytest
import yaml

from forte.model.body_spheres import _vertices, capsule_of, primitive_centres, robot_primitives, spheres_of_capsule
from forte.model.robot import default_robot
from forte.model.scene import Box, Capsule, Cylinder, SceneObject, Sphere, pose_matrix, proxy_distance
from forte.model.self_collision import arm_geometry
from forte.planning.nlp.collision_kernels import SLOT_SIZE, build_collision_kernels
from forte.planning.nlp.collision_slots import assign_slots, pair_distances, trajectory_distances, upright

SHAPES = [Box((0.4, 0.6, 0.3)), Cylinder(0.15, 0.8), Sphere(0.2), Capsule(0.1, 0.5)]


@pytest.mark.parametrize("shape", SHAPES, ids=lambda s: type(s).__name__)
def test_proxy_distance_equals_coal_outside_the_body(shape):
    """The proxy's closed-form signed distance equals coal's distance from a point (a tiny sphere)."""
    rng = np.random.default_rng(3)
    body = SceneObject("b", shape, pose_matrix([0.3, -0.2, 0.5, 0.2, -0.4, 1.1]))
    geometry = body.collision_geometry()
    T = coal.Transform3s(body.pose[:3, :3], body.pose[:3, 3])
    points = body.pose[:3, 3] + rng.uniform(-1.0, 1.0, (200, 3))
    ours = proxy_distance(body.proxy(), points)
    for point, value in zip(points, ours, strict=True):
        result = coal.DistanceResult()
        coal.distance(geometry, T, coal.Sphere(1e-9), coal.Transform3s(np.eye(3), point), coal.DistanceRequest(),
                      result)
        if result.min_distance > 1e-6:  # coal's penetration depth of a point is another quantity
            assert value == pytest.approx(result.min_distance, abs=1e-6)
        else:
            assert value <= 1e-6


def test_sphere_cover_contains_every_collision_mesh_point():
    """Points sampled on every triangle of the arm's meshes lie inside a sphere of the cover."""
    robot = default_robot()
    geometry = arm_geometry(robot)
    rng = np.random.default_rng(0)
    for obj in geometry.geom.geometryObjects:
        g = obj.geometry
        vertices = _vertices(g)
        if hasattr(g, "num_tris") and g.num_tris:
            triangles = np.array([[t[0], t[1], t[2]] for t in (g.tri_indices(i) for i in range(g.num_tris))])
            w = rng.dirichlet(np.ones(3), size=len(triangles))
            points = np.einsum("tk,tkd->td", w, vertices[triangles])
        else:  # a primitive: points of the convex hull of its bounding corners
            points = rng.dirichlet(np.ones(len(vertices)), size=500) @ vertices
        points = np.vstack([points, vertices])
        centres, radius = spheres_of_capsule(*capsule_of(vertices))
        inside = np.linalg.norm(points[:, None] - centres[None], axis=2).min(axis=1) <= radius + 1e-12
        assert inside.all(), obj.name
        assert radius < 0.15  # a cover, not a blob


def test_cover_moves_with_the_robot_and_holds_the_base_box():
    robot = default_robot()
    primitives = robot_primitives(robot)
    base = [p for p in primitives if p.piece == "base"]
    # the base box's corners at mid-height are inside a capsule of the grid
    corners = np.array([[sx * 0.3, sy * 0.25, 0.2] for sx in (-1, 1) for sy in (-1, 1)])
    q = np.r_[1.0, -0.5, 0.7, robot.home_arm]
    world = corners @ robot.base_transform(q[:3])[:3, :3].T + np.r_[q[:2], 0]
    centres = primitive_centres(robot, q, tuple(base))
    gap = np.linalg.norm(world[:, None, :2] - centres[None, :, :2], axis=2) - np.array([p.radius for p in base])
    assert (gap.min(axis=1) <= 1e-12).all()


def test_clearance_kernel_equals_its_numpy_twin_and_its_jacobian_finite_differences():
    robot = default_robot()
    primitives = robot_primitives(robot)
    rng = np.random.default_rng(1)
    body = SceneObject("crate", Box((0.5, 0.6, 0.45)), pose_matrix([0.9, 0.2, 0.4, 0, 0, 0.6]))
    proxy = upright(body.proxy())
    hand = [i for i, p in enumerate(primitives) if p.frame == robot.n_arm - 1][:3]
    kern = build_collision_kernels(robot, robot.n_arm, len(hand))
    from forte.planning.nlp.collision_slots import _slot

    params = np.concatenate([_slot(primitives[i], proxy, 0.02) for i in hand])
    for _ in range(5):
        q0 = np.r_[rng.uniform(-0.3, 0.3, 3), robot.home_arm + rng.uniform(-0.4, 0.4, robot.n_arm)]
        q1 = q0 + rng.normal(0, 0.05, robot.nq)
        z = np.r_[q0, q0, q1]
        rows = np.array(kern["clear_rows"](z, params)).ravel()
        c0 = primitive_centres(robot, q0, primitives)[hand]
        c1 = primitive_centres(robot, q1, primitives)[hand]
        middle = pair_distances(0.5 * (c0 + c1), tuple(primitives[i] for i in hand), [proxy])[:, 0]
        need = 0.02 + 0.5 * np.linalg.norm(c1 - c0, axis=1)
        assert rows == pytest.approx(middle - need, abs=1e-8)  # one row per slot: the chord's midpoint
        # the row keeps the whole chord: every point of it (numpy, 21 samples) at least the clearance
        chord = [pair_distances(c0 + s * (c1 - c0), tuple(primitives[i] for i in hand), [proxy])[:, 0]
                 for s in np.linspace(0, 1, 21)]
        assert np.all(np.min(chord, axis=0) >= 0.02 + np.minimum(rows, 0) - 1e-9)
        J = np.array(kern["clear_jac"](z, params))
        h = 1e-6
        fd = np.column_stack([(np.array(kern["clear_rows"](z + h * e, params)).ravel()
                               - np.array(kern["clear_rows"](z - h * e, params)).ravel()) / (2 * h)
                              for e in np.eye(z.size)])
        assert J == pytest.approx(fd, abs=1e-5)


def test_an_empty_slot_gives_rows_that_always_hold():
    robot = default_robot()
    kern = build_collision_kernels(robot, 0, 2)
    rows = np.array(kern["clear_rows"](np.zeros(3 * robot.nq), np.zeros(2 * SLOT_SIZE))).ravel()
    assert rows == pytest.approx(np.ones(2))


CRATE_TASK = {
    "name": "around-the-crate",
    "path": {"kind": "waypoints", "relative": True, "samples": 41,
             "waypoints": [{"t": 0.0, "position": [0.0, 0.0, 0.0]}, {"t": 8.0, "position": [2.4, 0.0, 0.0]}]},
    "payload": {"mass": 1.0},
    "scene": [{"name": "crate", "box": {"size": [0.5, 0.6, 0.45]}, "pose": [1.5, 0.0, 0.225, 0, 0, 0]}],
}


def _exact_clearance_along_the_motion(plan) -> float:
    """The smallest exact clearance (coal, real meshes) over the waypoints and the executed spline."""
    from forte.model.clearance import clearances
    from forte.planning.verdict.motion_samples import sample_motion

    samples = sample_motion(plan.robot, plan.t, plan.q)
    return float(clearances(plan.robot, plan.scene, samples.q).distance.min())


def _simulated_without_contact(plan, tmp_path: Path) -> None:
    from forte.execution.run import simulate_plan
    from forte.io.plandir import write_plan

    directory = write_plan(plan, tmp_path / plan.task.name, figures=False)
    result = simulate_plan(directory, hold=0.3, write=False)
    assert result.success, result.detail  # a touch of the scene or the floor would fail it (reason "contact")
    assert result.summary["contact_checked"] and result.summary["contacts"] == []


@pytest.mark.slow
def test_a_crate_on_the_straight_base_path_is_driven_around(tmp_path):
    import forte
    from forte.planning.tasks.tasks import task_from_dict

    task = task_from_dict(CRATE_TASK, tmp_path / "crate.yaml")
    guess_distances, _ = trajectory_distances(task.robot, task.nominal(), task.scene)
    assert guess_distances.min() < 0  # the straight path drives through the crate
    plan = forte.plan(task)
    assert plan.feasible, plan.verdict
    D, _ = trajectory_distances(task.robot, plan.q, task.scene)
    assert D.min() >= task.clearance - 1e-6  # the cover keeps the clearance at every waypoint
    assert _exact_clearance_along_the_motion(plan) >= task.clearance  # and the meshes, between waypoints too
    assert np.abs(plan.q[:, 1]).max() > 0.5  # around it, not through it
    _simulated_without_contact(plan, tmp_path)
    free = forte.plan(task_from_dict({k: v for k, v in CRATE_TASK.items() if k != "scene"}, tmp_path / "f.yaml"))
    assert np.abs(free.q[:, 1]).max() < 0.05  # no scene: the straight path again
    slots = assign_slots(task.robot, plan.q, task.scene, task.clearance, True)
    assert slots.rows > 0 and all(f.slots <= 32 for f in slots.frames)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["table-to-shelf", "through-the-doorway"])
def test_the_shelf_and_doorway_examples_plan_clear_and_execute_without_contact(name, tmp_path):
    import forte
    from forte.planning.tasks.tasks import load_task

    task = load_task(Path(__file__).resolve().parents[1] / "examples" / "tasks" / f"{name}.yaml")
    plan = forte.plan(task)
    assert plan.feasible, plan.verdict
    assert _exact_clearance_along_the_motion(plan) >= task.clearance
    _simulated_without_contact(plan, tmp_path)


def test_the_clear_start_keeps_a_clear_guess_and_finds_one_around_the_crate(tmp_path):
    from forte.planning.scene.scene_guess import clear_start
    from forte.planning.tasks.ik import initial_guess
    from forte.planning.tasks.tasks import task_from_dict

    task = task_from_dict(CRATE_TASK, tmp_path / "crate.yaml")
    straight = initial_guess(task)
    start = clear_start(task, straight)
    assert start is not None
    D, _ = trajectory_distances(task.robot, start, task.scene)
    assert D.min() >= task.clearance  # clear at every waypoint
    assert start[0] == pytest.approx(task.q_init)  # from the fixed first configuration
    far = task_from_dict(CRATE_TASK | {"scene": [{"name": "crate", "box": {"size": [0.5, 0.6, 0.45]},
                                                  "pose": [1.5, 3.0, 0.225, 0, 0, 0]}]}, tmp_path / "far.yaml")
    assert clear_start(far, straight) is straight  # nothing near: the usual start, untouched


def test_a_wall_through_the_goal_leaves_no_clear_start(tmp_path):
    from forte.planning.scene.scene_guess import clear_start
    from forte.planning.tasks.ik import initial_guess
    from forte.planning.tasks.tasks import task_from_dict

    wall = {"name": "wall", "box": {"size": [0.1, 4.0, 2.0]}, "pose": [3.19, 0.0, 1.0, 0, 0, 0]}
    task = task_from_dict(CRATE_TASK | {"scene": [wall]}, tmp_path / "wall.yaml")
    assert clear_start(task, initial_guess(task)) is None


def test_bad_scene_entries_exit_2_with_one_line(tmp_path):
    cases = [
        ([{"name": "a", "box": {"size": [1, 2]}, "pose": [0] * 6}], "scene[0].box.size"),
        ([{"name": "a", "box": {"size": [1, 1, 1]}, "sphere": {"radius": 1}, "pose": [0] * 6}], "exactly one shape"),
        ([{"name": "a", "mesh": {"file": "nope.stl"}, "pose": [0] * 6}], "scene[0].mesh.file"),
        ([{"name": "a", "box": {"size": [1, 1, 1]}}], "scene[0].pose"),
        ([{"name": "a", "cylinder": {"radius": -1, "length": 1}, "pose": [0] * 6}], "scene[0].cylinder.radius"),
        (3, "scene: expected a list"),
    ]
    for scene, expected in cases:
        path = tmp_path / "bad.yaml"
        path.write_text(yaml.safe_dump(CRATE_TASK | {"scene": scene}))
        forte_cli = str(Path(sys.executable).parent / "forte")
        proc = subprocess.run([forte_cli, "plan", str(path), "--out", str(tmp_path / "o")],
                              capture_output=True, text=True, check=False)
        assert proc.returncode == 2, proc.stderr
        lines = proc.stderr.strip().splitlines()
        assert len(lines) == 1 and expected in lines[0], proc.stderr
        assert not (tmp_path / "o").exists()


@pytest.mark.slow
def test_the_replanner_keeps_clear_of_the_scene_after_a_mass_change_and_a_shift(tmp_path):
    from forte.planning.online.replan import Replanner
    from forte.planning.tasks.tasks import task_from_dict

    task = task_from_dict(CRATE_TASK, tmp_path / "crate.yaml")
    replanner = Replanner(task)
    for result in (replanner.replan(mass=2.5), replanner.shift(4), replanner.replan(mass=0.5)):
        assert result.plan.solved
        assert result.plan.scene == task.scene
        D, _ = trajectory_distances(task.robot, result.plan.q, task.scene)
        assert D.min() >= task.clearance - 1e-6
        assert result.plan.metrics and result.plan.verdict is not None


def test_a_wall_through_the_path_is_found_before_any_solve(tmp_path):
    """The hand's own parts cross the wall at a target pose: no motion can keep clear, so the
    optimizer is not run; the verdict is infeasible and names the wall."""
    import forte
    from forte.planning.scene.scene_solve import blocked_path
    from forte.planning.tasks.tasks import task_from_dict

    wall = {"name": "wall", "box": {"size": [0.1, 4.0, 2.0]}, "pose": [2.5, 0.0, 1.0, 0, 0, 0]}
    task = task_from_dict(CRATE_TASK | {"scene": [wall]}, tmp_path / "wall.yaml")
    reason = blocked_path(task)
    assert reason is not None and "from wall" in reason
    plan = forte.plan(task)
    assert not plan.feasible and not plan.solved and plan.status == reason
    assert "clearance" in plan.verdict.failed
    assert " vs wall " in plan.verdict.violations[plan.verdict.failed.index("clearance")].detail
    assert blocked_path(task_from_dict(CRATE_TASK, tmp_path / "crate.yaml")) is None  # the crate is passable


def test_self_collision_kernel_equals_its_numpy_twin_and_the_pairs_skip_structural_overlaps():
    from forte.planning.nlp.collision_kernels import SELF_SIZE
    from forte.planning.nlp.collision_slots import _self_slot
    from forte.planning.nlp.self_pairs import HOME_GAP, contact_postures, self_distances, self_pairs

    robot = default_robot()
    primitives = robot_primitives(robot)
    pairs = self_pairs(robot)
    gaps = np.stack([self_distances(primitive_centres(robot, q, primitives), primitives, pairs)
                     for q in contact_postures(robot)])
    assert pairs and np.all(gaps.max(axis=0) >= HOME_GAP)  # each kept pair is apart at some posture
    assert len(contact_postures(robot)) > 1 and np.allclose(contact_postures(robot)[0], robot.home())
    assert all(primitives[a].frame > primitives[b].frame for a, b in pairs)
    hand_vs_base = [(a, b) for a, b in pairs if primitives[a].piece == "panda_hand" and primitives[b].piece == "base"]
    assert hand_vs_base  # the hand is kept off the base
    chosen = hand_vs_base[:2]
    frame, other = primitives[chosen[0][0]].frame + 1, primitives[chosen[0][1]].frame + 1
    kern = build_collision_kernels(robot, frame, len(chosen), other)
    params = np.concatenate([_self_slot(primitives[a], primitives[b]) for a, b in chosen])
    assert params.size == len(chosen) * SELF_SIZE
    rng = np.random.default_rng(5)
    for _ in range(4):
        q0 = np.r_[rng.uniform(-0.3, 0.3, 3), robot.home_arm + rng.uniform(-0.5, 0.5, robot.n_arm)]
        q1 = q0 + rng.normal(0, 0.05, robot.nq)
        rows = np.array(kern["clear_rows"](np.r_[q0, q0, q1], params)).ravel()
        c0, c1 = primitive_centres(robot, q0, primitives), primitive_centres(robot, q1, primitives)
        rel = np.array([np.linalg.norm((c1[a] - c1[b]) - (c0[a] - c0[b])) for a, b in chosen])
        # the midpoint of the relative chord: a's centre moved to b's (fixed) plus the mean offset
        middle = []
        for a, b in chosen:
            cm = c1.copy()
            cm[a] = c1[b] + 0.5 * ((c1[a] - c1[b]) + (c0[a] - c0[b]))
            middle.append(self_distances(cm, primitives, ((a, b),))[0])
        assert rows == pytest.approx(middle - rel / 2, abs=1e-8)


def test_a_raw_tiagos_pair_overlapping_at_all_zeros_but_apart_at_the_start_gets_rows(tmp_path):
    """The raw TIAGo (no ``home_arm``: home is all zeros) from the feasibility matrix's start: the
    ``arm_1_link`` / ``torso_fixed_column_link`` pairs whose covers overlap at all zeros but not at
    the start get rows with the plain margin; those overlapping at the start keep their start
    distance (less the slack); the pairs no posture separates are the only ones left out."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    import feasibility_matrix as fm

    from forte.planning.nlp.collision_kernels import SELF_FIELDS, SELF_SIZE
    from forte.planning.nlp.self_pairs import (
        HOME_GAP,
        SELF_ACTIVATION,
        SELF_MARGIN,
        SELF_START_SLACK,
        self_distances,
        self_pairs,
    )
    from forte.planning.tasks.tasks import task_from_dict

    task = task_from_dict(fm.task_dict(fm.Cell("tiago-urdf", fm.Reach("forward", 0.5, 3.0), 0.0, 21)),
                          tmp_path / "t.yaml")
    robot, q0 = task.robot, np.asarray(task.q_init)
    assert np.allclose(robot.home_arm, 0.0)
    primitives = robot_primitives(robot)
    column = ("arm_1_link", "torso_fixed_column_link")
    pairs = tuple(sorted((a, b) for a in range(len(primitives)) for b in range(len(primitives))
                         if (primitives[a].piece, primitives[b].piece) == column))
    assert len(pairs) == 12
    at_zero = self_distances(primitive_centres(robot, robot.home(), primitives), primitives, pairs)
    at_start = self_distances(primitive_centres(robot, q0, primitives), primitives, pairs)
    moved = [pair for pair, z, s in zip(pairs, at_zero, at_start, strict=True) if z < HOME_GAP <= s]
    assert moved and set(pairs) <= set(self_pairs(robot))
    slots = assign_slots(robot, np.tile(q0, (3, 1)), task.scene, task.clearance, True)
    margin = {(p, -1 - m): float(f.values[k, j * SELF_SIZE + SELF_FIELDS["margin"][0]])
              for f in slots.frames for (k, j), (p, m) in f.pairs.items() if m < 0}
    for pair, s in zip(pairs, at_start, strict=True):
        if s < SELF_ACTIVATION:  # near at the start: rows, keeping the start distance where they overlap
            assert margin[pair] == pytest.approx(min(SELF_MARGIN, s - SELF_START_SLACK))
    assert all(pair in margin and margin[pair] == SELF_MARGIN for pair in moved)


def test_the_payload_sphere_is_part_of_the_robot_for_the_planner_and_the_check(tmp_path):
    """A small body right at a target end-effector position, between the fingers: only the payload
    (the sphere MuJoCo's hand holds) touches it, and both the cover and the exact check see it."""
    from forte.model.description import PAYLOAD_RADIUS
    from forte.planning.scene.scene_solve import blocked_path
    from forte.planning.tasks.tasks import task_from_dict

    task = task_from_dict(CRATE_TASK, tmp_path / "crate.yaml")
    primitives = robot_primitives(task.robot)
    payload = [p for p in primitives if p.piece == "payload"]
    assert len(payload) == 1 and payload[0].radius == PAYLOAD_RADIUS
    at = task.targets[20][:3, 3]
    pebble = {"name": "pebble", "sphere": {"radius": 0.005}, "pose": [*at.tolist(), 0, 0, 0]}
    blocked = task_from_dict(CRATE_TASK | {"scene": [pebble]}, tmp_path / "pebble.yaml")
    reason = blocked_path(blocked)
    assert reason is not None and "payload" in reason and "pebble" in reason
    index = next(i for i, p in enumerate(primitives) if p.piece == "payload")
    centre = primitive_centres(task.robot, task.nominal()[20], primitives)[index]
    assert centre == pytest.approx(at, abs=1e-6)


def test_a_hold_keeps_clear_of_a_lamp_over_the_arm(tmp_path):
    """Holding (one waypoint, every start of the multi-start solve): one row per pair, no interval."""
    import forte
    from forte.model.clearance import clearances
    from forte.planning.tasks.tasks import load_task

    hold = yaml.safe_load((Path(__file__).resolve().parents[1] / "examples" / "tasks" / "hold.yaml").read_text())
    hold["scene"] = [{"name": "lamp", "sphere": {"radius": 0.08}, "pose": [0.62, 0.0, 1.25, 0, 0, 0]}]
    path = tmp_path / "hold.yaml"
    path.write_text(yaml.safe_dump(hold))
    task = load_task(path, mass=1.0)
    D, _ = trajectory_distances(task.robot, task.teaching[None], task.scene)
    assert D.min() < task.clearance  # the taught posture's elbow is under the lamp
    plan = forte.plan(task)
    assert plan.feasible, plan.verdict
    assert clearances(task.robot, task.scene, plan.q).distance.min() >= task.clearance


def test_an_upright_box_on_the_base_is_covered_by_vertical_capsules_that_hold_it():
    """TIAGo's torso column (a 0.23 x 0.23 x 0.55 m box fixed to the base): 4 vertical capsules of
    its cells' half diagonal, holding every point of the box, far tighter than one sphere chain."""
    import coal
    import pinocchio as pin

    from forte.model.body_spheres import BASE_FRAME, upright_box_capsules
    from forte.model.self_collision import arm_geometry
    from forte.planning.tasks.tasks import task_from_dict

    robot = task_from_dict({
        "robot": {"urdf": "erd:tiago_description/robots/tiago.urdf", "ee_frame": "arm_tool_link",
                  "base": "differential",
                  "arm_joints": ["torso_lift_joint", *(f"arm_{i}_joint" for i in range(1, 8))]},
        "path": {"kind": "waypoints", "relative": True, "waypoints": [{"t": 0.0, "position": [0, 0, 0]},
                                                                      {"t": 1.0, "position": [0.1, 0, 0]}]},
        "payload": {"mass": 0.5}}, Path("tiago.yaml")).robot
    (column,) = [o for o in arm_geometry(robot).geom.geometryObjects if o.name == "torso_fixed_column_link_0"]
    mount = pin.SE3(robot.mount[:3, :3].copy(), robot.mount[:3, 3].copy())
    placement = mount * column.placement
    capsules = [p for p in robot_primitives(robot) if p.piece == "torso_fixed_column_link"]
    again = upright_box_capsules(column.geometry, placement, "torso_fixed_column_link")
    np.testing.assert_allclose([p.centre for p in capsules], [p.centre for p in again])
    half = np.asarray(column.geometry.halfSide)
    assert len(capsules) == 4 and all(p.frame == BASE_FRAME and p.half_height == half[2] for p in capsules)
    assert capsules[0].radius == pytest.approx(np.hypot(half[0] / 2, half[1] / 2))
    # points of the box (corners, faces, inside), in the base frame, each inside some capsule
    rng = np.random.default_rng(0)
    local = rng.uniform(-1, 1, (4000, 3)) * half
    local[:8] = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * half
    axis = rng.integers(0, 3, 992)  # points on the faces: one coordinate at its bound
    local[np.arange(8, 1000), axis] = np.sign(local[np.arange(8, 1000), axis]) * half[axis]
    points = local @ placement.rotation.T + placement.translation
    centres = np.array([p.centre for p in capsules])
    d = points[:, None, :] - centres[None]
    dz = d[..., 2] - np.clip(d[..., 2], -half[2], half[2])
    inside = np.sqrt(d[..., 0] ** 2 + d[..., 1] ** 2 + dz**2) <= capsules[0].radius + 1e-9
    assert inside.any(axis=1).all()
    # the old cover, one sphere chain around the box, reaches farther from its faces
    corners = local[:8] @ placement.rotation.T + placement.translation
    _, old_radius = spheres_of_capsule(*capsule_of(corners))
    assert capsules[0].radius < 0.5 * old_radius
    assert upright_box_capsules(coal.Sphere(0.1), placement, "x") is None
    tilted = pin.SE3(pin.rpy.rpyToMatrix(0.3, 0.0, 0.0), np.zeros(3))
    assert upright_box_capsules(column.geometry, tilted, "x") is None
