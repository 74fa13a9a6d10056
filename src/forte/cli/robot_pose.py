"""``forte robot pose [TASK.yaml | --robot PRESET | --urdf U --ee-frame F] [--q ...]``: where the hand is.

The end effector's world pose at a whole-body configuration ``q = [x, y, yaw, q_arm]`` (or the arm
alone, the base at the task's start or at the origin): ``T = T_base(x, y, yaw) T_mount T_arm(q_arm)``,
Pinocchio's forward kinematics through :meth:`forte.model.robot.MobileManipulator.ee_pose`. Printed as
the position (m), roll-pitch-yaw (rad, ``R = Rz(yaw) Ry(pitch) Rx(roll)``), the quaternion (x, y,
z, w) and the 4x4 matrix, or as JSON. Without ``--q``: the task's initial configuration, else the
robot's home. A task is read for its robot and start only (its path is not needed).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from forte.exceptions import InvalidInputError


class EePose(NamedTuple):
    """The end effector's pose: ``q`` (whole body), ``matrix`` (4x4), ``rpy`` (rad), ``quaternion`` (x, y, z, w)."""

    q: list[float]
    matrix: list[list[float]]
    position: list[float]
    rpy: list[float]
    quaternion: list[float]


def register_pose(rsub: argparse._SubParsersAction) -> None:
    p = rsub.add_parser(
        "pose", help="print the end effector's pose at a configuration",
        description="Print the end effector's world pose (position, roll-pitch-yaw, quaternion x y z w, and the "
        "4x4 matrix) of a task's robot, a preset or a URDF at --q (whole body: x, y, yaw, then the arm joints; or "
        "the arm joints alone, the base at the task's start or the origin). Without --q: the task's initial "
        "configuration, else the robot's home.")
    p.add_argument("task", type=Path, nargs="?", metavar="TASK.yaml", help="use this task's robot and start")
    p.add_argument("--robot", metavar="PRESET", help="a robot preset")
    p.add_argument("--urdf", help="an arm's URDF (a path, or erd:<path inside example-robot-data>)")
    p.add_argument("--ee-frame", help="the end-effector frame of --urdf")
    p.add_argument("--q", type=float, nargs="+", metavar="V", help="the configuration (rad, m)")
    p.add_argument("--json", action="store_true", help="print JSON instead")
    p.set_defaults(func=run_robot_pose)


def robot_and_start(args: argparse.Namespace) -> tuple[Any, np.ndarray]:
    """The robot and its default configuration from the task, the preset or the URDF."""
    from forte.planning.tasks.schema import Reader, robot_section

    given = [name for name, v in (("TASK.yaml", args.task), ("--robot", args.robot), ("--urdf", args.urdf)) if v]
    if len(given) > 1:
        raise InvalidInputError(f"{given[1]}: give one of TASK.yaml, --robot, --urdf")
    if args.ee_frame and not args.urdf:
        raise InvalidInputError("--ee-frame: only with --urdf")
    if args.task is not None:
        from forte.planning.tasks.tasks import read_yaml

        reader = Reader(read_yaml(args.task, "task file"), args.task)
        robot = robot_section(reader, args.task.parent)
        start = reader.vector("initial_configuration", robot.nq) if reader.has("initial_configuration") \
            else robot.home()
        return robot, start
    if args.urdf:
        if not args.ee_frame:
            raise InvalidInputError("--ee-frame: required with --urdf")
        urdf = args.urdf if args.urdf.startswith("erd:") else str(Path(args.urdf).resolve())
        robot = robot_section(Reader({"robot": {"urdf": urdf, "ee_frame": args.ee_frame}}, None), Path("."))
    else:
        robot = robot_section(Reader({"robot": {"preset": args.robot or "authors"}}, None), Path("."))
    return robot, robot.home()


def ee_pose(robot: Any, start: np.ndarray, q: list[float] | None) -> EePose:
    """The pose at ``q`` (``nq`` values, or ``n_arm`` with ``start``'s base; ``None``: ``start``)."""
    import pinocchio as pin

    if q is None:
        full = np.asarray(start, dtype=float)
    elif len(q) == robot.nq:
        full = np.asarray(q, dtype=float)
    elif len(q) == robot.n_arm:
        full = np.concatenate([start[:3], q])
    else:
        raise InvalidInputError(f"--q: expected {robot.nq} values (x, y, yaw and {robot.n_arm} arm joints) or "
                                f"{robot.n_arm} (the arm joints), got {len(q)}")
    T = robot.ee_pose(full)
    quat = pin.Quaternion(T[:3, :3]).coeffs()  # (x, y, z, w)
    return EePose(full.tolist(), T.tolist(), T[:3, 3].tolist(), pin.rpy.matrixToRpy(T[:3, :3]).tolist(),
                  np.asarray(quat).tolist())


def run_robot_pose(args: argparse.Namespace) -> int:
    robot, start = robot_and_start(args)
    pose = ee_pose(robot, start, args.q)
    if args.json:
        print(json.dumps(pose._asdict() | {"robot": robot.name, "ee_frame": robot.ee_frame}))
        return 0

    def fmt(values: list[float]) -> str:
        return "[" + ", ".join(f"{v:.6f}" for v in values) + "]"

    ee = robot.ee_frame + (" with its ee_offset" if robot.ee_offset is not None else "")
    out = [f"robot {robot.name}, end effector {ee}", f"q           {fmt(pose.q)}",
           f"position    {fmt(pose.position)} m", f"rpy         {fmt(pose.rpy)} rad",
           f"quaternion  {fmt(pose.quaternion)} (x, y, z, w)", "matrix"]
    out += [f"  {fmt(row)}" for row in pose.matrix]
    sys.stdout.write("\n".join(out) + "\n")
    return 0
