"""``forte sweep SWEEP.yaml``: run a grid of plans and simulations in parallel, resumably.

Exit codes: 0 when every cell of the grid has a result (failed plans and simulations are
results: they are rows of the table); 2 for a bad sweep or task file, an output directory forte
may not use (or one another forte process is writing), ``--ray`` without Ray installed or with
an address it cannot reach, and a worker process that died while the sweep ran (killed for
memory, a native crash, a lost Ray node: the environment, like the others; the finished cells
are kept); 130 when interrupted (SIGTERM counts as an interruption, with the pool or ``--ray``).
Whenever a sweep stops early, the table is rebuilt from the finished cells and running the same
command again resumes.
"""

from __future__ import annotations

import argparse
import signal
import sys
from pathlib import Path

from forte.exceptions import InvalidInputError

#: Upper bound of --workers (documented).
MAX_WORKERS = 4096


def register(sub: argparse._SubParsersAction) -> None:
    """Add ``forte sweep`` to the CLI."""
    p = sub.add_parser(
        "sweep", help="run a grid (tasks x methods x masses x mass-error trials) on a process pool or Ray",
        description="Plan every (task, waypoints, method, payload mass) of the grid that SWEEP.yaml describes, "
        "simulate each plan (nominal run, mass-error trials, optionally without payload) and write one table "
        "(results.csv, and results.parquet when pyarrow is installed) and summary figures to --out. Finished "
        "cells are stored as they complete: running the same command again skips them (resume).")
    p.add_argument("sweep", type=Path, metavar="SWEEP.yaml", help="sweep file (see examples/sweeps/)")
    p.add_argument("--out", type=Path, help="output directory (default runs/sweeps/NAME); a new or empty "
                   "directory, or one of an earlier run of a sweep (resumed)")
    p.add_argument("--workers", type=int, default=None,
                   help="parallel workers (default: the CPUs available); with --ray and no address, the CPUs of "
                   "the local Ray instance")
    p.add_argument("--ray", nargs="?", const="local", default=None, metavar="ADDRESS",
                   help="run on Ray: a local instance (no ADDRESS), or the cluster at ADDRESS (auto, HOST:PORT or "
                   "ray://HOST:PORT; its nodes need forte installed; write --ray=ADDRESS, or --ray after SWEEP.yaml). "
                   "Needs Ray: pip install 'forte[ray]'")
    p.add_argument("--no-figures", action="store_true", help="write the table only")
    p.add_argument("--dry-run", action="store_true", help="check the sweep file and print the grid's size and "
                   "how many cells are finished, without computing anything")
    p.add_argument("--quiet", action="store_true", help="print nothing but errors")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run (or resume) the sweep; print where the table is unless ``--quiet``."""
    from forte.experiments.sweep.executors import check_ray
    from forte.experiments.sweep.run import default_out, run_sweep
    from forte.experiments.sweep.spec import plan_groups, read_sweep
    from forte.experiments.sweep.store import SweepDir

    if args.workers is not None and not 1 <= args.workers <= MAX_WORKERS:
        raise InvalidInputError(f"--workers: expected 1 to {MAX_WORKERS}, got {args.workers}")
    spec = read_sweep(args.sweep)
    out = args.out or default_out(spec)
    if args.dry_run:
        cells = [c for g in plan_groups(spec) for c in g.cells]
        store = SweepDir(out)
        store.check()
        done = len(store.finished(cells)) if out.is_dir() else 0
        print(f"{spec.name}: {len(cells)} cells ({len({(c.task_file, c.waypoints, c.method, c.mass) for c in cells})} "
              f"plans); {done} finished in {out}, {len(cells) - done} to compute")
        return 0
    SweepDir(out).check()  # before loading tasks: never work for minutes and then refuse
    if args.ray is not None:
        check_ray()

    def log(text: str) -> None:
        if not args.quiet:
            print(text, file=sys.stderr, flush=True)

    previous = signal.signal(signal.SIGTERM, _interrupt)  # a batch scheduler's stop: keep the table current
    try:
        result = run_sweep(spec, out, workers=args.workers, ray=args.ray, figures=not args.no_figures, log=log)
    finally:
        signal.signal(signal.SIGTERM, previous)
    if not args.quiet:
        errors = f"; {result.errors} with an error (see the table's error column)" if result.errors else ""
        print(f"{result.status}: {result.finished}/{result.cells} cells ({result.computed} computed now, "
              f"{result.skipped} from earlier runs){errors}; wrote {result.out} ({', '.join(result.files)})")
    return 0


def _interrupt(signum: int, frame: object) -> None:
    raise KeyboardInterrupt
