"""A live ROS 2 node: forte's warm re-planner answering payload estimates (``forte ros TASK.yaml``).

Topics (names relative to the node's namespace; the defaults are absolute):

- subscribes ``/joint_states`` (``sensor_msgs/JointState``): the robot's configuration. The first
  plan starts from it when one arrives within ``start_timeout`` seconds (joints named as in the
  trajectory below, in any order; missing ones keep the task's value), else from the task's own
  initial configuration;
- subscribes ``/forte/payload_mass`` (``std_msgs/Float64``, kg): every new mass is re-planned
  with the warm re-planner (:class:`forte.planning.online.replan.Replanner`: the last primal-dual
  solution, a few Newton steps);
- publishes ``/forte/joint_trajectory`` (``trajectory_msgs/JointTrajectory``): joint names
  ``base_x``, ``base_y``, ``base_yaw`` and the arm's joints; positions, velocities (backward
  differences, the plan's own) and ``time_from_start`` per waypoint;
- publishes ``/forte/status`` (``std_msgs/String``, JSON): ``seq`` (0 for the first plan, +1 per
  re-plan), ``mass_kg``, ``verdict`` (``feasible`` | ``infeasible`` | ``solver-failed``: the
  re-planner's, ``forte plan``'s verdict at the waypoints and 8 samples per interval; the
  trajectory and the status are published together, after it), ``failed`` (the requirements
  that failed), ``solved``, ``iterations``, ``latency_s`` (the
  re-plan call), ``warm``.
- with ``--cloud-topic TOPIC``, subscribes ``TOPIC`` (``sensor_msgs/PointCloud2``, best effort,
  depth 1): the latest cloud, at most once per ``--cloud-period`` seconds and only when its
  occupied voxels changed, becomes boxes beside the task's own bodies (the floor's points and the
  robot's own at the plan's start dropped; :mod:`forte.io.ros_cloud`), and the task is planned
  anew in that scene at the last mass; its status adds ``cloud`` (``points``, ``cells``,
  ``boxes``); a cloud forte cannot use or a scene with no plan publishes ``cloud_error`` and
  keeps the last plan.

Both publishers are reliable and transient-local (depth 1): a subscriber that joins late gets the
last plan. A re-plan that does not converge publishes its status (``solved: false``) and no
trajectory: the last good one stands. ROS parameters ``method`` and ``waypoints`` (set from the
command line) are declared read-only. SIGINT (Ctrl-C) stops spinning, destroys the node and shuts
rclpy down; the command exits 0.

Needs the ``ros`` extra (``pip install -e '.[ros]'``: the ``ros-rclpy``, ``ros-rmw-fastrtps-cpp``
and message wheels from PyPI; no ROS installation).
"""

from __future__ import annotations

import json
import signal
import threading
import time
from typing import Any

import numpy as np

from forte.exceptions import ForteError, InvalidInputError
from forte.io.ros_cloud import CloudOptions, LiveCloud
from forte.model.description import N_BASE
from forte.model.trajectory import backward_differences
from forte.planning.online.replan import Replanner
from forte.planning.planner import Plan
from forte.planning.tasks.tasks import Task

#: The base joints' names in the published trajectory and the joint states read.
BASE_JOINT_NAMES = ("base_x", "base_y", "base_yaw")


def joint_names(task: Task) -> list[str]:
    """The trajectory's joint names: the base's, then the arm's."""
    return [*BASE_JOINT_NAMES, *(task.robot.arm_joints or ())]


def require_rclpy() -> Any:
    """rclpy, or one clear line on how to get it."""
    try:
        import rclpy
    except ImportError as exc:
        raise ForteError("forte ros needs rclpy: pip install -e '.[ros]' (the ros-rclpy wheels from PyPI; "
                         f"no ROS installation needed) ({exc})") from None
    return rclpy


def trajectory_message(plan: Plan, names: list[str]) -> Any:
    """The plan as a ``trajectory_msgs/JointTrajectory``."""
    from builtin_interfaces.msg import Duration
    from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

    msg = JointTrajectory()
    msg.joint_names = list(names)
    qd = backward_differences(plan.q, plan.t, start=getattr(plan.task, "start_motion", None))[0]
    for tk, qk, vk in zip(plan.t - plan.t[0], plan.q, qd, strict=True):
        point = JointTrajectoryPoint()
        point.positions, point.velocities = [float(v) for v in qk], [float(v) for v in vk]
        seconds = int(np.floor(tk))
        point.time_from_start = Duration(sec=seconds, nanosec=int(round((tk - seconds) * 1e9)) % 1_000_000_000)
        msg.points.append(point)
    return msg


def status_document(plan: Plan, seq: int, mass: float | None, latency: float, warm: bool, iterations: int
                    ) -> dict[str, Any]:
    """The JSON of ``/forte/status``."""
    verdict = plan.verdict
    return {"seq": seq, "mass_kg": mass, "verdict": plan.label, "failed": list(verdict.failed) if verdict else [],
            "solved": bool(plan.solved), "iterations": int(iterations), "latency_s": float(latency), "warm": warm}


def start_from(task: Task, names: list[str], state_names: list[str], positions: list[float]) -> np.ndarray:
    """The task's initial configuration with the joints a ``JointState`` names replaced."""
    q = np.array(task.q_init, dtype=float)
    index = {name: i for i, name in enumerate(names)}
    for name, value in zip(state_names, positions, strict=False):
        if name in index and np.isfinite(value):
            q[index[name]] = float(value)
    return q


#: How often (s) the node's spin loop looks for a SIGINT between callbacks.
SPIN_PERIOD_S = 0.1


def run_node(task: Task, method: str = "forte", start_timeout: float = 2.0, node_name: str = "forte",
             cloud: CloudOptions | None = None) -> int:
    """Plan ``task``, publish it, and re-plan on every payload mass (and, with ``cloud``, every
    changed scene from the cloud topic: :class:`forte.io.ros_cloud.LiveCloud`) until SIGINT (returns 0)."""
    rclpy = require_rclpy()
    from rclpy.executors import ExternalShutdownException
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from rclpy.signals import SignalHandlerOptions
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64, String
    from trajectory_msgs.msg import JointTrajectory

    # SIGINT sets a flag the spin loop reads (rclpy's own handler lost one now and then: a Ctrl-C
    # during a re-plan's callback left the node waiting on a futex until a second one came)
    rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
    stop = threading.Event()
    on_main = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGINT, lambda *_: stop.set()) if on_main else None
    node = rclpy.create_node(node_name)
    try:
        node.declare_parameters("", [("method", method), ("waypoints", int(task.n))])
        latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                             durability=DurabilityPolicy.TRANSIENT_LOCAL)
        traj_pub = node.create_publisher(JointTrajectory, "/forte/joint_trajectory", latched)
        status_pub = node.create_publisher(String, "/forte/status", latched)
        names = joint_names(task)
        state: dict[str, Any] = {}
        node.create_subscription(JointState, "/joint_states",
                                 lambda m: state.update(names=list(m.name), positions=list(m.position)), 10)
        deadline = time.monotonic() + start_timeout
        while not state and time.monotonic() < deadline:
            rclpy.spin_once(node, timeout_sec=0.05)
        if state:
            task = _with_start(task, start_from(task, names, state["names"], state["positions"]))
        start = time.perf_counter()
        live = {"replanner": Replanner(task, method), "mass": task.payload.mass, "seq": 0, "task": task}
        first = live["replanner"].replan()  # the first plan as a re-plan result (its verdict and facts)

        def publish(result_plan: Plan, mass: float | None, latency: float, warm: bool, iterations: int,
                    extra: dict[str, Any] | None = None) -> None:
            if result_plan.solved:
                traj_pub.publish(trajectory_message(result_plan, names))
            doc = status_document(result_plan, live["seq"], mass, latency, warm, iterations)
            status_pub.publish(String(data=json.dumps({**doc, **(extra or {})})))

        publish(first.plan, task.payload.mass, time.perf_counter() - start, False, first.iterations)

        def on_mass(msg: Any) -> None:
            mass = float(msg.data)
            live["seq"] += 1
            try:
                result = live["replanner"].replan(mass=mass)
            except ForteError as exc:  # a mass forte rejects (negative, absurd): say so, keep the last plan
                status_pub.publish(String(data=json.dumps({"seq": live["seq"], "mass_kg": mass, "error": str(exc)})))
                return
            live["mass"] = mass
            publish(result.plan, mass, result.latency_s, result.warm, result.iterations)

        node.create_subscription(Float64, "/forte/payload_mass", on_mass, 10)
        poll = _cloud_poller(node, cloud, live, method, publish, status_pub) if cloud is not None else None
        node.get_logger().info(f"planned {task.name} with {method}; waiting for /forte/payload_mass")
        try:
            while not stop.is_set() and rclpy.ok():
                rclpy.spin_once(node, timeout_sec=SPIN_PERIOD_S)
                if poll is not None:
                    poll()
        except (KeyboardInterrupt, ExternalShutdownException):
            pass
    finally:
        if previous is not None:
            signal.signal(signal.SIGINT, previous)
        node.destroy_node()
        if rclpy.ok():
            rclpy.try_shutdown()
    return 0


def _cloud_poller(node: Any, cloud: CloudOptions, live: dict[str, Any], method: str, publish: Any,
                  status_pub: Any) -> Any:
    """Subscribe ``cloud.topic`` (best effort, depth 1: the latest cloud) and return the spin loop's
    poll: a changed scene, at most once per ``cloud.period``, plans the task anew in it (a new
    warm re-planner) at the last mass; the status says ``cloud`` (points, cells, boxes)."""
    from dataclasses import replace

    from rclpy.qos import qos_profile_sensor_data
    from sensor_msgs.msg import PointCloud2
    from std_msgs.msg import String

    base = live["task"]
    cloud_scene = LiveCloud(base.scene, base.robot, cloud.voxel, cloud.period, cloud.pose, cloud.carve)
    node.create_subscription(PointCloud2, cloud.topic, cloud_scene.offer, qos_profile_sensor_data)

    def poll() -> None:
        try:
            found = cloud_scene.poll(time.monotonic(), live["task"].q_init)
        except ForteError as exc:  # a cloud forte cannot use (no x, y, z; too many cells): keep the last plan
            status_pub.publish(String(data=json.dumps({"seq": live["seq"], "cloud_error": str(exc)})))
            return
        if found is None:
            return
        live["seq"] += 1
        start = time.perf_counter()
        try:
            task = replace(base, scene=found.scene)
            replanner = Replanner(task, method)
            result = replanner.replan(mass=live["mass"])
        except ForteError as exc:  # no plan in this scene (a start inside a sensed body): keep the last
            status_pub.publish(String(data=json.dumps({"seq": live["seq"], "cloud_error": str(exc)})))
            return
        live.update(task=task, replanner=replanner)
        publish(result.plan, live["mass"], time.perf_counter() - start, False, result.iterations,
                {"cloud": {"points": found.points, "cells": found.cells, "boxes": found.boxes}})

    return poll


def _with_start(task: Task, q: np.ndarray) -> Task:
    """``task`` starting from ``q`` when its end-effector pose is the path's start (1 mm), else
    unchanged with a warning: the path is fixed, a start elsewhere cannot follow it."""
    from dataclasses import replace

    ee = task.robot.ee_pose(q)
    if np.linalg.norm(ee[:3, 3] - task.targets[0][:3, 3]) > 1e-3:
        import warnings

        gap = float(np.linalg.norm(ee[:3, 3] - task.targets[0][:3, 3]))
        warnings.warn(f"/joint_states: the robot's end effector is {gap:.3f} m from the task's start; planning "
                      "from the task's initial configuration", stacklevel=2)
        return task
    if q.shape != (task.robot.nq,) or q.size < N_BASE:
        raise InvalidInputError("/joint_states: expected the whole-body configuration")
    return replace(task, q_init=q)
