"""The ROS 2 MCAP export of a plan: what a ROS 2 tool needs to replay it (``forte export PLAN FILE.mcap``).

Topics (CDR, ``ros2msg`` schemas of :mod:`forte.io.ros_messages`; stamps and log times are seconds
from the plan's start; every frame is a link of the whole-body URDF, the fixed frame is its root
``mobile_world``):

- :data:`TRAJECTORY_TOPIC` ``trajectory_msgs/JointTrajectory``: one message at 0, the whole plan
  (every waypoint: positions, the plan's backward-difference velocities and accelerations,
  ``time_from_start``);
- ``/robot_description`` ``std_msgs/String``: one message at 0, the whole-body URDF the plan was
  planned with, its meshes ``package://`` URIs (:func:`forte.io.whole_body.portable_urdf`, as
  ``forte robot export --plan`` writes it);
- ``/tf_static`` ``tf2_msgs/TFMessage``: one message at 0, every fixed joint of the URDF (parent
  link to child link), as ``robot_state_publisher`` publishes them;
- ``/tf`` ``tf2_msgs/TFMessage`` and ``/joint_states`` ``sensor_msgs/JointState``: one message
  per sample of the executed motion, the clamped cubic spline through the waypoints that
  ``forte simulate`` hands its controllers (:func:`forte.model.trajectory.clamped_spline`), at
  :data:`RATE_HZ` with every waypoint time added (at a waypoint the positions are the plan's own).
  ``/tf`` holds every moving joint of the URDF, parent link to child link, from Pinocchio's
  forward kinematics of the URDF: ``mobile_world -> mobile_base_x -> mobile_base_y -> mobile_base``
  are the base's ``x``, ``y`` and ``yaw``, then the arm's links;
- :data:`MARKERS_TOPIC` ``visualization_msgs/MarkerArray``: one message per waypoint, in
  ``mobile_world``, drawn at the end effector with forces scaled by :data:`FORCE_SCALE` (m per N):
  ``forte/force`` an ARROW from the end effector to ``p + s f_k`` (the required force),
  ``forte/force_ball`` a SPHERE of diameter ``2 s r_k`` at the arrow's tip (the uncertainty ball)
  and ``forte/rfp`` the residual force polytope of the waypoint
  (:func:`forte.capability.polytope.trajectory_rfp`) as a TRIANGLE_LIST of its hull, outward
  faces (a DELETE when it is empty). Each message replaces the previous one (same ns and id);
- :data:`SCENE_TOPIC` ``visualization_msgs/MarkerArray`` (only for a plan with a scene): one message
  at 0, a marker ``forte/scene/<name>`` per body at its pose in ``mobile_world``: a CUBE of the box's
  edges, a SPHERE or a CYLINDER of their diameter (and length), and a TRIANGLE_LIST in the body's
  axes for a capsule (the hull of :data:`CAPSULE_POINTS` points on its surface) or a mesh (its triangles).

QoS: every channel carries rosbag2's ``offered_qos_profiles`` (:func:`offered_qos`), what
``ros2 bag play`` offers the topic with: :data:`LATCHED` topics, written once at the start, are
transient local (RViz, ``robot_state_publisher``'s listeners and tf2's static listener ask for it:
a volatile replay never reaches them), the others volatile; all reliable, keep last. The profiles
use rosbag2's numeric encoding (the ``rmw`` enum values), with a ``rosbag2`` metadata record holding
only ``ROS_DISTRO``, as rosbag2's MCAP storage of Humble writes them: rosbag2 of Jazzy and later
reads a file with that record and no ``serialized_metadata`` as metadata version 8 (numbers), and
Humble's reads only numbers; the string form (version 9) is not read by Humble, and newer rosbag2
reads it only with version-9 ``serialized_metadata`` (the whole bag's) or with none of the record.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin
import yaml
from scipy.spatial import ConvexHull

from forte.capability.polytope import trajectory_rfp
from forte.exceptions import InvalidInputError
from forte.io import ros_messages as ros
from forte.io.whole_body import portable_urdf
from forte.model.robot import MobileManipulator
from forte.model.scene import Box, Capsule, Cylinder, Scene, SceneObject, Sphere
from forte.model.trajectory import clamped_spline
from forte.validation import FloatArray

TRAJECTORY_TOPIC = "/forte/joint_trajectory"
DESCRIPTION_TOPIC = "/robot_description"
TF_TOPIC = "/tf"
TF_STATIC_TOPIC = "/tf_static"
JOINT_STATES_TOPIC = "/joint_states"
MARKERS_TOPIC = "/forte/markers"
SCENE_TOPIC = "/forte/scene"
#: Message type of each topic.
TOPICS = {TRAJECTORY_TOPIC: "trajectory_msgs/JointTrajectory", DESCRIPTION_TOPIC: "std_msgs/String",
          TF_STATIC_TOPIC: "tf2_msgs/TFMessage", TF_TOPIC: "tf2_msgs/TFMessage",
          JOINT_STATES_TOPIC: "sensor_msgs/JointState", MARKERS_TOPIC: "visualization_msgs/MarkerArray",
          SCENE_TOPIC: "visualization_msgs/MarkerArray"}
#: Topics published once at the start: transient local, as their live publishers offer them.
LATCHED = frozenset({DESCRIPTION_TOPIC, TF_STATIC_TOPIC, SCENE_TOPIC})
#: ``rmw`` enum values of rosbag2's numeric QoS encoding.
KEEP_LAST, RELIABLE, TRANSIENT_LOCAL, VOLATILE, AUTOMATIC = 1, 1, 1, 2, 1
#: ``ROS_DISTRO`` of the ``rosbag2`` metadata record (the distro of :mod:`forte.io.ros_messages`).
ROS_DISTRO = "kilted"
#: Points on a capsule's surface whose hull draws it.
CAPSULE_POINTS = 400
#: Rate of ``/tf`` and ``/joint_states`` (Hz); the waypoint times are added.
RATE_HZ = 50.0
#: Length of a force in the markers (m per N).
FORCE_SCALE = 0.005
#: Fixed frame: the root link of the whole-body URDF.
FIXED_FRAME = "mobile_world"


def sample_times(t: FloatArray, rate: float = RATE_HZ) -> tuple[FloatArray, np.ndarray]:
    """Times of the stream: ``t[0] + i / rate`` and every waypoint time, sorted, and the index of
    each waypoint among them."""
    grid = t[0] + np.arange(int(np.floor((t[-1] - t[0]) * rate + 1e-9)) + 1) / rate
    grid = grid[np.min(np.abs(grid[:, None] - t[None, :]), axis=1) > 1e-6]  # a waypoint's time is its own
    times = np.sort(np.r_[grid, t])
    return times, np.searchsorted(times, t)


def stream(t: FloatArray, q: FloatArray,
           rate: float = RATE_HZ) -> tuple[FloatArray, FloatArray, FloatArray, np.ndarray]:
    """The executed motion at :func:`sample_times`: times, positions, velocities (the clamped
    spline; yaw unwrapped as the controllers' reference) and the waypoints' indices."""
    times, waypoint = sample_times(t, rate)
    unwrapped = q.copy()
    unwrapped[:, 2] = np.unwrap(q[:, 2])
    Q, V, _ = clamped_spline(t, unwrapped, times)
    Q[waypoint] = q
    return times, Q, V, waypoint


class UrdfTransforms:
    """Parent-to-child transforms of every joint of a URDF (text), from Pinocchio's kinematics."""

    def __init__(self, urdf: str, joint_names: tuple[str, ...]) -> None:
        self.model = pin.buildModelFromXML(urdf)
        self.data = self.model.createData()
        root = ET.fromstring(urdf)
        self.joints = [(j.get("name"), j.get("type"), j.find("parent").get("link"), j.find("child").get("link"))
                       for j in root.findall("joint")]
        names = list(joint_names)
        missing = [self.model.names[j] for j in range(1, self.model.njoints) if self.model.names[j] not in names]
        if missing:
            raise InvalidInputError(f"robot description: joint {missing[0]!r} is not in the plan's joints")
        self._columns = [(names.index(self.model.names[j]), self.model.idx_qs[j], self.model.joints[j].nq)
                         for j in range(1, self.model.njoints)]

    def configuration(self, q: FloatArray) -> FloatArray:
        """Pinocchio's configuration of the plan's positions ``q`` (continuous joints: cos, sin)."""
        x = pin.neutral(self.model)
        for col, idx, nq in self._columns:
            x[idx: idx + nq] = [q[col]] if nq == 1 else [np.cos(q[col]), np.sin(q[col])]
        return x

    def link_poses(self, q: FloatArray) -> dict[str, FloatArray]:
        """World (root link) pose of every link at the plan's positions ``q``."""
        pin.framesForwardKinematics(self.model, self.data, self.configuration(q))
        return {f.name: self.data.oMf[i].homogeneous for i, f in enumerate(self.model.frames)
                if f.type == pin.FrameType.BODY}

    def transforms(self, q: FloatArray, fixed: bool) -> list[tuple[str, str, FloatArray]]:
        """``(parent, child, T)`` of the fixed (or of the moving) joints at ``q``."""
        poses = self.link_poses(q)
        return [(parent, child, np.linalg.inv(poses[parent]) @ poses[child])
                for _, kind, parent, child in self.joints if (kind == "fixed") == fixed]


def _tf_message(seconds: float, transforms: list[tuple[str, str, FloatArray]]) -> dict:
    return {"transforms": [ros.transform_stamped(seconds, p, c, T) for p, c, T in transforms]}


def _outward(V: FloatArray, faces: np.ndarray) -> np.ndarray:
    """Faces of a convex hull ordered counter-clockwise seen from outside."""
    faces = np.array(faces, dtype=int)
    a, b, c = V[faces[:, 0]], V[faces[:, 1]], V[faces[:, 2]]
    inward = np.einsum("ij,ij->i", np.cross(b - a, c - a), (a + b + c) / 3 - V.mean(axis=0)) < 0
    faces[inward] = faces[inward][:, ::-1]
    return faces


def marker_arrays(robot: MobileManipulator, t: FloatArray, q: FloatArray,
                  force: dict[str, FloatArray]) -> list[tuple[float, dict]]:
    """``(time, MarkerArray)`` of each waypoint (see the module docstring)."""
    rfp = trajectory_rfp(robot, q, t)
    f = r = None
    if force:
        f = np.column_stack([np.interp(t, force["t"], force["f"][:, i]) for i in range(3)])
        r = np.interp(t, force["t"], force["r"])
    out = []
    for k, tk in enumerate(t - t[0]):
        p = robot.ee_position(q[k])
        markers = []
        if f is not None and r is not None:
            tip = p + FORCE_SCALE * f[k]
            markers.append(ros.marker(tk, FIXED_FRAME, "forte/force", ros.ARROW, points=np.array([p, tip]),
                                      scale=(0.01, 0.02, 0.0), rgba=ros.color(0.9, 0.1, 0.1)))
            d = 2 * FORCE_SCALE * float(r[k])
            markers.append(ros.marker(tk, FIXED_FRAME, "forte/force_ball", ros.SPHERE, position=tip, scale=(d, d, d),
                                      rgba=ros.color(1.0, 0.6, 0.0, 0.35)))
        polytope = rfp.at(k)
        V = polytope.vertices
        if len(V) >= 4:
            triangles = p + FORCE_SCALE * V[_outward(V, polytope.faces)].reshape(-1, 3)
            markers.append(ros.marker(tk, FIXED_FRAME, "forte/rfp", ros.TRIANGLE_LIST, points=triangles,
                                      rgba=ros.color(0.2, 0.4, 0.9, 0.3)))
        else:
            markers.append(ros.marker(tk, FIXED_FRAME, "forte/rfp", ros.TRIANGLE_LIST, action=ros.DELETE))
        out.append((float(tk), {"markers": markers}))
    return out


def offered_qos(topic: str) -> str:
    """rosbag2's ``offered_qos_profiles`` of ``topic``: a YAML list of one profile (see the module
    docstring); durations ``0 s 0 ns`` are ``rmw``'s "unspecified" (the default, no limit)."""
    unspecified = {"sec": 0, "nsec": 0}
    profile = {"history": KEEP_LAST, "depth": 1 if topic in LATCHED else 10, "reliability": RELIABLE,
               "durability": TRANSIENT_LOCAL if topic in LATCHED else VOLATILE, "deadline": unspecified,
               "lifespan": unspecified, "liveliness": AUTOMATIC, "liveliness_lease_duration": unspecified,
               "avoid_ros_namespace_conventions": False}
    return yaml.safe_dump([profile], sort_keys=False)


def capsule_points(capsule: Capsule, n: int = CAPSULE_POINTS) -> FloatArray:
    """``n`` points on the capsule's surface: a Fibonacci lattice on the sphere of its radius, each
    hemisphere moved by half the length along the axis (z)."""
    i = np.arange(n) + 0.5
    z = 1 - 2 * i / n  # never 0 for even n: each point belongs to one hemisphere
    rho, phi = np.sqrt(1 - z**2), np.pi * (3 - np.sqrt(5)) * i
    unit = np.column_stack([rho * np.cos(phi), rho * np.sin(phi), z])
    return capsule.radius * unit + np.outer(np.sign(z) * capsule.length / 2, [0.0, 0.0, 1.0])


def _body_marker(obj: SceneObject) -> dict:
    """The marker of one scene body (see the module docstring)."""
    s, kind, scale, points = obj.shape, ros.TRIANGLE_LIST, (1.0, 1.0, 1.0), None
    if isinstance(s, Box):
        kind, scale = ros.CUBE, tuple(map(float, s.size))
    elif isinstance(s, Sphere):
        kind, scale = ros.SPHERE, (2 * s.radius,) * 3
    elif isinstance(s, Cylinder):
        kind, scale = ros.CYLINDER, (2 * s.radius, 2 * s.radius, s.length)
    elif isinstance(s, Capsule):
        V = capsule_points(s)
        points = V[_outward(V, ConvexHull(V).simplices)].reshape(-1, 3)
    else:  # a mesh: its own triangles, as coal loads them (scaled)
        g = obj.collision_geometry()
        V = np.array(g.vertices(), dtype=float).reshape(-1, 3)
        points = V[[[g.tri_indices(i)[j] for j in range(3)] for i in range(g.num_tris)]].reshape(-1, 3)
    return ros.marker(0.0, FIXED_FRAME, f"forte/scene/{obj.name}", kind, position=obj.pose[:3, 3],
                      rotation=obj.pose[:3, :3], scale=scale, rgba=ros.color(0.59, 0.47, 0.35, 0.8), points=points)


def scene_markers(scene: Scene) -> dict:
    """The ``MarkerArray`` of :data:`SCENE_TOPIC`: one marker per body."""
    return {"markers": [_body_marker(obj) for obj in scene.objects]}


def write_mcap(data: Any, path: Path) -> None:
    """Write the topics of the module docstring for ``data`` (a :class:`forte.io.export.ExportedPlan`)."""
    try:
        from mcap_ros2.writer import Writer
    except ImportError as exc:
        raise InvalidInputError("MCAP export needs the 'mcap-ros2-support' package: "
                                "pip install 'forte[export]'") from exc
    robot: MobileManipulator = data.robot
    t0 = float(data.t[0])
    urdf = portable_urdf(robot)
    links = UrdfTransforms(urdf, data.joint_names)
    names = list(data.joint_names)
    points = [{"positions": data.q[k].tolist(), "velocities": data.qd[k].tolist(),
               "accelerations": data.qdd[k].tolist(), "effort": [],
               "time_from_start": ros.time(float(data.t[k]) - t0)} for k in range(data.t.size)]
    messages: list[tuple[float, str, dict]] = [
        (0.0, DESCRIPTION_TOPIC, {"data": urdf}),
        (0.0, TF_STATIC_TOPIC, _tf_message(0.0, links.transforms(data.q[0], fixed=True))),
        (0.0, TRAJECTORY_TOPIC, {"header": ros.header(0.0, FIXED_FRAME), "joint_names": names, "points": points}),
    ]
    if data.scene:
        messages.append((0.0, SCENE_TOPIC, scene_markers(data.scene)))
    times, Q, V, _ = stream(data.t, data.q)
    for ts, qs, vs in zip(times - t0, Q, V, strict=True):
        messages.append((ts, TF_TOPIC, _tf_message(ts, links.transforms(qs, fixed=False))))
        messages.append((ts, JOINT_STATES_TOPIC, {"header": ros.header(ts, ""), "name": names,
                                                  "position": qs.tolist(), "velocity": vs.tolist(), "effort": []}))
    messages += [(ts, MARKERS_TOPIC, m) for ts, m in marker_arrays(robot, data.t, data.q, data.force)]
    messages.sort(key=lambda m: m[0])  # stable: at equal times, in the order above
    with open(path, "wb") as fh:
        writer = Writer(fh)
        writer.add_metadata("rosbag2", {"ROS_DISTRO": ROS_DISTRO})
        schemas = {name: writer.register_msgdef(ros.schema_name(name), ros.msgdef(name))
                   for name in sorted(set(TOPICS.values()))}
        for topic in dict.fromkeys(topic for _, topic, _ in messages):
            _register_channel(writer, topic, schemas[TOPICS[topic]])
        for ts, topic, message in messages:
            ns = ros.nanoseconds(ts)
            writer.write_message(topic=topic, schema=schemas[TOPICS[topic]], message=message, log_time=ns,
                                 publish_time=ns)
        writer.finish()


def _register_channel(writer: Any, topic: str, schema: Any) -> None:
    """Register ``topic``'s channel with its :func:`offered_qos`: mcap-ros2-support's writer registers
    a channel without metadata on a topic's first message unless its table already holds one."""
    writer._channel_ids[topic] = writer._writer.register_channel(
        topic=topic, message_encoding="cdr", schema_id=schema.id, metadata={"offered_qos_profiles": offered_qos(topic)})
