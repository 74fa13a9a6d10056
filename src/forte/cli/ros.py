"""``forte ros TASK.yaml``: run forte as a live ROS 2 node (:mod:`forte.io.ros_node`).

Exit codes: 0 after SIGINT (Ctrl-C); 2 for a bad task file or argument, or rclpy missing (one line
naming the ``ros`` extra).
"""

from __future__ import annotations

import argparse
from pathlib import Path


def register(sub: argparse._SubParsersAction) -> None:
    """Add ``forte ros`` to the CLI."""
    p = sub.add_parser(
        "ros", help="a live ROS 2 node: re-plan on /forte/payload_mass, publish /forte/joint_trajectory",
        description="Plan TASK.yaml (starting from /joint_states when one arrives), publish the plan on "
        "/forte/joint_trajectory (trajectory_msgs/JointTrajectory) and its verdict on /forte/status "
        "(std_msgs/String, JSON), and re-plan with the warm re-planner on every std_msgs/Float64 on "
        "/forte/payload_mass (kg); with --cloud-topic, plan anew when a sensor_msgs/PointCloud2's occupied voxels "
        "change. Ctrl-C stops it. Needs pip install -e '.[ros]'.")
    p.add_argument("task", type=Path, help="task file (YAML), e.g. examples/tasks/lift.yaml")
    p.add_argument("--method", default="forte", help="an optimized method (default forte)")
    p.add_argument("--waypoints", type=int, default=None, help="waypoints of the horizon (default: the task's)")
    p.add_argument("--start-timeout", type=float, default=2.0,
                   help="seconds to wait for /joint_states before planning from the task's start (default 2)")
    p.add_argument("--node-name", default="forte", help="the ROS node's name (default forte)")
    p.add_argument("--cloud-topic", default=None,
                   help="a sensor_msgs/PointCloud2 topic whose occupied voxels join the scene (re-plans on change)")
    p.add_argument("--cloud-voxel", type=float, default=0.02, help="the cloud's voxel size (m, default 0.02)")
    p.add_argument("--cloud-period", type=float, default=1.0,
                   help="take a cloud at most once per this many seconds (default 1)")
    p.add_argument("--cloud-pose", type=float, nargs=6, default=None, metavar=("X", "Y", "Z", "ROLL", "PITCH", "YAW"),
                   help="the cloud frame's pose in the world (default: the points are in the world frame)")
    p.add_argument("--cloud-carve", action="store_true",
                   help="accumulate clouds: a new one clears the earlier cells its rays (from the cloud frame's "
                        "origin) pass through (default: each cloud replaces the last)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from forte.exceptions import InvalidInputError
    from forte.io.ros_node import require_rclpy, run_node
    from forte.planning.tasks.tasks import load_task

    if not 0 <= args.start_timeout <= 600:
        raise InvalidInputError(f"--start-timeout: expected 0 to 600 s, got {args.start_timeout}")
    cloud = None
    if args.cloud_topic is not None:
        from forte.io.ros_cloud import CloudOptions
        from forte.model.scene import pose_matrix

        if not 0 < args.cloud_voxel <= 1.0:
            raise InvalidInputError(f"--cloud-voxel: expected a size in (0, 1] m, got {args.cloud_voxel}")
        if not 0 <= args.cloud_period <= 3600:
            raise InvalidInputError(f"--cloud-period: expected 0 to 3600 s, got {args.cloud_period}")
        pose = None if args.cloud_pose is None else pose_matrix(args.cloud_pose)
        cloud = CloudOptions(args.cloud_topic, args.cloud_voxel, args.cloud_period, pose, args.cloud_carve)
    require_rclpy()  # before the plan: a missing extra is one line, not a wasted solve
    task = load_task(args.task, waypoints=args.waypoints)
    return run_node(task, args.method, args.start_timeout, args.node_name, cloud)
