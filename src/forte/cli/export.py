"""``forte export PLAN_DIR FILE`` (npz, csv, ROS 2 MCAP) and ``forte robot export FILE`` (URDF, MJCF)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from forte.exceptions import InvalidInputError

ROBOT_FORMATS = (".urdf", ".xml")


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "export", help="export a plan: .npz, .csv or .mcap (ROS 2 bag: trajectory, robot, tf, joint states, markers)",
        description="Write the plan in PLAN_DIR to FILE; the format is FILE's suffix: .npz (t, q, qd, qdd, joint "
        "names, units, force, metrics), .csv (named columns, units in a comment line) or .mcap (ROS 2 topics: "
        "/forte/joint_trajectory, /robot_description, /tf_static, /tf, /joint_states at 50 Hz, /forte/markers with "
        "the force and the RFP per waypoint). Trajectory velocities and accelerations are the "
        "plan's backward differences from rest.")
    p.add_argument("plan_dir", type=Path, metavar="PLAN_DIR", help="output folder of 'forte plan'")
    p.add_argument("file", type=Path, metavar="FILE", help="FILE.npz, FILE.csv or FILE.mcap")
    p.add_argument("--quiet", action="store_true", help="print nothing on success")
    p.set_defaults(func=run_export)
    r = sub.add_parser("robot", help="robot model tools (export the whole-body model, the hand's pose)")
    rsub = r.add_subparsers(dest="robot_command", metavar="ACTION", required=True)
    e = rsub.add_parser(
        "export", help="write the whole-body model (base x, y, yaw + arm) as URDF or MJCF",
        description="Write the combined model: FILE.urdf (base joints base_x, base_y prismatic and base_yaw "
        "revolute, the arm mounted on them, the base's mass and inertia, the tool load as a link; meshes as "
        "package://example-robot-data/... URIs, resolved against example-robot-data's share folder) "
        "or FILE.xml (MuJoCo MJCF of the simulation "
        "model; a task's or a plan's carries its scene as static bodies scene/NAME, with the contacts of "
        "'forte simulate'). The robot is the built-in one, a task's or a plan's.")
    e.add_argument("file", type=Path, metavar="FILE", help="FILE.urdf or FILE.xml")
    src = e.add_mutually_exclusive_group()
    src.add_argument("--task", type=Path, help="use this task file's robot")
    src.add_argument("--plan", type=Path, metavar="PLAN_DIR", help="use this plan's robot")
    e.add_argument("--quiet", action="store_true", help="print nothing on success")
    e.set_defaults(func=run_robot_export)
    from forte.cli.robot_pose import register_pose

    register_pose(rsub)


def run_export(args: argparse.Namespace) -> int:
    from forte.io.export import export_plan

    path = export_plan(args.plan_dir, args.file)
    if not args.quiet:
        print(f"wrote {path}", file=sys.stderr)
    return 0


def run_robot_export(args: argparse.Namespace) -> int:
    suffix = args.file.suffix.lower()
    if suffix not in ROBOT_FORMATS:
        raise InvalidInputError(f"{args.file}: unknown robot format {args.file.suffix or '(no suffix)'}; "
                                f"expected one of {', '.join(ROBOT_FORMATS)}")
    if args.file.is_dir() or not args.file.parent.is_dir():
        raise InvalidInputError(f"{args.file}: expected a file name in an existing folder")
    scene = None
    if args.task is not None:
        from forte.planning.tasks.tasks import load_task

        task = load_task(args.task)
        robot, scene = task.robot, task.scene
    elif args.plan is not None:
        from forte.io.plandir import read_plan_dir

        plan = read_plan_dir(args.plan)
        robot, scene = plan.robot, plan.scene
    else:
        from forte.model.robot import default_robot

        robot = default_robot()
    if suffix == ".urdf":
        from forte.io.whole_body import portable_urdf

        text = portable_urdf(robot)  # package:// meshes: the file travels
        scene_note = f"; the scene's {len(scene.objects)} bodies are in the MJCF (.xml) only" if scene else ""
    else:
        from forte.execution.model import whole_body_mjcf

        # a task's or a plan's model is the one 'forte simulate' builds: its scene, contacts on
        text = whole_body_mjcf(robot, scene=scene)
        scene_note = f" and {len(scene.objects)} scene bodies" if scene else ""
    args.file.write_text(text)
    if not args.quiet:
        print(f"wrote {args.file} ({robot.name}: base_x, base_y, base_yaw + {robot.n_arm} arm joints{scene_note})",
              file=sys.stderr)
    return 0
