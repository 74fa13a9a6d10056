"""Every topic of the MCAP export read back with mcap-ros2-support's decoder and checked against the plan."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections import defaultdict
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin
import pytest
import yaml

from forte.capability.polytope import trajectory_rfp
from forte.cli.main import main
from forte.io import ros_messages as ros
from forte.io.export import BASE_JOINTS, BASE_LINKS, whole_body_urdf
from forte.io.mcap_export import FORCE_SCALE, RATE_HZ, SCENE_TOPIC, TOPICS, TRAJECTORY_TOPIC, sample_times
from forte.io.plandir import read_plan_dir, write_plan, write_plan_dir
from forte.model.description import mesh_package_dirs
from forte.model.robot import default_robot
from forte.model.scene import Box, Capsule, Cylinder, Mesh, Scene, SceneObject, Sphere, pose_matrix
from forte.model.trajectory import clamped_spline
from forte.planning.planner import plan
from forte.planning.tasks.tasks import load_task

LIFT = Path(__file__).resolve().parents[1] / "examples" / "tasks" / "lift.yaml"


def _export(plan_dir: Path) -> dict[str, Any]:
    """``forte export PLAN_DIR X.mcap`` read back: every decoded message by topic, in file order."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    out = plan_dir.parent / f"{plan_dir.name}.mcap"
    assert main(["export", str(plan_dir), str(out), "--quiet"]) == 0
    topics: dict[str, list] = defaultdict(list)
    log_times = []
    with open(out, "rb") as fh:
        reader = make_reader(fh, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        for schema, channel, message, decoded in reader.iter_decoded_messages(log_time_order=False):
            assert (schema.encoding, channel.message_encoding) == ("ros2msg", "cdr")
            assert schema.name == ros.schema_name(TOPICS[channel.topic])
            topics[channel.topic].append((message.log_time, decoded))
            log_times.append(message.log_time)
        metadata = {m.name: m.metadata for m in reader.iter_metadata()}
    return {"plan": read_plan_dir(plan_dir), "topics": topics, "log_times": log_times, "summary": summary,
            "metadata": metadata, "path": out}


@pytest.fixture(scope="module")
def bag(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """The lift at 12 waypoints (quintic: fast, with a force), exported and read back."""
    root = tmp_path_factory.mktemp("mcap")
    return _export(write_plan(plan(load_task(LIFT, waypoints=12), "quintic"), root / "lift", figures=False))


def _seconds(stamp: Any) -> float:
    return stamp.sec + 1e-9 * stamp.nanosec


def _matrix(tf: Any) -> np.ndarray:
    r, p = tf.rotation, tf.translation
    T = np.eye(4)
    T[:3, :3] = pin.Quaternion(np.array([r.x, r.y, r.z, r.w])).toRotationMatrix()
    T[:3, 3] = [p.x, p.y, p.z]
    return T


def _world_poses(*messages: Any) -> dict[str, np.ndarray]:
    """Every frame's pose in the root frame, by composing the transforms of ``messages``."""
    parent = {}
    for msg in messages:
        for tr in msg.transforms:
            assert tr.child_frame_id not in parent, f"{tr.child_frame_id} has two parents"
            parent[tr.child_frame_id] = (tr.header.frame_id, _matrix(tr.transform))
    poses: dict[str, np.ndarray] = {}

    def pose(frame: str) -> np.ndarray:
        if frame not in parent:
            return np.eye(4)
        if frame not in poses:
            up, T = parent[frame]
            poses[frame] = pose(up) @ T
        return poses[frame]

    return {frame: pose(frame) for frame in parent}


def test_every_topic_is_there_with_its_count_and_monotone_stamps(bag: dict[str, Any]) -> None:
    ref, topics = bag["plan"], bag["topics"]
    assert set(topics) == set(TOPICS) - {SCENE_TOPIC}  # the lift has no scene
    times, _ = sample_times(ref.t)
    counts = {topic: len(msgs) for topic, msgs in topics.items()}
    assert counts == {TRAJECTORY_TOPIC: 1, "/robot_description": 1, "/tf_static": 1, "/tf": times.size,
                      "/joint_states": times.size, "/forte/markers": ref.t.size}
    assert np.all(np.diff(bag["log_times"]) >= 0)  # the file is in time order
    for topic in ("/robot_description", "/tf_static", TRAJECTORY_TOPIC):
        assert topics[topic][0][0] == 0  # written once at the start (latched)
    for topic in ("/tf", "/joint_states", "/forte/markers"):
        log = np.array([lt for lt, _ in topics[topic]])
        assert np.all(np.diff(log) > 0)
        for lt, msg in topics[topic]:
            stamps = [m.header.stamp for m in getattr(msg, "transforms", getattr(msg, "markers", [msg]))]
            assert all(s.sec * 1_000_000_000 + s.nanosec == lt for s in stamps)
    stream_t = np.array([_seconds(m.header.stamp) for _, m in topics["/joint_states"]])
    np.testing.assert_allclose(stream_t, times - ref.t[0], atol=1e-9)
    assert np.max(np.diff(stream_t)) <= 1 / RATE_HZ + 1e-9


def test_trajectory_is_the_plan(bag: dict[str, Any]) -> None:
    ref = bag["plan"]
    ((_, msg),) = bag["topics"][TRAJECTORY_TOPIC]
    assert list(msg.joint_names) == [*BASE_JOINTS, *ref.robot.arm_joints]
    assert msg.header.frame_id == BASE_LINKS[0]
    np.testing.assert_array_equal([p.positions for p in msg.points], ref.q)
    t = [_seconds(p.time_from_start) for p in msg.points]
    np.testing.assert_allclose(t, ref.t - ref.t[0], atol=1e-9)


def test_robot_description_is_the_planned_urdf(bag: dict[str, Any]) -> None:
    ref = bag["plan"]
    ((_, msg),) = bag["topics"]["/robot_description"]
    assert msg.data == whole_body_urdf(ref.robot, mesh_uris="package")
    model = pin.buildModelFromXML(msg.data)
    assert [model.names[j] for j in range(1, model.njoints)] == [*BASE_JOINTS, *ref.robot.arm_joints]
    # the meshes travel as package:// URIs (no path of this machine), which resolve where the package is
    meshes = [m.get("filename") for m in ET.fromstring(msg.data).iter("mesh")]
    assert meshes and all(m.startswith("package://example-robot-data/") for m in meshes)
    assert "file://" not in msg.data
    geometry = pin.buildGeomFromUrdfString(model, msg.data, pin.GeometryType.VISUAL, package_dirs=mesh_package_dirs())
    visual = [m for v in ET.fromstring(msg.data).iter("visual") for m in v.iter("mesh")]
    resolved = [g.meshPath for g in geometry.geometryObjects if g.meshPath.endswith((".dae", ".stl"))]
    assert len(resolved) == len(visual) and all(Path(p).is_file() for p in resolved)


def _qos(channel: Any) -> dict:
    (profile,) = yaml.safe_load(channel.metadata["offered_qos_profiles"])
    return profile


def test_every_channel_offers_the_qos_of_its_topic(bag: dict[str, Any]) -> None:
    """rosbag2's numeric encoding (metadata version 8, which a ``rosbag2`` record without
    ``serialized_metadata`` selects): durability 1 transient local, 2 volatile; reliability 1 reliable."""
    channels = {c.topic: c for c in bag["summary"].channels.values()}
    assert set(channels) == set(bag["topics"])
    for topic, channel in channels.items():
        profile = _qos(channel)
        assert list(profile) == ["history", "depth", "reliability", "durability", "deadline", "lifespan",
                                 "liveliness", "liveliness_lease_duration", "avoid_ros_namespace_conventions"]
        latched = topic in ("/robot_description", "/tf_static")
        assert profile["durability"] == (1 if latched else 2), topic
        assert (profile["reliability"], profile["history"], profile["liveliness"]) == (1, 1, 1)
        assert profile["depth"] >= 1 and profile["avoid_ros_namespace_conventions"] is False
        for key in ("deadline", "lifespan", "liveliness_lease_duration"):
            assert profile[key] == {"sec": 0, "nsec": 0}
    assert set(bag["metadata"]) == {"rosbag2"} and set(bag["metadata"]["rosbag2"]) == {"ROS_DISTRO"}


def test_rosbags_reads_the_qos(bag: dict[str, Any]) -> None:
    """An independent reader of rosbag2 files (rosbags, when installed) finds the same profiles."""
    rosbags = pytest.importorskip("rosbags.rosbag2")

    with rosbags.Reader(bag["path"]) as reader:
        qos = {c.topic: [(p.durability.name, p.reliability.name) for p in c.ext.offered_qos_profiles]
               for c in reader.connections}
    latched = ("/robot_description", "/tf_static")
    assert qos == {t: [("TRANSIENT_LOCAL" if t in latched else "VOLATILE", "RELIABLE")] for t in bag["topics"]}


def test_joint_states_follow_the_plan(bag: dict[str, Any]) -> None:
    ref = bag["plan"]
    msgs = [m for _, m in bag["topics"]["/joint_states"]]
    assert all(list(m.name) == [*BASE_JOINTS, *ref.robot.arm_joints] for m in msgs)
    Q = np.array([m.position for m in msgs])
    times, waypoint = sample_times(ref.t)
    np.testing.assert_array_equal(Q[waypoint], ref.q)  # at the waypoints: the plan's own positions
    spline, velocity, _ = clamped_spline(ref.t, ref.q, times)  # between them: the executed spline
    np.testing.assert_allclose(Q, spline, atol=1e-9)
    np.testing.assert_allclose([m.velocity for m in msgs], velocity, atol=1e-9)
    assert not np.allclose(Q[1], Q[0])  # the stream moves between waypoints, not only at them


def test_transforms_are_the_robot_moving(bag: dict[str, Any]) -> None:
    ref, topics = bag["plan"], bag["topics"]
    robot = ref.robot
    ((_, static),) = topics["/tf_static"]
    model = pin.buildModelFromXML(topics["/robot_description"][0][1].data)
    links = {f.name for f in model.frames if f.type == pin.FrameType.BODY}
    tf = [m for _, m in topics["/tf"]]
    moving = {tr.child_frame_id for tr in tf[0].transforms}
    assert moving == {BASE_LINKS[1], BASE_LINKS[2], BASE_LINKS[3], *(f"panda_link{i}" for i in range(1, 8))}
    assert {tr.child_frame_id for tr in static.transforms} | moving | {BASE_LINKS[0]} == links
    assert all(tr.header.frame_id in links for m in (static, tf[0]) for tr in m.transforms)
    q_states = np.array([m.position for _, m in topics["/joint_states"]])
    _, waypoint = sample_times(ref.t)
    ee = robot.model.frames[robot.ee_frame_id].name
    for k, i in enumerate(waypoint):
        poses = _world_poses(static, tf[i])
        # the base: x, y, yaw of the plan; the end effector: the planner's own kinematics
        np.testing.assert_allclose(poses[BASE_LINKS[-1]], robot.base_transform(ref.q[k, :3]), atol=1e-12)
        np.testing.assert_allclose(poses[ee], robot.ee_pose(ref.q[k]), atol=1e-9)
    # a link between waypoints: Pinocchio's forward kinematics of the description at that sample
    i = (waypoint[5] + waypoint[6]) // 2
    assert i not in waypoint
    data = model.createData()
    pin.framesForwardKinematics(model, data, q_states[i])
    np.testing.assert_allclose(_world_poses(static, tf[i])["panda_link4"],
                               data.oMf[model.getFrameId("panda_link4")].homogeneous, atol=1e-9)


def test_markers_are_the_force_and_the_rfp(bag: dict[str, Any]) -> None:
    ref = bag["plan"]
    robot = ref.robot
    rfp = trajectory_rfp(robot, ref.q, ref.t)
    msgs = [m for _, m in bag["topics"]["/forte/markers"]]
    np.testing.assert_array_equal(ref.force.t, ref.t)
    for k, msg in enumerate(msgs):
        by_ns = {m.ns: m for m in msg.markers}
        assert set(by_ns) == {"forte/force", "forte/force_ball", "forte/rfp"}
        assert all(m.header.frame_id == BASE_LINKS[0] for m in msg.markers)
        arrow, ball, hull = by_ns["forte/force"], by_ns["forte/force_ball"], by_ns["forte/rfp"]
        assert (arrow.type, ball.type, hull.type) == (ros.ARROW, ros.SPHERE, ros.TRIANGLE_LIST)
        start, end = (np.array([p.x, p.y, p.z]) for p in arrow.points)
        p = robot.ee_position(ref.q[k])
        np.testing.assert_allclose(start, p, atol=1e-12)
        np.testing.assert_allclose((end - start) / FORCE_SCALE, ref.force.f[k], atol=1e-9)
        assert ball.scale.x == pytest.approx(2 * FORCE_SCALE * ref.force.r[k])
        np.testing.assert_allclose([ball.pose.position.x, ball.pose.position.y, ball.pose.position.z], end)
        # the polytope: its hull's triangles, with every vertex of the RFP and only points inside it
        tri = (np.array([[v.x, v.y, v.z] for v in hull.points]) - p) / FORCE_SCALE
        assert hull.action == ros.ADD and len(tri) % 3 == 0 and len(tri) >= 12
        poly = rfp.at(k)
        assert np.all(tri @ poly.A.T <= poly.b + 1e-6 * np.abs(poly.b).max())
        assert np.min(np.linalg.norm(poly.vertices[:, None] - tri[None], axis=2), axis=1).max() < 1e-6
        a, b, c = tri[0::3], tri[1::3], tri[2::3]
        normals = np.cross(b - a, c - a)
        assert np.all(np.einsum("ij,ij->i", normals, (a + b + c) / 3 - poly.vertices.mean(axis=0)) > 0)


def test_msgdef_holds_each_dependency_once() -> None:
    text = ros.msgdef("visualization_msgs/MarkerArray")
    blocks = text.split("=" * 80 + "\n")
    assert blocks[0] == "Marker[] markers\n"
    names = [b.splitlines()[0] for b in blocks[1:]]
    assert len(names) == len(set(names))
    assert set(names) == {f"MSG: {n}" for n in (
        "visualization_msgs/Marker", "std_msgs/Header", "builtin_interfaces/Time", "geometry_msgs/Pose",
        "geometry_msgs/Point", "geometry_msgs/Quaternion", "geometry_msgs/Vector3", "std_msgs/ColorRGBA",
        "builtin_interfaces/Duration", "sensor_msgs/CompressedImage", "visualization_msgs/UVCoordinate",
        "visualization_msgs/MeshFile")}


def test_a_turning_base_and_a_single_waypoint(tmp_path: Path) -> None:
    """The base turns by 2.5 rad in 1 s (the lift barely turns): /tf follows it; a one-waypoint plan
    (a hold) gives one sample of each stream."""
    robot = default_robot()
    base = [(0.0, 0.0, 0.0), (0.3, -0.2, 1.0), (0.5, 0.1, 2.5)]
    turn = _export(write_plan_dir(tmp_path / "turn", robot, [0.0, 0.5, 1.0], [robot.home(b) for b in base], mass=1.0))
    counts = {topic: len(msgs) for topic, msgs in turn["topics"].items()}
    assert counts["/tf"] == counts["/joint_states"] == 51 and counts["/forte/markers"] == 3  # 50 Hz, 0.5 s on it
    static = turn["topics"]["/tf_static"][0][1]
    tf = [m for _, m in turn["topics"]["/tf"]]
    for k, i in enumerate((0, 25, 50)):
        poses = _world_poses(static, tf[i])
        np.testing.assert_allclose(poses[BASE_LINKS[-1]], robot.base_transform(np.array(base[k])), atol=1e-12)
        np.testing.assert_allclose(poses["forte_ee"], robot.ee_pose(robot.home(base[k])), atol=1e-9)
    yaw = [np.arctan2(*_world_poses(static, m)[BASE_LINKS[-1]][[1, 0], 0]) for m in tf]
    assert np.all(np.diff(yaw) >= -1e-12) and yaw[-1] == pytest.approx(2.5)  # turns one way, no jump
    hold = _export(write_plan_dir(tmp_path / "hold", robot, [0.0], [robot.home()], mass=1.0))
    assert {topic: len(msgs) for topic, msgs in hold["topics"].items()} == {t: 1 for t in TOPICS if t != SCENE_TOPIC}


def _wedge(path: Path) -> list[tuple[int, int, int]]:
    """An OBJ wedge (6 vertices, 8 triangles); returns its faces (0-based)."""
    vertices = [(0, 0, 0), (0.2, 0, 0), (0, 0.1, 0), (0, 0, 0.05), (0.2, 0, 0.05), (0, 0.1, 0.05)]
    faces = [(0, 2, 1), (3, 4, 5), (0, 1, 4), (0, 4, 3), (0, 3, 5), (0, 5, 2), (1, 2, 5), (1, 5, 4)]
    path.write_text("".join(f"v {x} {y} {z}\n" for x, y, z in vertices)
                    + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in faces))
    return faces


def test_scene_bodies_are_markers_at_their_poses(tmp_path: Path) -> None:
    """Every body of the plan's scene is one marker of /forte/scene (latched, one message at 0): its
    shape's marker type and size, its pose; a capsule's and a mesh's triangles in the body's axes."""
    robot = default_robot()
    faces = _wedge(tmp_path / "wedge.obj")
    scale = (1.0, 2.0, 0.5)
    shapes = {"crate": Box((0.4, 0.3, 0.2)), "ball": Sphere(0.1), "post": Cylinder(0.05, 0.8),
              "rail": Capsule(0.04, 0.6), "wedge": Mesh(tmp_path / "wedge.obj", scale)}
    poses = {"crate": [1.0, 0.5, 0.1, 0.0, 0.0, 0.4], "ball": [1.2, -0.4, 0.9, 0.0, 0.0, 0.0],
             "post": [0.8, -0.8, 0.4, 0.3, -0.2, 0.1], "rail": [1.5, 0.0, 1.0, 0.0, 1.2, 0.5],
             "wedge": [1.1, 0.9, 0.0, 0.1, 0.2, 0.3]}
    scene = Scene(tuple(SceneObject(n, s, pose_matrix(poses[n])) for n, s in shapes.items()))
    out = _export(write_plan_dir(tmp_path / "p", robot, [0.0, 1.0], [robot.home(), robot.home((0.1, 0, 0))],
                                 mass=1.0, scene=scene))
    ((log_time, msg),) = out["topics"][SCENE_TOPIC]
    assert log_time == 0
    channel = next(c for c in out["summary"].channels.values() if c.topic == SCENE_TOPIC)
    assert _qos(channel)["durability"] == 1  # transient local: RViz gets it whenever it subscribes
    markers = {m.ns: m for m in msg.markers}
    assert list(markers) == [f"forte/scene/{n}" for n in shapes]
    expected = {"crate": (ros.CUBE, (0.4, 0.3, 0.2)), "ball": (ros.SPHERE, (0.2, 0.2, 0.2)),
                "post": (ros.CYLINDER, (0.1, 0.1, 0.8)), "rail": (ros.TRIANGLE_LIST, (1, 1, 1)),
                "wedge": (ros.TRIANGLE_LIST, (1, 1, 1))}
    for name, m in ((n, markers[f"forte/scene/{n}"]) for n in shapes):
        assert m.header.frame_id == BASE_LINKS[0] and m.action == ros.ADD
        assert m.type == expected[name][0]
        np.testing.assert_allclose([m.scale.x, m.scale.y, m.scale.z], expected[name][1], rtol=1e-15)
        p, o = m.pose.position, m.pose.orientation
        pose = np.eye(4)
        pose[:3, :3] = pin.Quaternion(np.array([o.x, o.y, o.z, o.w])).toRotationMatrix()
        pose[:3, 3] = [p.x, p.y, p.z]
        np.testing.assert_allclose(pose, pose_matrix(poses[name]), atol=1e-12)
    # the capsule: points on its surface (at its radius from the axis segment), closed at both ends
    tri = np.array([[v.x, v.y, v.z] for v in markers["forte/scene/rail"].points])
    assert len(tri) % 3 == 0 and len(tri) >= 300
    rail = shapes["rail"]
    axis = np.clip(tri[:, 2], -rail.length / 2, rail.length / 2)
    np.testing.assert_allclose(np.linalg.norm(tri - np.outer(axis, [0, 0, 1]), axis=1), rail.radius, atol=1e-12)
    tip = rail.length / 2 + 0.99 * rail.radius
    assert tri[:, 2].max() > tip and tri[:, 2].min() < -tip
    a, b, c = tri[0::3], tri[1::3], tri[2::3]  # outward: each normal points away from the axis
    centre = (a + b + c) / 3
    away = centre - np.outer(np.clip(centre[:, 2], -rail.length / 2, rail.length / 2), [0, 0, 1])
    assert np.all(np.einsum("ij,ij->i", np.cross(b - a, c - a), away) > 0)
    # the mesh: the file's triangles, scaled, in its own axes (assimp reads single precision)
    vertices = np.loadtxt(tmp_path / "wedge.obj", usecols=(1, 2, 3), max_rows=6) * scale
    tri = np.array([[v.x, v.y, v.z] for v in markers["forte/scene/wedge"].points]).reshape(-1, 3, 3)
    got = sorted(tuple(sorted(map(tuple, np.round(t, 6)))) for t in tri)
    want = sorted(tuple(sorted(map(tuple, np.round(vertices[list(f)], 6)))) for f in faces)
    assert got == want
