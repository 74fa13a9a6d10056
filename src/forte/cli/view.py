"""``forte view PLAN_DIR``: interactive 3D replay in the Rerun viewer, or a recording (``--save``)."""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from forte.exceptions import InvalidInputError


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "view", help="replay a plan in 3D (Rerun): robot, paths, force, ball, RFP, capacity plots",
        description="Open the plan in the Rerun viewer: the robot's meshes along the plan, base and end-effector "
        "paths, the desired force with its uncertainty ball and the residual force polytope at each time, and "
        "capacity vs |f| +- r and manipulability over time. --save FILE.rrd writes a recording instead "
        "(open it later with 'rerun FILE.rrd').")
    p.add_argument("plan_dir", type=Path, metavar="PLAN_DIR", help="output folder of 'forte plan'")
    p.add_argument("--save", type=Path, metavar="FILE.rrd", help="write a recording instead of opening the viewer")
    p.add_argument("--quiet", action="store_true", help="print nothing on success")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from forte import progress
    from forte.io.viewer import record_plan

    if args.save is None and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        raise InvalidInputError("forte view: no display (DISPLAY is not set); write a recording with "
                                "--save FILE.rrd and open it with 'rerun FILE.rrd' where a display exists")
    with progress.step(f"recording {args.plan_dir} for Rerun"):
        saved = record_plan(args.plan_dir, save=args.save, spawn=args.save is None)
    if saved is not None and not args.quiet:
        print(f"wrote {saved}; open it with: rerun {saved}", file=sys.stderr)
    return 0
