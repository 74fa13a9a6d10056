"""Static bodies read from a URDF or an MJCF file (a task's ``scene_file:``), and the task's scene
fields: shapes, poses (MuJoCo's recentred meshes put back in their file's frame), errors."""

from __future__ import annotations

import struct
from pathlib import Path

import mujoco
import numpy as np
import pytest
import yaml

from forte.exceptions import InvalidInputError, TaskFileError
from forte.model.scene import Box, Capsule, Cylinder, Mesh, Sphere, mesh_vertices, pose_matrix
from forte.model.scene_files import read_scene_file

URDF = """<?xml version="1.0"?>
<robot name="room">
  <link name="world"/>
  <link name="table">
    <collision><origin xyz="1.2 0 0.36" rpy="0 0 0.3"/><geometry><box size="0.6 0.9 0.72"/></geometry></collision>
  </link>
  <joint name="table_fixed" type="fixed"><parent link="world"/><child link="table"/></joint>
  <link name="post">
    <collision><origin xyz="0 0 0.9"/><geometry><cylinder radius="0.05" length="1.8"/></geometry></collision>
    <collision><origin xyz="0 0 1.9"/><geometry><sphere radius="0.1"/></geometry></collision>
  </link>
  <joint name="post_fixed" type="fixed"><parent link="world"/><child link="post"/><origin xyz="0.6 0.5 0"/></joint>
</robot>
"""

MJCF = """<mujoco>
  <asset><mesh name="wedge" file="wedge.stl" scale="1 1 2"/></asset>
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1"/>
    <body name="shelf" pos="2 1 0" euler="0 0 30">
      <geom name="board" type="box" size="0.2 0.35 0.015" pos="0 0 0.8"/>
      <geom name="rail" type="capsule" size="0.02 0.3" pos="0 0 1.2" euler="90 0 0"/>
      <geom name="look" type="sphere" size="0.05" pos="0 0 2" contype="0" conaffinity="0"/>
      <geom name="wedge" type="mesh" mesh="wedge" pos="0.1 -0.2 0.3"/>
    </body>
    <body name="cart" pos="0 -2 0">
      <joint type="slide" axis="1 0 0"/><geom name="cartbox" type="box" size="0.1 0.1 0.1"/>
    </body>
  </worldbody>
</mujoco>
"""


def _write_stl(path: Path) -> None:
    """A tetrahedron away from its file frame's origin (MuJoCo recentres it), binary STL."""
    tris = np.array([[[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 0, 0], [0, 1, 0], [0, 0, 1]],
                     [[0, 0, 0], [0, 0, 1], [1, 0, 0]], [[1, 0, 0], [0, 1, 0], [0, 0, 1]]], float) * 0.4 + [0.3, 0.1, 0]
    with path.open("wb") as fh:
        fh.write(b"\0" * 80 + struct.pack("<I", len(tris)))
        for tri in tris:
            fh.write(struct.pack("<3f", 0, 0, 0) + b"".join(struct.pack("<3f", *v) for v in tri) + b"\0\0")


def test_urdf_collision_elements_become_bodies_at_their_placements(tmp_path):
    path = tmp_path / "room.urdf"
    path.write_text(URDF)
    bodies = {o.name: o for o in read_scene_file(path)}
    assert bodies["table_0"].shape == Box((0.6, 0.9, 0.72))
    assert bodies["table_0"].pose == pytest.approx(pose_matrix([1.2, 0, 0.36, 0, 0, 0.3]))
    assert bodies["post_0"].shape == Cylinder(0.05, 1.8)
    assert bodies["post_0"].pose[:3, 3] == pytest.approx([0.6, 0.5, 0.9])
    assert bodies["post_1"].shape == Sphere(0.1)


def test_mjcf_world_geoms_become_bodies_and_meshes_keep_their_file_frame(tmp_path):
    _write_stl(tmp_path / "wedge.stl")
    path = tmp_path / "room.xml"
    path.write_text(MJCF)
    bodies = {o.name: o for o in read_scene_file(path)}
    assert set(bodies) == {"board", "rail", "wedge"}  # no plane, no visual geom, no moving body
    assert bodies["board"].shape == Box(pytest.approx((0.4, 0.7, 0.03)))
    assert bodies["rail"].shape == Capsule(pytest.approx(0.02), pytest.approx(0.6))
    wedge = bodies["wedge"]
    assert isinstance(wedge.shape, Mesh) and wedge.shape.scale == (1.0, 1.0, 2.0)
    model = mujoco.MjModel.from_xml_path(str(path))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    g = model.geom("wedge").id
    mesh = model.geom_dataid[g]
    compiled = model.mesh_vert[model.mesh_vertadr[mesh]:model.mesh_vertadr[mesh] + model.mesh_vertnum[mesh]]
    theirs = compiled @ data.geom_xmat[g].reshape(3, 3).T + data.geom_xpos[g]
    ours = mesh_vertices(wedge.shape) @ wedge.pose[:3, :3].T + wedge.pose[:3, 3]
    assert np.linalg.norm(theirs[:, None] - ours[None], axis=2).min(axis=1).max() < 1e-6


def test_a_scene_file_adds_to_the_task_scene_and_bad_files_name_the_field(tmp_path):
    from forte.planning.tasks.tasks import task_from_dict

    (tmp_path / "room.urdf").write_text(URDF)
    task = {"path": {"kind": "waypoints", "relative": True, "samples": 5,
                     "waypoints": [{"t": 0, "position": [0, 0, 0]}, {"t": 2, "position": [0.1, 0, 0]}]},
            "payload": {"mass": 1.0}, "scene_file": "room.urdf",
            "scene": [{"name": "ball", "sphere": {"radius": 0.1}, "pose": [3, 0, 1, 0, 0, 0]}]}
    loaded = task_from_dict(task, tmp_path / "task.yaml")
    assert sorted(loaded.scene.names) == ["ball", "post_0", "post_1", "table_0"]
    for value, expected in (("nope.urdf", "scene_file: no such file"),
                            ("task.yaml", "takes a .urdf, an MJCF .xml or a PlanningScene")):
        (tmp_path / "task.yaml").write_text(yaml.safe_dump(task))
        with pytest.raises(TaskFileError, match=expected):
            task_from_dict(task | {"scene_file": value}, tmp_path / "task.yaml")
    (tmp_path / "broken.urdf").write_text("<robot")
    with pytest.raises(TaskFileError, match="scene_file: broken.urdf: cannot read it as a URDF"):
        task_from_dict(task | {"scene_file": "broken.urdf"}, tmp_path / "task.yaml")


def test_a_mesh_entry_is_read_once_and_relative_to_the_task_file(tmp_path):
    from forte.planning.tasks.tasks import task_from_dict

    _write_stl(tmp_path / "wedge.stl")
    task = {"path": {"kind": "waypoints", "relative": True, "samples": 5,
                     "waypoints": [{"t": 0, "position": [0, 0, 0]}, {"t": 2, "position": [0.1, 0, 0]}]},
            "payload": {"mass": 1.0},
            "scene": [{"name": "wedge", "mesh": {"file": "wedge.stl", "scale": [1, 1, 2]}, "pose": [3, 0, 0, 0, 0, 0]}]}
    loaded = task_from_dict(task, tmp_path / "task.yaml")
    body = loaded.scene.objects[0]
    assert body.shape.file == (tmp_path / "wedge.stl").resolve()
    proxy = body.proxy()  # the mesh's box in its own axes contains every vertex
    v = mesh_vertices(body.shape) + body.pose[:3, 3]
    from forte.model.scene import proxy_distance

    assert proxy_distance(proxy, v).max() <= 1e-12
    with pytest.raises(InvalidInputError, match="no such file"):
        mesh_vertices(Mesh(tmp_path / "missing.stl"))
