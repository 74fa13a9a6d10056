"""``forte import moveit REQUEST.yaml --scene SCENE.yaml --out TASK.yaml``: a MoveIt problem as a goal task."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from forte.model.robot import BASE_MODES


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("import", help="turn another tool's problem into a forte task (MoveIt)")
    isub = p.add_subparsers(dest="import_command", metavar="FORMAT", required=True)
    m = isub.add_parser(
        "moveit", help="a MoveIt MotionPlanRequest and PlanningScene (YAML) as a goal task",
        description="Write a goal task from a MoveIt MotionPlanRequest (start_state.joint_state, "
        "goal_constraints[0]: joint constraints, or position and orientation constraints) and its PlanningScene "
        "(scene_file: the scene's path relative to the task). The start's joints that are not planned (the Panda's "
        "fingers) become robot.locked_joints, clipped to the URDF's range; a scene with a body below z = 0 gets "
        "floor: none. Without --robot or --urdf, a Panda start state gives MotionBenchMaker's Panda "
        "(erd:panda_description/urdf/panda.urdf, ee_frame panda_hand, base fixed).")
    m.add_argument("request", type=Path, metavar="REQUEST.yaml", help="a MoveIt MotionPlanRequest")
    m.add_argument("--scene", type=Path, required=True, metavar="SCENE.yaml", help="its MoveIt PlanningScene")
    m.add_argument("--out", type=Path, required=True, metavar="TASK.yaml",
                   help="the task to write (a new file, or one 'forte import moveit' wrote)")
    robot = m.add_mutually_exclusive_group()
    robot.add_argument("--robot", metavar="PRESET", help="a robot preset (forte's built-in robots)")
    robot.add_argument("--urdf", help="the arm's URDF (a path, or erd:<path inside example-robot-data>)")
    m.add_argument("--ee-frame", help="the end-effector frame of --urdf")
    m.add_argument("--base", choices=BASE_MODES, default="fixed", help="how the base of --urdf moves (default fixed)")
    m.add_argument("--floor", choices=("auto", "none", "keep"), default="auto",
                   help="auto (default): floor: none when a scene body reaches below z = 0; none: always; keep: "
                   "forte's floor at z = 0")
    m.add_argument("--payload", type=float, metavar="KG", help="a payload in the hand (default: none)")
    m.add_argument("--quiet", action="store_true", help="print nothing on success")
    m.set_defaults(func=run_import_moveit)


def run_import_moveit(args: argparse.Namespace) -> int:
    from forte.exceptions import InvalidInputError
    from forte.io.moveit_import import check_task_out, task_document, write_task

    check_task_out(args.out)  # before any work: a foreign file is one line at once
    for option, path in (("REQUEST.yaml", args.request), ("--scene", args.scene)):
        if not path.is_file():
            raise InvalidInputError(f"{option} {path}: no such file")
    robot = None
    if args.robot:
        robot = {"preset": args.robot}
    elif args.urdf:
        if not args.ee_frame:
            raise InvalidInputError("--ee-frame: required with --urdf")
        urdf = args.urdf if args.urdf.startswith("erd:") else str(Path(args.urdf).resolve())
        robot = {"urdf": urdf, "ee_frame": args.ee_frame, "base": args.base}
    elif args.ee_frame:
        raise InvalidInputError("--ee-frame: only with --urdf")
    if args.payload is not None and not args.payload > 0:
        raise InvalidInputError(f"--payload: expected a mass > 0 kg, got {args.payload:g}")
    doc, notes = task_document(args.request, args.scene, args.out, robot, args.payload, args.floor)
    write_task(args.out, doc, (args.request, args.scene))
    if not args.quiet:
        for note in notes:
            print(f"forte: note: {note}", file=sys.stderr)
        goal = "joint goal" if "configuration" in doc["path"] else "pose goal"
        print(f"wrote {args.out} ({goal}, scene {doc['scene_file']}"
              f"{', no floor' if doc.get('floor') == 'none' else ''})", file=sys.stderr)
    return 0
