"""The ROS 2 MCAP export of a plan: what a ROS 2 tool needs to replay it (``forte export PLAN FILE.mcap``).

Topics (CDR, ``ros2msg`` schemas of :mod:`forte.io.ros_messages`; stamps and log times are seconds
from the plan's start; every frame is a link of the whole-body URDF, the fixed frame is its root
``mobile_world``):

- :data:`TRAJECTORY_TOPIC` ``trajectory_msgs/JointTrajectory``: one message at 0, the whole plan
  (every waypoint: positions, the plan's backward-difference velocities and accelerations,
  ``time_from_start``);
- ``/robot_description`` ``std_msgs/String``: one message at 0, the whole-body URDF the plan was
  planned with (:func:`forte.io.export.whole_body_urdf`, as ``forte robot export --plan`` writes it);
  rosbag2 has no latching, so the single message at the start stands in for it;
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
  faces (a DELETE when it is empty). Each message replaces the previous one (same ns and id).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from forte.capability.polytope import trajectory_rfp
from forte.exceptions import InvalidInputError
from forte.io import ros_messages as ros
from forte.model.robot import MobileManipulator
from forte.model.trajectory import clamped_spline
from forte.validation import FloatArray

TRAJECTORY_TOPIC = "/forte/joint_trajectory"
DESCRIPTION_TOPIC = "/robot_description"
TF_TOPIC = "/tf"
TF_STATIC_TOPIC = "/tf_static"
JOINT_STATES_TOPIC = "/joint_states"
MARKERS_TOPIC = "/forte/markers"
#: Message type of each topic.
TOPICS = {TRAJECTORY_TOPIC: "trajectory_msgs/JointTrajectory", DESCRIPTION_TOPIC: "std_msgs/String",
          TF_STATIC_TOPIC: "tf2_msgs/TFMessage", TF_TOPIC: "tf2_msgs/TFMessage",
          JOINT_STATES_TOPIC: "sensor_msgs/JointState", MARKERS_TOPIC: "visualization_msgs/MarkerArray"}
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


def write_mcap(data: Any, path: Path) -> None:
    """Write the topics of the module docstring for ``data`` (a :class:`forte.io.export.ExportedPlan`)."""
    try:
        from mcap_ros2.writer import Writer
    except ImportError as exc:
        raise InvalidInputError("MCAP export needs the 'mcap-ros2-support' package: "
                                "pip install 'forte[export]'") from exc
    from forte.io.export import whole_body_urdf

    robot: MobileManipulator = data.robot
    t0 = float(data.t[0])
    urdf = whole_body_urdf(robot)
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
    times, Q, V, _ = stream(data.t, data.q)
    for ts, qs, vs in zip(times - t0, Q, V, strict=True):
        messages.append((ts, TF_TOPIC, _tf_message(ts, links.transforms(qs, fixed=False))))
        messages.append((ts, JOINT_STATES_TOPIC, {"header": ros.header(ts, ""), "name": names,
                                                  "position": qs.tolist(), "velocity": vs.tolist(), "effort": []}))
    messages += [(ts, MARKERS_TOPIC, m) for ts, m in marker_arrays(robot, data.t, data.q, data.force)]
    messages.sort(key=lambda m: m[0])  # stable: at equal times, in the order above
    with open(path, "wb") as fh:
        writer = Writer(fh)
        schemas = {name: writer.register_msgdef(ros.schema_name(name), ros.msgdef(name))
                   for name in sorted(set(TOPICS.values()))}
        for ts, topic, message in messages:
            ns = ros.nanoseconds(ts)
            writer.write_message(topic=topic, schema=schemas[TOPICS[topic]], message=message, log_time=ns,
                                 publish_time=ns)
        writer.finish()
