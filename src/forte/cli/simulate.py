"""``forte simulate PLAN_DIR``: execute a plan in MuJoCo with the Section 3.1 controllers.

Exit codes: 0 when the verdict is success, 1 when it is failure (``sim.json`` says why and
when), 2 for user errors (missing/malformed plan directory, rendering unavailable).
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

# Offscreen rendering: MuJoCo picks its GL backend when it is first imported, so choose EGL
# (GPU or Mesa) before anything imports mujoco, unless the user chose a backend already.
if "mujoco" not in sys.modules:
    os.environ.setdefault("MUJOCO_GL", "egl")

from forte.exceptions import InvalidInputError  # noqa: E402


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``simulate`` sub-command to the ``forte`` parser."""
    p = sub.add_parser(
        "simulate",
        help="run a plan in MuJoCo (joint impedance arm + admittance base) and judge it",
        description="Interpolate the planned waypoints (clamped cubic spline), track them with the "
        "paper's controllers at 1 kHz and write PLAN_DIR/sim.csv and PLAN_DIR/sim.json.",
    )
    p.add_argument("plan_dir", type=Path, metavar="PLAN_DIR", help="output folder of 'forte plan'")
    p.add_argument("--mass", type=float, default=None,
                   help="true payload mass in kg (default: the plan's payload mass). A different "
                   "mass > 0 models an estimation error (the force feedforward keeps the plan's "
                   "force); 0 means no payload: no payload and no force feedforward")
    p.add_argument("--no-force", action="store_true",
                   help="switch the task-force feedforward tau_F = J^T f off (any mass)")
    p.add_argument("--out", type=Path, default=None, help="result folder (default: PLAN_DIR)")
    p.add_argument("--hold", type=float, default=1.0, help="seconds held after the last waypoint")
    p.add_argument("--stop-on-failure", action="store_true", help="stop at the first failure")
    p.add_argument("--sag", type=float, default=None, help="sustained sag threshold in m (0.03)")
    p.add_argument("--drop-sag", type=float, default=None, help="payload-drop sag in m (0.10)")
    p.add_argument("--saturation-time", type=float, default=None,
                   help="sustained torque saturation in s (0.25)")
    group = p.add_mutually_exclusive_group()
    group.add_argument("--video", type=Path, default=None, metavar="FILE.mp4",
                       help="render an mp4 (needs offscreen GL and ffmpeg)")
    group.add_argument("--frames", type=Path, default=None, metavar="DIR",
                       help="render PNG frames into DIR (needs offscreen GL)")
    p.add_argument("--quiet", action="store_true", help="print nothing on success")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from dataclasses import replace

    from forte.execution.judge import Thresholds
    from forte.execution.run import simulate_plan

    if args.video is not None and args.video.suffix.lower() != ".mp4":
        raise InvalidInputError(f"--video: expected a .mp4 file name, got {args.video}")
    th = Thresholds()
    overrides = {k: v for k, v in (("sag", args.sag), ("drop_sag", args.drop_sag),
                                   ("saturation_time", args.saturation_time)) if v is not None}
    th = replace(th, **overrides)
    result = simulate_plan(
        args.plan_dir, args.mass, force_feedforward=False if args.no_force else None,
        out_dir=args.out, thresholds=th, hold=args.hold,
        stop_on_failure=args.stop_on_failure, frames_dir=args.frames, video=args.video,
    )
    out = args.out or args.plan_dir
    s = result.summary
    if result.success:
        if not args.quiet:
            print(f"success: {s['duration']:.2f} s simulated in {s['wall_time_s']:.2f} s, max end-effector "
                  f"error {1000 * s['max_ee_error_m']:.1f} mm; wrote {out}/sim.csv, {out}/sim.json")
        return 0
    print(f"failure at t = {result.failure_time:.3f} s: {result.reason} ({result.detail}); "
          f"wrote {out}/sim.csv, {out}/sim.json", file=sys.stderr)
    return 1
