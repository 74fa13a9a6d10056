"""``forte simulate PLAN_DIR``: execute a plan in MuJoCo with the Section 3.1 controllers.

Exit codes: 0 when the verdict is success, 1 when it is failure (``sim.json`` says why and
when; a touch of the plan's scene or of the floor is one: the line names the bodies), 2 for
user errors (missing/malformed plan directory or gains file, rendering or display unavailable).

Controller gains: the defaults of :mod:`forte.execution.gains` (Franka's on the Panda, the
bandwidth rule ``K_i = M_ii (2 pi f)^2``, ``D_i = 2 zeta sqrt(K_i M_ii)`` on other arms);
the task file's ``controller:`` block (recorded in plan.json) replaces them; ``--gains FILE.yaml``
holds a ``controller:`` mapping (or the mapping's fields at the top level) used instead of the
task's, and ``--bandwidth`` / ``--damping-ratio`` set the rule's ``f`` and ``zeta`` on top.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path
from typing import Any

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
    p.add_argument("--mass", "--true-mass", dest="mass", type=float, default=None,
                   help="true payload mass in kg (default: the plan's payload mass). A different "
                   "mass > 0 models an estimation error (the force feedforward keeps the plan's "
                   "force); 0 means no payload: the feedforward keeps only the tool's share of the force")
    p.add_argument("--reference", choices=("spline", "plan"), default="spline",
                   help="controller reference: a clamped cubic spline through the waypoints (default), or "
                   "'plan': the plan's own backward-difference velocities and accelerations at every waypoint "
                   "(quintic Hermite)")
    p.add_argument("--no-force", action="store_true",
                   help="switch the task-force feedforward tau_F = J^T f off (any mass)")
    p.add_argument("--out", type=Path, default=None, help="result folder (default: PLAN_DIR)")
    p.add_argument("--hold", type=float, default=1.0, help="seconds held after the last waypoint")
    p.add_argument("--stop-on-failure", action="store_true", help="stop at the first failure")
    p.add_argument("--sag", type=float, default=None, help="sustained sag threshold in m (0.03)")
    p.add_argument("--drop-sag", type=float, default=None, help="payload-drop sag in m (0.10)")
    p.add_argument("--saturation-time", type=float, default=None,
                   help="sustained torque saturation in s (0.25)")
    p.add_argument("--gains", type=Path, default=None, metavar="FILE.yaml",
                   help="controller gains: a 'controller:' mapping (K_a, D_a, bandwidth_hz, damping_ratio, "
                   "M_b, B_b, K_b, D_b, base_feedforward, force_feedforward, base_coupling, "
                   "force_along_reference)")
    p.add_argument("--bandwidth", type=float, default=None, metavar="HZ",
                   help="arm gain rule K_i = M_ii (2 pi HZ)^2 (default: Franka's gains on the Panda, 4 Hz "
                   "on other arms)")
    p.add_argument("--damping-ratio", type=float, default=None, metavar="Z",
                   help="arm gain rule D_i = 2 Z sqrt(K_i M_ii) (default 1)")
    group = p.add_mutually_exclusive_group()
    group.add_argument("--video", type=Path, default=None, metavar="FILE.mp4",
                       help="render an mp4 (needs offscreen GL and ffmpeg)")
    group.add_argument("--frames", type=Path, default=None, metavar="DIR",
                       help="render PNG frames into DIR (needs offscreen GL)")
    group.add_argument("--viewer", action="store_true",
                       help="watch the run in MuJoCo's interactive viewer, in real time (needs a display); "
                       "the results are written when the run ends, the command returns when the window "
                       "is closed")
    p.add_argument("--replan", action="store_true",
                   help="identify the payload from the joint torques and re-plan the remaining motion at "
                   "--replan-rate when the estimate departs from the plan's mass")
    p.add_argument("--replan-rate", type=float, default=10.0, metavar="HZ", help="re-plan check rate (10 Hz)")
    p.add_argument("--add-mass", type=_time_and_mass, default=None, metavar="T:KG",
                   help="the payload gains KG kilograms at time T seconds (with or without --replan, --mpc)")
    p.add_argument("--mpc", type=float, default=None, metavar="HZ",
                   help="model-predictive control: re-solve the remaining motion at HZ (simulated time) from the "
                   "measured state for the newest payload estimate; a solve over its 1/HZ deadline is a miss "
                   "(not with --replan)")
    p.add_argument("--on-miss", choices=("drop", "delay"), default=None,
                   help="--mpc: a solve over its deadline is dropped (default), or published once simulated time "
                   "has caught up with its wall-clock time (the solver busy meanwhile)")
    p.add_argument("--deadline", type=float, default=None, metavar="S",
                   help="--mpc: wall-clock budget of a solve in seconds (default 1/HZ)")
    p.add_argument("--estimate-at", type=_time_and_mass, action="append", default=None, metavar="T:KG",
                   help="--mpc: an asynchronous payload estimate of KG kilograms (e.g. a VLM answer) arrives at "
                   "time T seconds (repeatable)")
    p.add_argument("--mpc-solver", choices=("rti", "stagewise", "ipopt"), default=None,
                   help="--mpc: one real-time iteration of the stagewise solver per tick (rti, default), or a "
                   "warm re-plan to convergence with the stagewise solver or IPOPT")
    p.add_argument("--mpc-start", choices=("reference", "measured", "rest"), default=None,
                   help="--mpc: the motion a shifted horizon starts with: the controller reference's at the "
                   "splice (default), the measured velocity, or at rest")
    p.add_argument("--on-infeasible", choices=("splice", "keep", "stop"), default=None,
                   help="--replan, --mpc: a converged re-plan whose verdict is not feasible is spliced anyway "
                   "(default: measured best), the plan in force kept, or the robot stopped at the next waypoint")
    p.add_argument("--no-identify", action="store_true",
                   help="--mpc: no identification from the joint torques: only --estimate-at changes the mass")
    p.add_argument("--base-model", choices=("kinematic", "floor"), default="kinematic",
                   help="kinematic: the base on slide joints and a yaw hinge (cannot tip or slip; default); floor: a "
                        "free body on wheels and casters that can tip and slip, judged on tip-over, slip and leaving "
                        "its path")
    p.add_argument("--quiet", action="store_true", help="print nothing on success")
    p.set_defaults(func=run)


def _time_and_mass(text: str) -> tuple[float, float]:
    try:
        t, kg = (float(v) for v in text.split(":"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected T:KG (seconds:kilograms), got {text!r}") from None
    if not (t >= 0 and kg > 0):
        raise argparse.ArgumentTypeError(f"expected T >= 0 s and KG > 0, got {text!r}")
    return t, kg


def _replan_options(args: argparse.Namespace) -> object | None:
    if args.on_infeasible is not None and not args.replan and args.mpc is None:
        raise InvalidInputError("--on-infeasible: applies to --replan and --mpc runs only")
    if not args.replan and args.add_mass is None:
        return None
    from forte.execution.closed_loop import ReplanOptions

    # without --replan a mass change is simulated (and identified) but never re-planned for
    return ReplanOptions(rate_hz=args.replan_rate, add_mass=args.add_mass, enabled=args.replan,
                         on_infeasible=args.on_infeasible or "splice")


def _mpc_options(args: argparse.Namespace) -> object | None:
    mpc_only = (("--on-miss", args.on_miss is not None), ("--deadline", args.deadline is not None),
                ("--estimate-at", bool(args.estimate_at)), ("--no-identify", args.no_identify),
                ("--mpc-solver", args.mpc_solver is not None), ("--mpc-start", args.mpc_start is not None))
    if args.mpc is None:
        for flag, given in mpc_only:
            if given:
                raise InvalidInputError(f"{flag}: applies to --mpc runs only")
        return None
    if args.replan:
        raise InvalidInputError("--mpc: expected one closed loop, got --replan too")
    from forte.execution.mpc import MpcOptions

    try:
        return MpcOptions(rate_hz=args.mpc, deadline_s=args.deadline, on_miss=args.on_miss or "drop",
                          identify=not args.no_identify, add_mass=args.add_mass,
                          estimates=tuple(args.estimate_at or ()),
                          solver="rti" if args.mpc_solver in (None, "rti") else "converged",
                          backend=args.mpc_solver if args.mpc_solver in ("stagewise", "ipopt") else "stagewise",
                          start=args.mpc_start or "reference", on_infeasible=args.on_infeasible or "splice")
    except InvalidInputError as exc:  # name the flag, not the field
        field, _, rest = str(exc).partition(": ")
        flag = {"rate_hz": "--mpc", "deadline_s": "--deadline"}.get(field, field)
        raise InvalidInputError(f"{flag}: {rest}") from None


def run(args: argparse.Namespace) -> int:
    from dataclasses import replace

    from forte.execution.judge import Thresholds
    from forte.execution.run import simulate_plan
    from forte.io.outputs import output_lock

    if args.video is not None and args.video.suffix.lower() != ".mp4":
        raise InvalidInputError(f"--video: expected a .mp4 file name, got {args.video}")
    _check_arguments(args)
    mpc = _mpc_options(args)
    th = Thresholds()
    overrides = {k: v for k, v in (("sag", args.sag), ("drop_sag", args.drop_sag),
                                   ("saturation_time", args.saturation_time)) if v is not None}
    th = replace(th, **overrides)
    gains = _gains(args)
    if args.viewer:
        from forte.execution.render import check_display

        check_display()
        if not args.quiet:
            print("viewer: the run plays in real time; close the window to finish", file=sys.stderr)
    out = args.out or args.plan_dir
    from forte import progress

    with output_lock(out), progress.step(f"simulating {args.plan_dir} in MuJoCo (1 kHz)"):
        result = simulate_plan(  # one writer of sim.csv / sim.json at a time
            args.plan_dir, args.mass, force_feedforward=False if args.no_force else None,
            out_dir=args.out, gains=gains, thresholds=th, hold=args.hold,
            stop_on_failure=args.stop_on_failure, frames_dir=args.frames, video=args.video, viewer=args.viewer,
            replan=None if mpc is not None else _replan_options(args), reference=args.reference, mpc=mpc,
            base_model=args.base_model,
        )
    s = result.summary
    if not args.quiet and s.get("plan_verdict") not in (None, "feasible"):
        failed = ", ".join(s.get("plan_verdict_failed") or ())
        print(f"note: the plan's verdict is {s['plan_verdict']}" + (f" ({failed})" if failed else "")
              + "; simulating it anyway", file=sys.stderr)
    if result.success:
        if not args.quiet:
            print(f"success: {s['duration']:.2f} s simulated in {s['wall_time_s']:.2f} s, max end-effector "
                  f"error {1000 * s['max_ee_error_m']:.1f} mm; wrote {out}/sim.csv, {out}/sim.json")
    if "replanning" in s and not args.quiet:
        r = s["replanning"]
        latency = (f"; latency median {1000 * r['latency_median_s']:.0f} ms, p95 {1000 * r['latency_p95_s']:.0f} ms, "
                   f"max {1000 * r['latency_max_s']:.0f} ms" if r["replans"] else "")
        print(f"payload estimate {r['final_mass_estimate']:.3f} kg (sigma {r['final_sigma']:.4f}); "
              f"{r['replans']} re-plans ({r['replans_failed']} not converged, {r['replans_infeasible']} not "
              f"feasible: {r['on_infeasible']}){latency}", file=sys.stderr)
    if "mpc" in s and not args.quiet:
        print(_mpc_line(s["mpc"]), file=sys.stderr)
    if result.success:
        return 0
    print(f"failure at t = {result.failure_time:.3f} s: {result.reason} ({result.detail}){_touched(result)}; "
          f"wrote {out}/sim.csv, {out}/sim.json", file=sys.stderr)
    return 1


def _mpc_line(m: dict[str, Any]) -> str:
    """The one console line of an MPC run."""
    times = (f"; solve time median {1000 * m['solve_median_s']:.1f} ms, p95 {1000 * m['solve_p95_s']:.1f} ms, "
             f"max {1000 * m['solve_max_s']:.1f} ms" if m["solves"] else "")
    estimate = "" if m["final_sigma"] is None else f" (sigma {m['final_sigma']:.4f})"
    kind = "real-time iterations" if m.get("solver") == "rti" else f"converged {m.get('backend', 'ipopt')} solves"
    return (f"MPC at {m['rate_hz']:g} Hz ({kind}): {m['ticks']} ticks, {m['solves']} solves "
            f"({m['published']} published, "
            f"{m['misses']} over the {1000 * m['deadline_s']:g} ms deadline, {m['failed']} "
            f"{'not sound' if m.get('solver') == 'rti' else 'not converged'}){times}; "
            f"min d {m['min_d']:.2f} N; payload estimate {m['final_mass_estimate']:.3f} kg{estimate}")


def _touched(result: Any, shown: int = 3) -> str:
    """The pairs that touched (robot body - world body, first time, peak force), for the failure
    line (nothing when the failure's own detail names the only one)."""
    pairs = result.summary.get("contacts") or []
    if not pairs or (result.reason == "contact" and len(pairs) == 1):
        return ""
    text = ", ".join(f"{c['robot']}-{c['world']} from t = {c['first_time']:.3f} s (peak {c['peak_force_N']:.1f} N)"
                     for c in pairs[:shown])
    more = f" and {len(pairs) - shown} more" if len(pairs) > shown else ""
    return f"; {len(pairs)} pair{'s' if len(pairs) > 1 else ''} touched: {text}{more}"


def _check_arguments(args: argparse.Namespace) -> None:
    """Numbers in range and output paths forte may write, before the (long) simulation."""
    from forte.io.outputs import check_output
    from forte.io.plandir import read_plan_dir
    from forte.validation import MAX_HOLD_S, payload_mass

    if args.mass is not None:
        payload_mass(args.mass, "--mass", allow_zero=True)  # 0: no payload
    for flag, value, low, high in (("--hold", args.hold, 0.0, MAX_HOLD_S),
                                   ("--sag", args.sag, 1e-9, 10.0), ("--drop-sag", args.drop_sag, 1e-9, 10.0),
                                   ("--saturation-time", args.saturation_time, 1e-9, MAX_HOLD_S)):
        if value is not None and not low <= value <= high:  # NaN fails too
            raise InvalidInputError(f"{flag}: expected a number in [{low:g}, {high:g}], got {value}")
    read_plan_dir(args.plan_dir)  # a missing or tampered plan directory: one line, now
    if args.out is not None:
        out = Path(args.out)
        if out.exists() and out.is_dir() and not _simulation_folder(out):
            raise InvalidInputError(f"--out {out}: holds files forte did not write; expected a new folder, an empty "
                                    "one or a plan directory")
        if not out.is_dir():
            check_output(out)
    if args.frames is not None:
        frames = Path(args.frames)
        if frames.exists() and (not frames.is_dir() or any(
                not p.name.startswith("frame_") for p in frames.iterdir())):
            raise InvalidInputError(f"--frames {frames}: exists and is not a folder of forte's frames; "
                                    "expected a new or empty folder")
        if not frames.exists():
            check_output(frames, "--frames")
    if args.video is not None and Path(args.video).is_dir():
        raise InvalidInputError(f"--video {args.video}: is a directory; expected a .mp4 file name")


def _simulation_folder(folder: Path) -> bool:
    """An empty folder, a plan directory, or one holding only forte's simulation results."""
    from forte.io.outputs import is_forte_output

    names = {p.name for p in folder.iterdir()}
    return not names or is_forte_output(folder) or names <= {"sim.csv", "sim.json"}


def _gains(args: argparse.Namespace) -> Any:
    """``ControlGains`` from ``--gains`` (else the task's ``controller:`` block recorded in plan.json)
    with ``--bandwidth``/``--damping-ratio`` on top, or None (defaults).

    The fields are checked against the plan's robot here, so that errors name the file.
    """
    from forte.execution.gains import gains_from_mapping
    from forte.io.plandir import PLAN_FILE, read_controller, read_plan_dir
    from forte.model.robot import N_BASE

    if args.gains is not None:
        mapping, prefix = _read_gains_file(args.gains)
    else:
        mapping = read_controller(args.plan_dir) if (args.plan_dir / PLAN_FILE).is_file() else {}
        prefix = f"{args.plan_dir / PLAN_FILE}: controller."
    if not mapping and args.bandwidth is None and args.damping_ratio is None:
        return None
    for flag, key, value in (("--bandwidth", "bandwidth_hz", args.bandwidth),
                             ("--damping-ratio", "damping_ratio", args.damping_ratio)):
        if value is not None:
            if not value > 0 or value == float("inf"):
                raise InvalidInputError(f"{flag}: expected a finite number > 0, got {value}")
            mapping[key] = value
    plan = read_plan_dir(args.plan_dir)
    return gains_from_mapping(mapping, plan.robot, q_a=plan.q[0, N_BASE:], prefix=prefix)


def _read_gains_file(path: Path) -> tuple[dict[str, Any], str]:
    """The gains mapping of ``path`` and the prefix naming its fields in errors.

    The file holds a ``controller:`` mapping (as in a task file; other top-level keys are
    ignored) or the mapping's fields at the top level.
    """
    import yaml

    if not path.is_file():
        raise InvalidInputError(f"--gains {path}: file does not exist")
    try:
        data = yaml.safe_load(path.read_text())
    except yaml.MarkedYAMLError as exc:
        line = f"line {exc.problem_mark.line + 1}: " if exc.problem_mark is not None else ""
        raise InvalidInputError(f"{path}: {line}not valid YAML: {exc.problem or exc.context}") from exc
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as exc:
        raise InvalidInputError(f"{path}: cannot read: {exc}") from exc
    where, prefix = str(path), f"{path}: "
    if isinstance(data, dict) and "controller" in data:
        data, where, prefix = data["controller"], f"{path}: controller", f"{path}: controller."
    if data is None:  # an empty file or block: the defaults
        return {}, prefix
    if not isinstance(data, dict):
        raise InvalidInputError(f"{where}: expected a mapping of gains (K_a, D_a, bandwidth_hz, ...), "
                                f"got {type(data).__name__}")
    return dict(data), prefix
