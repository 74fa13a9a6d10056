"""The scene in MuJoCo: static bodies, robot-versus-world contacts judged as failures, the scene in
the exported MJCF and in ``forte view``."""

from __future__ import annotations

import json
import struct
from dataclasses import replace
from pathlib import Path

import mujoco
import numpy as np
import pytest

import forte.execution.run as run_module
from forte.cli.main import main
from forte.exceptions import SimulationError
from forte.execution.contact import touches
from forte.execution.model import build_sim_model
from forte.execution.run import simulate_plan
from forte.io.plandir import read_plan_dir, write_plan_dir
from forte.model.description import BASE_BOX_HALF_XY
from forte.model.robot import MobileManipulator, default_robot
from forte.model.scene import Box, Capsule, Cylinder, Mesh, Scene, SceneObject, Sphere, pose_matrix
from forte.model.scene_files import read_scene_file
from forte.planning.planner import evaluate

# The hand at home is at (0.79, 0.01, 0.98) m; turning joint 1 by +1.2 rad in 1 s sweeps it
# through (0.69, 0.31, 0.98) at 0.5 s to (0.44, 0.50, 0.98): the box below stands in that arc.
BOX_ON_ARC = SceneObject("box", Box((0.2, 0.2, 0.3)), pose_matrix([0.55, 0.55, 0.95, 0, 0, 0]))
BOX_AWAY = BOX_ON_ARC._replace(pose=pose_matrix([-2.0, 0.0, 0.95, 0, 0, 0]))


def _sweep(robot: MobileManipulator) -> tuple[list[float], list[np.ndarray]]:
    q0 = robot.home()
    q1 = q0.copy()
    q1[3] += 1.2
    return [0.0, 1.0], [q0, q1]


def _cube_stl(path: Path, half: float) -> Path:
    """A binary STL cube of half edge ``half`` centred on its origin (MuJoCo reads binary STL only)."""
    corners = np.array([[x, y, z] for x in (-half, half) for y in (-half, half) for z in (-half, half)])
    faces = [(0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1),
             (2, 3, 7), (2, 7, 6), (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3)]
    data = bytearray(80) + struct.pack("<I", len(faces))
    for f in faces:
        data += struct.pack("<3f", 0, 0, 0) + b"".join(struct.pack("<3f", *corners[i]) for i in f) + b"\0\0"
    path.write_bytes(bytes(data))
    return path


def test_arm_through_a_box_fails_naming_the_box_and_the_link(
        robot: MobileManipulator, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    plan_dir = write_plan_dir(tmp_path / "p", robot, *_sweep(robot), scene=Scene((BOX_ON_ARC,)))
    assert main(["simulate", str(plan_dir), "--hold", "0.3"]) == 1
    line = capsys.readouterr().err.strip().splitlines()[-1]
    result = json.loads((plan_dir / "sim.json").read_text())
    assert result["verdict"] == "failure" and result["reason"] == "contact" and result["contact_checked"]
    first = result["contacts"][0]
    assert first["world"] == "box" and first["robot"].startswith("panda_")
    assert 0.3 < first["first_time"] < 1.0 and result["failure_time"] == first["first_time"]
    assert first["peak_force_N"] >= first["first_force_N"] > 0
    assert all(c["world"] == "box" for c in result["contacts"])  # never the base on the floor
    assert line.startswith(f"failure at t = {first['first_time']:.3f} s: contact ({first['robot']} touched box")
    assert "N" in line and "sim.json" in line


def test_every_pair_that_touched_is_reported(
        robot: MobileManipulator, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A crate 1 cm into the back of the base from the start, the box on the hand's arc later."""
    behind = -BASE_BOX_HALF_XY[0] - 0.1 + 0.01
    crate = SceneObject("crate", Box((0.2, 0.2, 0.2)), pose_matrix([behind, 0.0, 0.1, 0, 0, 0]))
    plan_dir = write_plan_dir(tmp_path / "p", robot, *_sweep(robot), scene=Scene((crate, BOX_ON_ARC)))
    assert main(["simulate", str(plan_dir), "--hold", "0.3"]) == 1
    line = capsys.readouterr().err.strip().splitlines()[-1]
    pairs = json.loads((plan_dir / "sim.json").read_text())["contacts"]
    assert [(c["robot"], c["world"]) for c in pairs[:1]] == [("base", "crate")] and pairs[0]["first_time"] == 0.0
    assert any(c["world"] == "box" and c["robot"].startswith("panda_") for c in pairs[1:])
    assert all(c["peak_force_N"] > 0 for c in pairs)
    assert line.startswith("failure at t = 0.000 s: contact (base touched crate at t = 0.000 s")
    assert f"{len(pairs)} pairs touched: base-crate from t = 0.000 s" in line


def test_the_box_moved_away_is_never_touched(robot: MobileManipulator, tmp_path: Path) -> None:
    plan_dir = write_plan_dir(tmp_path / "p", robot, *_sweep(robot), scene=Scene((BOX_AWAY,)))
    res = simulate_plan(plan_dir, hold=0.3, write=False)
    assert res.success, res.detail
    assert res.summary["contact_checked"] and res.summary["contacts"] == []


def test_an_empty_scene_changes_nothing(robot: MobileManipulator, tmp_path: Path,
                                        monkeypatch: pytest.MonkeyPatch) -> None:
    """A plan whose base drives and turns, with an empty scene (contacts on, the floor there):
    the same numbers as the model without any contact geometry, and the base never touches the
    floor it slides on."""
    q0 = robot.home()
    q1 = robot.home((0.4, -0.2, 0.5))
    q1[4] += 0.2
    plan_dir = write_plan_dir(tmp_path / "p", robot, [0.0, 1.5], [q0, q1], mass=1.0)
    assert not read_plan_dir(plan_dir).scene
    with_contacts = simulate_plan(plan_dir, hold=0.3, write=False)

    def no_contacts(*args, **kwargs):  # the model of before: no scene, no contact geometry
        kwargs["scene"] = None
        return build_sim_model(*args, **kwargs)

    monkeypatch.setattr(run_module, "build_sim_model", no_contacts)
    without = simulate_plan(plan_dir, hold=0.3, write=False)
    assert with_contacts.summary["contact_checked"] and not without.summary["contact_checked"]
    assert with_contacts.success and with_contacts.summary["contacts"] == []
    assert with_contacts.log.keys() == without.log.keys()
    for name, column in with_contacts.log.items():
        assert np.array_equal(column, without.log[name]), name
    assert with_contacts.log["x_b"][-1] == pytest.approx(0.4, abs=0.01)


def test_contact_geometry_has_no_mass(robot: MobileManipulator) -> None:
    scene = Scene((BOX_AWAY,))
    sim = build_sim_model(robot, 1.5, armature=0.0, scene=scene)
    plain = build_sim_model(robot, 1.5, armature=0.0)
    robot_bodies = slice(1, plain.model.nbody)  # the scene's bodies come after the robot's
    assert sim.model.ngeom > plain.model.ngeom
    assert np.array_equal(sim.model.body_mass[robot_bodies], plain.model.body_mass[robot_bodies])
    assert np.array_equal(sim.model.body_inertia[robot_bodies], plain.model.body_inertia[robot_bodies])
    bare = build_sim_model(robot, armature=0.0, scene=scene)
    rng = np.random.default_rng(3)
    span = robot.upper - robot.lower
    for _ in range(10):
        q = rng.uniform(robot.lower + 0.05 * span, robot.upper - 0.05 * span)
        dq, a = rng.normal(size=robot.n_arm), 3 * rng.normal(size=robot.n_arm)
        assert np.abs(bare.inverse_dynamics(q, dq, a) - robot.rnea(q, dq, a)).max() < 1e-6


def test_which_pairs_touch(robot: MobileManipulator) -> None:
    """Arm and payload against the scene and the floor; the base against the scene, never the
    floor; nothing of the robot against itself."""
    q = robot.home()
    hand = robot.ee_position(q)
    scene = Scene((SceneObject("ball", Sphere(0.03), pose_matrix([*hand, 0, 0, 0])),
                   SceneObject("crate", Box((0.2, 0.2, 0.2)), pose_matrix([-0.3, 0.0, 0.1, 0, 0, 0]))))
    sim = build_sim_model(robot, 1.0, payload_radius=0.05, scene=scene)
    sim.set_state(q)
    found = {(t.robot, t.world) for t in touches(sim.model, sim.data, "arm/")}
    assert ("payload", "ball") in found and ("base", "crate") in found
    assert all(world != "floor" for _, world in found)  # the base box stands on the floor: no pair
    assert all(t.force >= 0 for t in touches(sim.model, sim.data, "arm/"))
    # the arm on a lower mount reaches the floor: that pair exists
    mount = np.eye(4)
    mount[:3, 3] = (0.25, 0.0, 0.15)
    low = default_robot(mount=mount)
    down = low.home().copy()
    down[3:] = [0.0, 1.76, 0.0, -1.0, 0.0, 2.9, 0.0]
    assert low.ee_position(down)[2] < 0.0
    sim = build_sim_model(low, scene=Scene())
    sim.set_state(down)
    assert {w for _, w, _ in touches(sim.model, sim.data, "arm/")} == {"floor"}


def test_every_shape_is_built_and_exported(robot: MobileManipulator, tmp_path: Path) -> None:
    """Box, cylinder, sphere, capsule and mesh in the simulation model; ``forte robot export
    --plan`` writes them into the MJCF, which reads back as the same bodies."""
    cube = _cube_stl(tmp_path / "cube.stl", 0.1)
    tilt = [0.1, -0.2, 0.7]
    scene = Scene((
        SceneObject("table", Box((0.8, 1.2, 0.75)), pose_matrix([1.5, 0.0, 0.375, *tilt])),
        SceneObject("post", Cylinder(0.05, 1.8), pose_matrix([0.6, 1.5, 0.9, 0, 0, 0])),
        SceneObject("ball", Sphere(0.1), pose_matrix([0.9, -1.4, 1.0, 0, 0, 0])),
        SceneObject("rail", Capsule(0.04, 0.6), pose_matrix([-1.0, 1.0, 0.5, 0.3, 0, 0])),
        SceneObject("crate", Mesh(cube, (1.0, 2.0, 1.0)), pose_matrix([-1.5, -1.0, 0.3, *tilt])),
    ))
    plan_dir = write_plan_dir(tmp_path / "p", robot, [0.0], [robot.home()], scene=scene)
    out = tmp_path / "robot.xml"
    assert main(["robot", "export", str(out), "--plan", str(plan_dir), "--quiet"]) == 0
    back = {o.name: o for o in read_scene_file(out)}
    assert sorted(back) == sorted(f"scene/{o.name}" for o in scene.objects)
    for obj in scene.objects:
        got = back[f"scene/{obj.name}"]
        assert type(got.shape) is type(obj.shape)
        np.testing.assert_allclose(got.pose, obj.pose, atol=2e-6)  # MJCF text: quaternions to 7 digits
        if isinstance(obj.shape, Mesh):
            assert Path(got.shape.file) == cube.resolve() and got.shape.scale == (1.0, 2.0, 1.0)
        else:
            np.testing.assert_allclose(got.shape[:], obj.shape[:], rtol=1e-12)
    sim = build_sim_model(robot, scene=scene)
    mujoco.mj_forward(sim.model, sim.data)
    for obj in scene.objects[:4]:  # primitives: the geom is the body (a mesh is recentred by MuJoCo)
        g = sim.model.geom(f"scene/{obj.name}").id
        np.testing.assert_allclose(sim.data.geom_xpos[g], obj.pose[:3, 3], atol=1e-12)
        np.testing.assert_allclose(sim.data.geom_xmat[g].reshape(3, 3), obj.pose[:3, :3], atol=1e-12)
    res = simulate_plan(plan_dir, hold=0.2, write=False)  # at home, away from every body
    assert res.success and res.summary["contacts"] == []


def test_a_mesh_mujoco_cannot_read_is_one_line(robot: MobileManipulator, tmp_path: Path) -> None:
    dae = tmp_path / "shelf.dae"
    dae.write_text("<COLLADA/>")
    scene = Scene((SceneObject("shelf", Mesh(dae), np.eye(4)),))
    with pytest.raises(SimulationError, match=r"scene body shelf: mesh shelf.dae: MuJoCo reads \.stl"):
        build_sim_model(robot, scene=scene)


def test_view_draws_the_scene(robot: MobileManipulator, tmp_path: Path) -> None:
    pytest.importorskip("rerun")
    from rerun.chunk import RrdReader

    cube = _cube_stl(tmp_path / "cube.stl", 0.1)
    scene = Scene((BOX_ON_ARC, SceneObject("rail", Capsule(0.04, 0.6), pose_matrix([-1.0, 1.0, 0.5, 0, 0, 0])),
                   SceneObject("crate", Mesh(cube), pose_matrix([-1, -1, 0.3, 0, 0, 0]))))
    plan_dir = write_plan_dir(tmp_path / "p", robot, [0.0, 0.5], [robot.home()] * 2, scene=scene)
    out = tmp_path / "scene.rrd"
    assert main(["view", str(plan_dir), "--save", str(out), "--quiet"]) == 0
    columns: dict[str, set[str]] = {}
    for chunk in RrdReader(out).stream():
        columns.setdefault(chunk.entity_path, set()).update(chunk.to_record_batch().schema.names)
    assert "Boxes3D:half_sizes" in columns["/world/scene/box/shape"]
    assert "Capsules3D:lengths" in columns["/world/scene/rail/shape"]
    assert "Mesh3D:triangle_indices" in columns["/world/scene/crate/shape"]
    assert "Transform3D:translation" in columns["/world/scene/box"]


def _area(outline: np.ndarray) -> float:
    x, y = outline.T
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def test_footprints_and_the_scene_figure(robot: MobileManipulator, tmp_path: Path) -> None:
    """The footprints seen from above (areas by hand), and scene.png beside a plan's figures."""
    from forte.io.figures import footprint, plan_figures

    yawed = SceneObject("table", Box((0.8, 1.2, 0.75)), pose_matrix([1.5, 0.2, 0.375, 0, 0, 0.6]))
    assert _area(footprint(yawed)) == pytest.approx(0.8 * 1.2, rel=1e-9)  # counter-clockwise, exact
    np.testing.assert_allclose(footprint(yawed).mean(axis=0), [1.5, 0.2], atol=1e-9)
    lying = SceneObject("rail", Capsule(0.05, 1.0), pose_matrix([0, 0, 0.5, np.pi / 2, 0, 0]))
    assert _area(footprint(lying, samples=400)) == pytest.approx(1.0 * 0.1 + np.pi * 0.05**2, rel=1e-3)
    upright = SceneObject("post", Cylinder(0.05, 1.8), pose_matrix([0.6, 1.5, 0.9, 0, 0, 0]))
    assert _area(footprint(upright, samples=400)) == pytest.approx(np.pi * 0.05**2, rel=1e-3)
    cube = SceneObject("crate", Mesh(_cube_stl(tmp_path / "cube.stl", 0.1)), pose_matrix([0, 0, 0, 0, 0, 0.3]))
    assert _area(footprint(cube)) == pytest.approx(0.04, rel=1e-6)
    for name, scene in (("p", Scene((yawed, lying, upright))), ("e", Scene())):
        plan = read_plan_dir(write_plan_dir(tmp_path / name, robot, *_sweep(robot), scene=scene))
        plan_figures(replace(plan, metrics=evaluate(robot, plan.q, plan.t, plan.force)), tmp_path / name)
        assert (tmp_path / name / "capacity.png").is_file()
    assert (tmp_path / "p" / "scene.png").stat().st_size > 10_000
    assert not (tmp_path / "e" / "scene.png").exists()
