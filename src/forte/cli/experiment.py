"""``forte experiment {continuous,lift,hold,replan,wrench,contact,base}``: re-run the paper's experiments
(Sections 5.2-5.4) and the ones beyond it (online re-planning, offset payloads)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

#: Sub-command -> (function name in :mod:`forte.experiments`, paper section).
EXPERIMENTS: dict[str, tuple[str, str]] = {
    "continuous": ("run_continuous", "5.2, continuous trajectory with a time-varying force"),
    "lift": ("run_lift", "5.3, lifting with 0.33 L and 2.7 L payloads"),
    "hold": ("run_hold", "5.4, single-point holding with 0.33 L and 2.7 L payloads"),
    "replan": ("run_replan", "6 (future work), online re-planning with a misjudged or growing payload"),
    "mpc": ("run_mpc", "6 (future work), forte as a 100 Hz MPC against open loop and the 10 Hz re-planner"),
    "wrench": ("run_wrench", "6 (future work, issue 25), offset payloads: the wrench vs the force-only metric"),
    "contact": ("run_contact", "6 (future work, issue 25), contact-rich tasks: push, drawer, carry with a partner"),
    "base": ("run_base", "6 (beyond the paper, issue 39), the tip-over verdict against a base on the floor in MuJoCo"),
}
#: Figure formats (the same as :data:`forte.experiments.common.FORMATS`, kept here so that
#: ``forte --help`` does not import the planner).
FORMATS = ("png", "pdf", "svg")
#: The experiments that run the RFP baselines' weight sweep and take --weights and --torque-limits.
WEIGHTED: tuple[str, ...] = ("lift", "hold")
#: Upper bound of --trials (documented).
MAX_TRIALS = 1000


def register(sub: argparse._SubParsersAction) -> None:
    """Add ``forte experiment`` to the CLI."""
    p = sub.add_parser("experiment", help="re-run one of the paper's experiments (Sections 5.2-5.4)",
                       description="Plan, simulate and plot one of the paper's experiments; writes per-method "
                       "plan directories, figures, summary.json and summary.md (with a 'paper claim vs our "
                       "result' table; a claim about the simulation counts only if it holds in every trial) "
                       "to --out.")
    p.add_argument("name", choices=list(EXPERIMENTS),
                   help="; ".join(f"{k}: Section {v[1]}" for k, v in EXPERIMENTS.items()))
    p.add_argument("--out", type=Path, help="output directory (default runs/experiments/NAME)")
    p.add_argument("--trials", type=int,
                   help="simulation trials with a random +-10%% payload-mass error (continuous: planning repeats); "
                   "default: the paper's (lift, hold: 3; continuous: 6; replan runs once; mpc: 3 runs of each MPC "
                   "mode, whose outcome depends on the solve times)")
    p.add_argument("--waypoints", type=int, help="number of waypoints N (default: the task file's)")
    p.add_argument("--seed", type=int, default=0, help="seed of the mass errors (default 0)")
    p.add_argument("--format", dest="fmt", choices=FORMATS, default="png",
                   help="figure file format: png (default), or pdf / svg (vector)")
    p.add_argument("--no-weight-sweep", dest="weight_sweep", action="store_false",
                   help="lift, hold: skip the RFP baselines at 3, 10 and 30 times their capability weight (faster; "
                   "drops that table, its figure and its two claims)")
    p.add_argument("--weights", metavar="PRESET",
                   help="lift, hold: plan with this named weight set instead of the task file's (e.g. "
                   "authors-trajectory for the authors' exact lift set, authors-hold-as-run for holding with "
                   "the trajectory weights, see docs/formulas.md); the summary names the set it used")
    p.add_argument("--torque-limits", metavar="SET",
                   help="lift, hold: the arm's torque limits in planning and in every simulated run: paper (the "
                   "paper's 60/12 Nm, the default) or urdf (the URDF's efforts, 87/12 Nm on the Panda, a what-if); "
                   "the summary names the limits it used")
    p.add_argument("--offsets", type=float, nargs="+", metavar="M",
                   help="wrench: the payload's centre-of-mass offsets to the side of the hand, m (default 0 0.1 0.2)")
    p.add_argument("--quick", action="store_true",
                   help="base: each task's heaviest payload and one base-mode task only (8 plans instead of 19)")
    p.add_argument("--quiet", action="store_true", help="print nothing but errors")
    p.set_defaults(func=run_experiment)


def run_experiment(args: argparse.Namespace) -> int:
    """Run the chosen experiment; print its summary.md unless ``--quiet``."""
    import forte.experiments as experiments  # the runners load the planner and MuJoCo
    from forte.exceptions import InvalidInputError
    from forte.io.outputs import check_output, output_lock
    from forte.model.description import torque_limit_set
    from forte.settings import weight_set
    from forte.validation import MAX_WAYPOINTS

    if args.trials is not None and not 0 <= args.trials <= MAX_TRIALS:
        print(f"forte: error: --trials: expected 0 to {MAX_TRIALS}, got {args.trials}", file=sys.stderr)
        return 2
    if args.waypoints is not None and not 2 <= args.waypoints <= MAX_WAYPOINTS:
        print(f"forte: error: --waypoints: expected 2 to {MAX_WAYPOINTS}, got {args.waypoints}", file=sys.stderr)
        return 2
    if not getattr(args, "weight_sweep", True) and args.name not in WEIGHTED:
        print(f"forte: error: --no-weight-sweep: only lift and hold run the weight sweep, not {args.name}",
              file=sys.stderr)
        return 2
    offsets = getattr(args, "offsets", None)
    if offsets is not None and (args.name != "wrench" or not all(0.0 <= o <= 2.0 for o in offsets)):
        print(f"forte: error: --offsets: expected offsets of 0 to 2 m for the wrench experiment, got {offsets} "
              f"for {args.name}", file=sys.stderr)
        return 2
    weights = getattr(args, "weights", None)
    limits = getattr(args, "torque_limits", None)
    for option, value, what, check in (("--weights", weights, "a weight set", weight_set),
                                       ("--torque-limits", limits, "torque limits", torque_limit_set)):
        if value is None:
            continue
        if args.name not in WEIGHTED:
            print(f"forte: error: {option}: only lift and hold take {what}, not {args.name}", file=sys.stderr)
            return 2
        try:
            check(value)
        except InvalidInputError as exc:
            print(f"forte: error: {option}: {exc}", file=sys.stderr)
            return 2
    out = args.out or Path("runs") / "experiments" / args.name

    check_output(out)  # before minutes of planning: never replace what forte did not write

    def log(text: str) -> None:
        if not args.quiet:
            print(text, file=sys.stderr, flush=True)

    func = getattr(experiments, EXPERIMENTS[args.name][0])
    kwargs = {"waypoints": args.waypoints, "log": log, "fmt": getattr(args, "fmt", "png")}
    if args.trials is not None:  # otherwise the runner's default, the paper's count
        kwargs["trials"] = args.trials
    if args.name != "continuous":
        kwargs["seed"] = args.seed
    if not getattr(args, "weight_sweep", True):
        kwargs["weight_factors"] = ()
    if weights is not None:
        kwargs["weights"] = weights
    if offsets is not None:
        kwargs["offsets"] = tuple(offsets)
    if limits is not None:
        kwargs["torque_limits"] = limits
    if getattr(args, "quick", False):
        if args.name != "base":
            print(f"forte: error: --quick: only the base experiment has a quick version, not {args.name}",
                  file=sys.stderr)
            return 2
        kwargs["quick"] = True
    check_output(out)  # before any work: never run for minutes and then refuse
    with output_lock(out):
        check_output(out)
        func(out, **kwargs)
    if not args.quiet:
        report = out / "summary.md" if (out / "summary.md").exists() else out / "README.md"
        print(report.read_text())
        print(f"wrote {out}", file=sys.stderr)
    return 0
