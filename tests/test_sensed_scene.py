"""Scenes from sensor data (issue 40): cloud files, voxels merged into boxes, depth images, the self-filter."""

from __future__ import annotations

import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from forte.exceptions import InvalidInputError
from forte.model.occupancy import (
    Intrinsics,
    Occupancy,
    box_objects,
    depth_points,
    merged_boxes,
    occupancy,
    octree,
    robot_cover_distance,
)
from forte.model.point_files import read_depth, read_points
from forte.model.robot import default_robot
from forte.model.scene import Box, Scene, SceneObject, pose_matrix

#: A box whose faces lie off the 2 cm grid's lines (0.3 voxel in), so every cell test is exact.
LO, HI, VOXEL = np.array([1.206, -0.294, 0.006]), np.array([1.706, 0.306, 0.446]), 0.02
#: A table and a box on it, and an upright camera above the robot looking along +x and down.
TRUE_SCENE = Scene((SceneObject("table", Box((0.8, 1.2, 0.05)), pose_matrix([1.3, 0.0, 0.7, 0, 0, 0])),
                    SceneObject("box", Box((0.2, 0.2, 0.3)), pose_matrix([1.2, 0.2, 0.875, 0, 0, 0]))), 0.0)
CAMERA = pose_matrix([0.3, 0.0, 1.6, -np.pi / 2 - 0.7, 0.0, -np.pi / 2])
W, H = 160, 120
K = Intrinsics(120.0, 120.0, (W - 1) / 2, (H - 1) / 2)


def box_surface(lo, hi, step, normals=False):
    """Points on the six faces of box ``[lo, hi]`` on a grid of spacing <= ``step``, edges included
    (and, with ``normals``, each point's face's outward normal)."""
    axes = [np.linspace(a, b, int(np.ceil((b - a) / step)) + 1) for a, b in zip(lo, hi, strict=True)]
    out, normal = [], []
    for k in range(3):
        i, j = [a for a in range(3) if a != k]
        u, v = np.meshgrid(axes[i], axes[j], indexing="ij")
        for sign, side in ((-1.0, lo[k]), (1.0, hi[k])):
            face = np.empty((u.size, 3))
            face[:, i], face[:, j], face[:, k] = u.ravel(), v.ravel(), side
            out.append(face)
            normal.append(np.tile(sign * np.eye(3)[k], (len(face), 1)))
    return (np.vstack(out), np.vstack(normal)) if normals else np.vstack(out)


def union_grid(boxes, shape):
    grid = np.zeros(shape, dtype=bool)
    for x0, y0, z0, x1, y1, z1 in boxes:
        assert not grid[x0:x1, y0:y1, z0:z1].any()  # disjoint
        grid[x0:x1, y0:y1, z0:z1] = True
    return grid


def test_the_readers_agree_on_one_cloud_in_every_format(tmp_path):
    rng = np.random.default_rng(1)
    points = rng.uniform(-2, 2, (57, 3)).astype(np.float32)
    np.save(tmp_path / "c.npy", points.astype(float))
    rows = "".join(f"{x} {y} {z} 7\n" for x, y, z in points)
    (tmp_path / "a.ply").write_text("ply\nformat ascii 1.0\ncomment hi\nelement vertex 57\nproperty float x\n"
                                    "property float y\nproperty float z\nproperty uchar intensity\n"
                                    f"element face 1\nproperty list uchar int vertex_indices\nend_header\n{rows}"
                                    "3 0 1 2\n")
    head = (b"ply\nformat binary_little_endian 1.0\nelement vertex 57\nproperty double t\nproperty float x\n"
            b"property float y\nproperty float z\nend_header\n")
    body = b"".join(struct.pack("<dfff", 0.5, *p) for p in points)
    (tmp_path / "b.ply").write_bytes(head + body)
    pcd = "VERSION .7\nFIELDS x y z rgb\nSIZE 4 4 4 4\nTYPE F F F U\nCOUNT 1 1 1 1\nWIDTH 57\nHEIGHT 1\n" \
          "VIEWPOINT 0 0 0 1 0 0 0\nPOINTS 57\n"
    (tmp_path / "a.pcd").write_text(pcd + "DATA ascii\n" + rows)
    (tmp_path / "b.pcd").write_bytes((pcd + "DATA binary\n").encode()
                                     + b"".join(struct.pack("<fffI", *p, 9) for p in points))
    for name in ("c.npy", "a.ply", "b.ply", "a.pcd", "b.pcd"):
        assert read_points(tmp_path / name) == pytest.approx(points.astype(float), abs=1e-6), name


@pytest.mark.parametrize(("content", "expected"), [
    (None, "no such file"), ("ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\n"
                             "property float z\nend_header\n", "no points"),
    ("ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\n"
     "end_header\n0 0 0\n1 nan 1\n", "NaN"), ("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                                              "property float y\nproperty float z\nend_header\n0 0 0\n", "ends before"),
    ("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n0\n", "no x, y and z"),
    ("solid x\n", "not a PLY"),
])
def test_bad_cloud_files_are_one_line_naming_the_file(tmp_path, content, expected):
    path = tmp_path / "cloud.ply"
    if content is not None:
        path.write_text(content)
    with pytest.raises(InvalidInputError) as info:
        read_points(path)
    assert "cloud.ply" in str(info.value) and expected in str(info.value) and "\n" not in str(info.value)


def test_a_box_surface_cloud_occupies_exactly_the_cells_the_box_surface_meets():
    """The cells of a dense sample of the faces are the cells the surface meets (computed from
    the box's bounds alone: those meeting the closed box and not inside its open interior), and
    the merged boxes are disjoint, cover exactly those cells and stay within a voxel of the box."""
    occ = occupancy(box_surface(LO, HI, VOXEL / 4), VOXEL)
    idx = [np.arange(occ.grid.shape[a]) + occ.origin[a] for a in range(3)]
    meets = [(i * VOXEL <= HI[a]) & ((i + 1) * VOXEL > LO[a]) for a, i in enumerate(idx)]
    inner = [(i * VOXEL > LO[a]) & ((i + 1) * VOXEL <= HI[a]) for a, i in enumerate(idx)]
    expected = np.einsum("i,j,k->ijk", *meets) & ~np.einsum("i,j,k->ijk", *inner)
    assert np.array_equal(occ.grid, expected)
    boxes = merged_boxes(occ.grid)
    assert np.array_equal(union_grid(boxes, occ.grid.shape), occ.grid)
    assert len(boxes) <= 12 < occ.cells  # six faces: a few slabs, not thousands of cells
    objects = box_objects("cloud", occ, None)
    lo = np.min([o.pose[:3, 3] - np.array(o.shape.size) / 2 for o in objects], axis=0)
    hi = np.max([o.pose[:3, 3] + np.array(o.shape.size) / 2 for o in objects], axis=0)
    assert np.all((LO - VOXEL < lo) & (lo <= LO)) and np.all((HI <= hi) & (hi < HI + VOXEL))


def test_the_merged_boxes_and_coals_octree_give_the_same_distances():
    """coal's distance from a sphere to the merged boxes (the minimum over them) equals its distance
    to an OcTree of the same cells, and is within a voxel's diagonal of the distance to the true box."""
    import coal

    rng = np.random.default_rng(2)
    occ = occupancy(box_surface(LO, HI, VOXEL / 4) + rng.normal(0, 0.003, (1, 3)), VOXEL)
    tree, objects = octree(occ), box_objects("c", occ, None)
    assert len(tree.toBoxes()) == occ.cells
    truth = coal.Box(*(HI - LO))
    sphere, request = coal.Sphere(0.05), coal.DistanceRequest()
    for centre in rng.uniform(LO - 0.4, HI + 0.4, (30, 3)):
        if np.all((centre > LO - 0.06) & (centre < HI + 0.06)):
            continue
        at = coal.Transform3s(np.eye(3), centre)
        to_boxes = min(coal.distance(sphere, at, o.collision_geometry(), coal.Transform3s(np.eye(3), o.pose[:3, 3]),
                                     request, coal.DistanceResult()) for o in objects)
        to_tree = coal.distance(sphere, at, tree, coal.Transform3s(), request, coal.DistanceResult())
        to_truth = coal.distance(sphere, at, truth, coal.Transform3s(np.eye(3), (LO + HI) / 2), request,
                                 coal.DistanceResult())
        assert to_boxes == pytest.approx(to_tree, abs=1e-9)
        assert to_truth - np.sqrt(3) * VOXEL - 0.01 <= to_boxes <= to_truth + 0.01  # the noise moved it 3 mm


def test_a_voxel_too_small_is_refused():
    with pytest.raises(InvalidInputError, match="choose a larger voxel"):
        occupancy(np.array([[0.0, 0, 0], [10.0, 10, 10]]), 0.001)


def _segment_hits_box(a, b, lo, hi):
    """Whether segment a-b meets the open box (lo, hi) (slab test)."""
    d = b - a
    with np.errstate(divide="ignore", invalid="ignore"):
        t0, t1 = (lo - a) / d, (hi - a) / d
    t0 = np.where(d == 0, np.where((a > lo) & (a < hi), -np.inf, np.inf), t0)
    t1 = np.where(d == 0, np.where((a > lo) & (a < hi), np.inf, -np.inf), t1)
    enter, leave = np.max(np.minimum(t0, t1)), np.min(np.maximum(t0, t1))
    return enter < leave and leave > 0 and enter < 1


def test_a_depth_image_of_a_known_scene_reproduces_it_within_a_voxel():
    """Ray-cast depth (MuJoCo) of a table and a box, back-projected: every point lies on the true
    bodies or the floor, every occupied cell is within a voxel's diagonal of a true body, and every
    point of the true surfaces the camera sees (line of sight by a slab test; at 60 degrees or less
    from the face's normal: at a glancing angle the pixels' footprint on the face outgrows a voxel)
    is within a voxel of the merged boxes."""
    from forte.execution.depth_camera import ray_depth

    depth = ray_depth(TRUE_SCENE, CAMERA, K, W, H)
    points = depth_points(depth, K, 10.0, CAMERA)
    assert len(points) == W * H  # the floor behind everything: every ray returns
    on_bodies = np.abs(TRUE_SCENE.distance(points)).min(axis=1) < 1e-6
    assert np.all(on_bodies | (np.abs(points[:, 2]) < 1e-6))
    occ = occupancy(points[points[:, 2] >= VOXEL], VOXEL)
    assert np.all(TRUE_SCENE.distance(occ.centres()).min(axis=1) <= np.sqrt(3) / 2 * VOXEL + 1e-9)
    objects = box_objects("camera", occ)
    sensed = Scene(objects, 0.0)
    boxes = [(o.pose[:3, 3] - np.array(o.shape.size) / 2, o.pose[:3, 3] + np.array(o.shape.size) / 2)
             for o in TRUE_SCENE.objects]
    faces = [box_surface(lo, hi, 0.01, normals=True) for lo, hi in boxes]
    truth, normal = np.vstack([f[0] for f in faces]), np.vstack([f[1] for f in faces])
    seen = []
    for p, n in zip(truth, normal, strict=True):
        c = np.linalg.inv(CAMERA)[:3] @ np.r_[p, 1]
        u, v = K.fx * c[0] / c[2] + K.cx, K.fy * c[1] / c[2] + K.cy
        ray = (p - CAMERA[:3, 3]) / np.linalg.norm(p - CAMERA[:3, 3])
        if (c[2] > 0 and 0 <= u <= W - 1 and 0 <= v <= H - 1 and -ray @ n >= 0.5
                and not any(_segment_hits_box(CAMERA[:3, 3], p - 0.002 * (p - CAMERA[:3, 3]), lo - 1e-6, hi + 1e-6)
                            for lo, hi in boxes)):
            seen.append(p)
    seen = np.array(seen)
    assert len(seen) > 1000
    assert sensed.distance(seen).min(axis=1).max() <= VOXEL
    assert len(objects) < occ.cells / 5  # merging pays


def test_mujocos_renderer_and_the_ray_cast_give_the_same_depth():
    import os

    from forte.exceptions import SimulationError
    from forte.execution.depth_camera import ray_depth, render_depth

    if os.environ.get("MUJOCO_GL") not in ("egl", "osmesa"):
        pytest.skip("MUJOCO_GL is not egl or osmesa: no off-screen OpenGL")
    try:
        rendered = render_depth(TRUE_SCENE, CAMERA, K, W, H)
    except SimulationError as exc:
        pytest.skip(str(exc))
    assert rendered == pytest.approx(ray_depth(TRUE_SCENE, CAMERA, K, W, H), abs=1e-4)


def test_the_robots_own_points_are_filtered_out():
    """Points on the arm's collision meshes, the fingers, the base box and the payload at the capture
    configuration are removed (they lie inside the cover); a table's points 10 cm away stay."""
    import coal

    from forte.model.body_spheres import _vertices
    from forte.model.clearance import ClearanceChecker

    robot = default_robot()
    q = np.r_[0.4, -0.2, 0.5, robot.home_arm]
    checker = ClearanceChecker(robot, Scene((), None))
    placements = checker.placements(q)
    own = []
    for part, T in zip(checker.parts, placements, strict=True):
        g = part.geometry
        if isinstance(g, coal.Sphere):  # the payload: points on its sphere
            directions = np.random.default_rng(3).normal(size=(200, 3))
            local = g.radius * directions / np.linalg.norm(directions, axis=1, keepdims=True)
        else:  # a hull's points, a box's corners
            local = np.asarray(g.points()) if hasattr(g, "points") else _vertices(g)
        own.append(local @ T[:3, :3].T + T[:3, 3])
    assert robot_cover_distance(np.vstack(own), robot, q).max() <= 1e-9
    table = box_surface(np.array([1.6, -0.5, 0.6]), np.array([2.2, 0.5, 0.65]), 0.01)
    assert robot_cover_distance(table, robot, q).min() > 0.1


def _task(tmp_path, entry, clearance=None):
    task = {"name": "sensed", "path": {"relative": True, "samples": 5, "waypoints": [
        {"t": 0.0, "position": [0.0, 0.0, 0.0]}, {"t": 1.0, "position": [0.05, 0.0, 0.0]}]},
        "payload": {"mass": 1.0}, "scene": [entry]}
    path = tmp_path / "task.yaml"
    path.write_text(yaml.safe_dump(task))
    return path


def test_a_depth_png_entry_and_the_self_filter_in_a_task_file(tmp_path):
    from PIL import Image

    from forte.execution.depth_camera import ray_depth
    from forte.planning.tasks.tasks import load_task

    robot = default_robot()
    q = np.r_[0.0, 0.0, 0.0, robot.home_arm]
    scene = Scene((*TRUE_SCENE.objects,), 0.0)
    depth = ray_depth(scene, CAMERA, K, W, H)
    Image.fromarray(np.round(depth * 1000).astype(np.uint16)).save(tmp_path / "depth.png")
    assert read_depth(tmp_path / "depth.png") == pytest.approx(np.round(depth * 1000))
    entry = {"name": "camera", "pose": [0.3, 0.0, 1.6, -np.pi / 2 - 0.7, 0.0, -np.pi / 2],
             "depth_image": {"file": "depth.png", "intrinsics": dict(K._asdict()), "voxel": VOXEL}}
    task = load_task(_task(tmp_path, entry))
    assert task.scene.names[0] == "camera/0" and task.scene.floor == 0.0
    sensed = np.array([o.pose[:3, 3] for o in task.scene.objects])
    assert TRUE_SCENE.distance(sensed).min(axis=1).max() < 0.3  # boxes of the table and the box, no floor
    # the scene's points lie beyond the padding from the robot at the start: the self-filter keeps them
    own = robot_cover_distance(depth_points(depth, K, 10.0, CAMERA), robot, q)
    assert (own > 0.03).all()
    np.save(tmp_path / "cloud.npy", np.vstack([box_surface(LO, HI, 0.005), _arm_points(robot, q)]))
    with_arm = load_task(_task(tmp_path, {"name": "c", "pose": [0] * 6, "point_cloud": {"file": "cloud.npy"}}))
    filtered = load_task(_task(tmp_path, {"name": "c", "pose": [0] * 6, "point_cloud": {"file": "cloud.npy"},
                                          "capture_configuration": q.tolist()}))
    near = [o for o in with_arm.scene.objects if robot_cover_distance(o.pose[None, :3, 3], robot, q)[0] < 0.1]
    assert near and all(robot_cover_distance(o.pose[None, :3, 3], robot, q)[0] > 0.3 for o in filtered.scene.objects)


def _arm_points(robot, q):
    from forte.model.clearance import ClearanceChecker

    checker = ClearanceChecker(robot, Scene((), None))
    T = checker.placements(q)
    return np.vstack([np.asarray(p.geometry.points()) @ t[:3, :3].T + t[:3, 3]
                      for p, t in zip(checker.parts, T, strict=True) if hasattr(p.geometry, "points")])


@pytest.mark.parametrize(("entry", "field"), [
    ({"point_cloud": {"file": "missing.ply"}}, "scene[0].point_cloud.file: "),
    ({"point_cloud": {"file": "nan.npy"}}, "scene[0].point_cloud.file: nan.npy: 1 of 3 points are NaN"),
    ({"point_cloud": {"file": "empty.npy"}}, "scene[0].point_cloud.file: empty.npy: "),
    ({"point_cloud": {"file": "ok.npy", "voxel": 0.0001}}, "scene[0].point_cloud.voxel: ok.npy: "),
    ({"point_cloud": {"file": "ok.npy", "voxel": -1}}, "scene[0].point_cloud.voxel: expected a number > 0"),
    ({"depth_image": {"file": "ok.npy"}}, "scene[0].depth_image.intrinsics: expected {fx, fy, cx, cy}"),
    ({"box": {"size": [1, 1, 1]}, "capture_configuration": [0] * 10}, "scene[0].capture_configuration: belongs"),
    ({"point_cloud": {"file": "ok.npy"}, "capture_configuration": [0, 0]}, "scene[0].capture_configuration: "),
    ({"point_cloud": {"file": "ok.npy", "merge": "rough"}}, "scene[0].point_cloud.merge: expected exact or {slack"),
    ({"depth_image": {"file": "ok.npy", "merge": {"slack": -1}}}, "scene[0].depth_image.merge.slack: expected a "
                                                                   "number >= 0"),
    ({"point_cloud": {"file": "ok.npy", "merge": {"max_boxes": 0}}}, "scene[0].point_cloud.merge.max_boxes: "),
])
def test_bad_sensed_entries_exit_2_with_one_line(tmp_path, entry, field):
    np.save(tmp_path / "nan.npy", np.array([[1.0, 1, 1], [np.nan, 0, 0], [2, 2, 2]]))
    np.save(tmp_path / "empty.npy", np.zeros((0, 3)))
    np.save(tmp_path / "ok.npy", np.array([[2.0, 2, 0.5], [12.0, 2, 3]]))
    path = _task(tmp_path, {"name": "s", "pose": [0] * 6, **entry})
    forte_cli = str(Path(sys.executable).parent / "forte")
    proc = subprocess.run([forte_cli, "plan", str(path), "--out", str(tmp_path / "o")], capture_output=True,
                          text=True, check=False)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and field in lines[0], proc.stderr
    assert not (tmp_path / "o").exists()


def test_an_occupancy_knows_its_cells():
    occ = Occupancy(0.1, np.array([-1, 0, 2]), np.zeros((2, 2, 2), dtype=bool))
    occ.grid[1, 0, 1] = True
    assert occ.occupied(np.array([[0.05, 0.05, 0.35], [-0.05, 0.05, 0.35], [5.0, 5, 5]])).tolist() == [True, False,
                                                                                                    False]
    assert occ.centres() == pytest.approx(np.array([[0.05, 0.05, 0.35]]))


def test_the_k_d_tree_broad_phase_equals_the_dense_one():
    """Past SPHERE_CULL_BODIES small bodies, pair_distances finds near pairs in a k-d tree: the same
    distances below the cutoff as measuring every pair, and never more than the true distance."""
    from forte.model.body_spheres import primitive_centres, robot_primitives
    from forte.planning.nlp.collision_slots import SPHERE_CULL_BODIES, body_proxies, pair_distances

    robot = default_robot()
    primitives = robot_primitives(robot)
    rng = np.random.default_rng(4)
    cells = rng.uniform([0.3, -0.6, 0.05], [1.2, 0.6, 1.2], (400, 3))
    occ = occupancy(cells, 0.05)
    scene = Scene((*box_objects("c", occ, None), SceneObject("tilted", Box((0.2, 0.3, 0.4)),
                                                       pose_matrix([1.0, 0.5, 0.5, 0.3, 0, 0.7]))), 0.0)
    assert len(scene.objects) > SPHERE_CULL_BODIES
    q = np.array([np.r_[x, 0.2 * x, 0.3 * x, robot.home_arm] for x in np.linspace(-0.5, 0.5, 6)])
    centres = np.stack([primitive_centres(robot, qk, primitives) for qk in q])
    proxies = body_proxies(scene)
    full = pair_distances(centres, primitives, proxies)
    for cutoff in (0.05, 0.3):
        culled = pair_distances(centres, primitives, proxies, cutoff)
        near = full < cutoff
        assert near.any() and np.array_equal(culled < cutoff, near)
        assert culled[near] == pytest.approx(full[near], abs=1e-12)
        assert np.all(culled <= full + 1e-12)


def _noisy_crate(voxel, sigma=0.01):
    points = box_surface(LO, HI, voxel / 3)
    return occupancy(points + np.random.default_rng(5).normal(0, sigma, points.shape), voxel)


def _cells_of(boxes, shape):
    """How many boxes hold each cell (an int grid)."""
    grid = np.zeros(shape, dtype=int)
    for x0, y0, z0, x1, y1, z1 in boxes:
        grid[x0:x1, y0:y1, z0:z1] += 1
    return grid


@pytest.mark.parametrize("voxel", [0.02, 0.01])
def test_the_cover_holds_every_occupied_cell_and_no_point_beyond_its_excess(voxel):
    """The coarse cover of a noisy cloud: every occupied voxel centre lies in exactly one box; every
    box cell centre is within the reported excess of an occupied centre (a k-d tree, not the distance
    transform); random points of the boxes are within it of the occupied cubes (the exact boxes'
    distance: their union is the cells); the excess is within the slack, far fewer boxes than the
    exact merge's, and the free volume added is what the boxes hold beyond the cells."""
    from scipy.spatial import cKDTree

    from forte.model.occupancy import sensed_boxes
    from forte.model.occupancy_cover import CoverSettings

    occ = _noisy_crate(voxel)
    made = sensed_boxes(occ, CoverSettings(0.04, 10_000))
    held = _cells_of(made.boxes, occ.grid.shape)
    assert held.max() == 1 and np.all(held[occ.grid] == 1)  # disjoint, every occupied cell in one box
    inside = np.argwhere(held > 0)
    far, _ = cKDTree(np.argwhere(occ.grid)).query(inside)
    assert far.max() * voxel == pytest.approx(made.excess) and 0 < made.excess <= 0.04
    assert made.free_cells == len(inside) - occ.cells > 0
    exact = Scene(box_objects("e", occ, None), None)
    rng = np.random.default_rng(6)
    for x0, y0, z0, x1, y1, z1 in made.boxes[:: max(1, len(made.boxes) // 40)]:
        lo, hi = (np.array([x0, y0, z0]) + occ.origin) * voxel, (np.array([x1, y1, z1]) + occ.origin) * voxel
        points = rng.uniform(lo, hi, (50, 3))
        assert exact.distance(points).min(axis=1).max() <= made.excess + 1e-9
    assert len(made.boxes) < len(exact.objects) / 5


def test_the_cover_of_a_noisy_cloud_stays_under_its_budget_and_is_exact_at_zero_slack():
    """A budget smaller than the slack needs is kept (the excess grows instead, and still bounds
    every box); slack 0 gives boxes whose union is exactly the occupied cells."""
    from forte.model.occupancy import sensed_boxes
    from forte.model.occupancy_cover import CoverSettings

    occ = _noisy_crate(0.02)
    loose = sensed_boxes(occ, CoverSettings(0.04, 10_000))
    tight = sensed_boxes(occ, CoverSettings(0.04, 12))
    assert len(loose.boxes) > 12 >= len(tight.boxes) and tight.excess > loose.excess
    held = _cells_of(tight.boxes, occ.grid.shape)
    assert np.all(held[occ.grid] == 1)
    zero = sensed_boxes(occ, CoverSettings(0.0, 10_000))
    assert zero.excess == 0 and zero.free_cells == 0
    assert np.array_equal(_cells_of(zero.boxes, occ.grid.shape), occ.grid.astype(int))


def test_the_cover_of_a_noisy_wall_leaves_its_doorway_open():
    """A 3 m x 2.2 m wall (1 cm noise) with a 0.9 m x 2 m doorway, at 2 cm voxels: a few dozen boxes
    (the exact merge: ten times as many or more), and none reaches into the doorway farther than
    the excess (points of the opening more than that from the door frame are outside every box)."""
    from forte.model.occupancy import sensed_boxes

    y, z = np.meshgrid(np.arange(-1.5, 1.5, 0.007), np.arange(0.0, 2.2, 0.007))
    door = (np.abs(y) < 0.45) & (z < 2.0)
    wall = np.column_stack([np.full(np.count_nonzero(~door), 2.0), y[~door], z[~door]])
    occ = occupancy(wall + np.random.default_rng(8).normal(0, 0.01, wall.shape), VOXEL)
    made = sensed_boxes(occ)
    assert len(made.boxes) <= 40 and 10 * len(made.boxes) < len(merged_boxes(occ.grid))
    assert made.excess <= 0.04 + 1e-9
    boxes = Scene(box_objects("w", occ, None), None)  # the exact cells: the distance to the door frame
    lo, hi = (made.boxes[:, :3] + occ.origin) * VOXEL, (made.boxes[:, 3:] + occ.origin) * VOXEL
    yy, zz = np.meshgrid(np.linspace(-0.45, 0.45, 46), np.linspace(0.05, 1.95, 96))
    opening = np.column_stack([np.full(yy.size, 2.0), yy.ravel(), zz.ravel()])
    far = opening[boxes.distance(opening).min(axis=1) > made.excess + 1e-9]
    assert len(far) > 0.5 * len(opening)
    assert not np.any(np.all((far[:, None] >= lo) & (far[:, None] <= hi), axis=2))


def test_the_cut_scores_bounding_volumes_are_the_brute_force_ones():
    """_prefix_volumes: the volume of the bounding box of the occupied cells of each prefix of slices."""
    from forte.model.occupancy_cover import _prefix_volumes

    rng = np.random.default_rng(7)
    slab = rng.random((9, 6, 7)) < 0.08
    slab[0, 2, 3] = True
    expected = []
    for k in range(9):
        cells = np.argwhere(slab[:k + 1])
        expected.append(int(np.prod(cells.max(axis=0) - cells.min(axis=0) + 1)) if len(cells) else 0)
    assert _prefix_volumes(slab).tolist() == expected


def test_a_task_entry_chooses_the_exact_merge_or_the_cover(tmp_path):
    from forte.planning.tasks.tasks import load_task

    occ = _noisy_crate(0.02)
    np.save(tmp_path / "noisy.npy", occ.centres())
    entry = {"name": "c", "pose": [0] * 6, "point_cloud": {"file": "noisy.npy"}}
    default = load_task(_task(tmp_path, entry)).scene.objects
    exact = load_task(_task(tmp_path, {**entry, "point_cloud": {"file": "noisy.npy", "merge": "exact"}})).scene.objects
    small = load_task(_task(tmp_path, {**entry, "point_cloud": {"file": "noisy.npy",
                                                              "merge": {"slack": 0.1, "max_boxes": 5}}})).scene.objects
    assert len(small) <= 5 < len(default) <= 128 < len(exact)
    volume = [sum(np.prod(o.shape.size) for o in objects) for objects in (exact, default, small)]
    above = occ.centres()[occ.centres()[:, 2] >= 0.02]  # the floor's points are dropped
    assert volume[0] == pytest.approx(len(above) * 0.02**3) and volume[0] < volume[1] < volume[2]


def test_a_second_scan_carves_what_its_rays_see_through():
    """The table and the box seen by the camera, then the table alone (the box taken away): fusing
    the second scan into the first clears the box's cells its rays pass through (all but those
    within two voxels of the table top, where the rays end, and a few a ray only clips), keeps
    every cell of the second scan, adds none the scans did not hold, and every cleared cell is
    pierced by a ray of the second scan short of its point by a voxel (a slab test per cell)."""
    from forte.execution.depth_camera import ray_depth
    from forte.model.occupancy import fused

    def scan(scene):
        return depth_points(ray_depth(scene, CAMERA, K, W, H), K, 10.0, CAMERA)

    first, rays = scan(TRUE_SCENE), scan(Scene(TRUE_SCENE.objects[:1], 0.0))
    first, second = first[first[:, 2] >= VOXEL], rays[rays[:, 2] >= VOXEL]  # the floor's points: rays, no cells
    before = occupancy(first, VOXEL)
    after = fused(before, CAMERA[:3, 3], rays, VOXEL, rays[:, 2] >= VOXEL)
    assert fused(None, CAMERA[:3, 3], first, VOXEL).grid.tolist() == before.grid.tolist()
    assert after.occupied(occupancy(second, VOXEL).centres()).all()
    assert (before.occupied(after.centres()) | occupancy(second, VOXEL).occupied(after.centres())).all()
    box = TRUE_SCENE.objects[1]
    lo, hi = box.pose[:3, 3] - np.array(box.shape.size) / 2, box.pose[:3, 3] + np.array(box.shape.size) / 2
    centres = before.centres()
    on_box = np.all((centres > lo - VOXEL) & (centres < hi + VOXEL), axis=1) & (centres[:, 2] > lo[2] + 2 * VOXEL)
    assert on_box.sum() > 100
    cleared_on_box = ~after.occupied(centres[on_box])
    assert cleared_on_box.mean() > 0.95
    cleared = centres[~after.occupied(centres) & ~occupancy(second, VOXEL).occupied(centres)]
    assert len(cleared) >= on_box.sum() * 0.95
    origin = CAMERA[:3, 3]
    d = rays - origin
    length = np.linalg.norm(d, axis=1)
    end = origin + d * ((length - VOXEL) / length)[:, None]
    for c in cleared:
        assert any(_segment_hits_box(origin, e, c - VOXEL / 2, c + VOXEL / 2) for e in end[_near(origin, end, c)])


def _near(origin, end, c):
    """The rays (origin to each end) passing within a voxel's diagonal of ``c`` (a cheap pre-filter)."""
    d = end - origin
    t = np.clip(((c - origin) @ d.T) / np.einsum("ij,ij->i", d, d), 0, 1)
    return np.linalg.norm(origin + t[:, None] * d - c, axis=1) <= np.sqrt(3) * VOXEL


def _crate_task(tmp_path, scene):
    return {"name": "sensed-crate", "path": {"kind": "waypoints", "relative": True, "samples": 41, "waypoints": [
        {"t": 0.0, "position": [0.0, 0.0, 0.0]}, {"t": 8.0, "position": [2.4, 0.0, 0.0]}]},
        "payload": {"mass": 1.0}, "scene": scene}


@pytest.mark.slow
def test_a_cloud_of_a_crate_and_the_crate_give_plans_of_the_same_clearance_within_a_voxel(tmp_path):
    """The crate of test_scene_planning as a box and as a cloud sampled on its faces (and with 1 cm
    noise): every plan keeps the clearance from the true crate (coal, between waypoints too), the
    clean cloud's plan within a voxel of the box's, and it runs in MuJoCo without a touch. The noisy
    cloud's coarse cover (the default merge) is a few dozen boxes, not the exact merge's hundreds;
    its plan keeps the clearance from the truth, exceeds the box's by no more than what the cover
    may add (its excess, a voxel's diagonal, 5 sigma of noise), and runs without a touch too."""
    import forte
    from forte.model.clearance import clearances
    from forte.model.occupancy import sensed_boxes
    from forte.planning.tasks.tasks import task_from_dict
    from forte.planning.verdict.motion_samples import sample_motion

    lo, hi = np.array([1.25, -0.3, 0.0]), np.array([1.75, 0.3, 0.45])
    crate = Scene((SceneObject("crate", Box(tuple(hi - lo)), pose_matrix([*(lo + hi) / 2, 0, 0, 0])),), 0.0)
    points = box_surface(lo, hi, 0.005)
    np.save(tmp_path / "crate.npy", points)
    np.save(tmp_path / "noisy.npy", points + np.random.default_rng(0).normal(0, 0.01, points.shape))
    true_clearance = {}
    for label, entry in (("box", {"box": {"size": (hi - lo).tolist()}, "pose": [*(lo + hi) / 2, 0, 0, 0]}),
                         ("cloud", {"point_cloud": {"file": "crate.npy", "voxel": VOXEL}, "pose": [0] * 6}),
                         ("noisy", {"point_cloud": {"file": "noisy.npy", "voxel": VOXEL}, "pose": [0] * 6})):
        task = task_from_dict(_crate_task(tmp_path, [{"name": "crate", **entry}]), tmp_path / f"{label}.yaml")
        plan = forte.plan(task)
        assert plan.feasible, (label, plan.verdict)
        samples = sample_motion(plan.robot, plan.t, plan.q).q
        true_clearance[label] = float(clearances(plan.robot, crate, samples).distance.min())
        assert true_clearance[label] >= task.clearance, label
        if label != "box":
            from test_scene_planning import _simulated_without_contact

            assert len(task.scene.objects) <= (12 if label == "cloud" else 128)
            _simulated_without_contact(plan, tmp_path / label)
    assert abs(true_clearance["cloud"] - true_clearance["box"]) <= VOXEL, true_clearance
    noisy = np.load(tmp_path / "noisy.npy")
    noisy = occupancy(noisy[noisy[:, 2] >= VOXEL], VOXEL)  # the floor's points dropped, as the entry does
    assert len(sensed_boxes(noisy, None).boxes) > 300  # the exact merge's staircase
    excess = sensed_boxes(noisy).excess
    assert true_clearance["noisy"] - true_clearance["box"] <= excess + np.sqrt(3) * VOXEL + 0.05, true_clearance


def _example():
    import importlib.util

    path = Path(__file__).resolve().parents[1] / "examples" / "sensed_scene.py"
    spec = importlib.util.spec_from_file_location("sensed_scene_example", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_examples_depth_image_is_what_its_script_renders():
    example = _example()
    stored = read_depth(example.IMAGE)
    assert stored.shape == (example.HEIGHT, example.WIDTH)
    assert np.array_equal(stored, np.round(example.render() * 1000))
    text = (example.IMAGE.parent / "sensed-crate.yaml").read_text()
    entry = yaml.safe_load(text)["scene"][0]
    assert entry["pose"] == pytest.approx(example.CAMERA_POSE, abs=1e-6)
    assert entry["depth_image"]["intrinsics"] == pytest.approx(dict(example.INTRINSICS._asdict()))
    assert entry["capture_configuration"] == pytest.approx(default_robot().home().tolist(), abs=1e-3)
    from forte.planning.tasks.tasks import load_task, task_from_dict

    robot = default_robot()
    data = yaml.safe_load(text)
    del data["scene"][0]["capture_configuration"]
    unfiltered = task_from_dict(data, example.IMAGE.parent / "sensed-crate.yaml")
    filtered = load_task(example.IMAGE.parent / "sensed-crate.yaml")
    for task, arm_seen in ((unfiltered, True), (filtered, False)):
        centres = np.array([o.pose[:3, 3] for o in task.scene.objects])
        assert (robot_cover_distance(centres, robot, robot.home()).min() < 0) == arm_seen


@pytest.mark.slow
def test_the_sensed_crate_example_keeps_clear_of_the_true_scene_and_runs_without_a_touch(tmp_path):
    """examples/tasks/sensed-crate.yaml: the plan from the depth image keeps the clearance from the
    true crate and table (coal, between waypoints too) and runs in MuJoCo, among the sensed boxes,
    without a touch; the arm the camera saw is not in the scene."""
    from test_scene_planning import _simulated_without_contact

    import forte
    from forte.model.clearance import clearances
    from forte.planning.verdict.motion_samples import sample_motion

    example = _example()
    task = forte.load_task(example.IMAGE.parent / "sensed-crate.yaml")
    robot = task.robot
    centres = np.array([o.pose[:3, 3] for o in task.scene.objects])
    assert robot_cover_distance(centres, robot, task.q_init).min() > 0.03  # the arm was filtered out
    plan = forte.plan(task)
    assert plan.feasible, plan.verdict
    samples = sample_motion(plan.robot, plan.t, plan.q).q
    assert clearances(plan.robot, example.TRUE_SCENE, samples).distance.min() >= task.clearance
    _simulated_without_contact(plan, tmp_path)
