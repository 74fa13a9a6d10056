"""Scaling benchmark (issue 15): time per IPOPT iteration against the horizon N. Prints its figures;
nothing is asserted.

Run: python benchmarks/bench_scaling.py [--repeats 3] [--waypoints 25 50 100 200 400] [--skip-cli]

1. for N = 25, 50, 100, 200, 400 on lift.yaml (forte, 2.7 kg), the planner's solve (coarse
   25-waypoint pass first for N > 50, as ``forte plan`` does): iterations, solve time (median of
   the repeats) and time per iteration, wall and CPU (best of the repeats; CPU time is less
   disturbed by other processes); for J5 in the default form (``dct_form: auto``: the formula up to 64 waypoints, the
   banded alternative beyond) and in the dense formula (the previous implementation);
2. the two forms compared: J5's exact value on each plan, the largest configuration difference;
3. the per-iteration ratio N = 400 / N = 100 of each form;
4. ``forte plan examples/tasks/lift.yaml --waypoints 100 --no-figures`` in a fresh process with
   the kernels cached: wall time, median of 5 runs after one warm-up.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path
from typing import NamedTuple

import numpy as np

from forte.planning.methods.catalog import get_method
from forte.planning.nlp.optimizer import TrajectoryOptimizer
from forte.planning.solve import coarse_guess, start_guess
from forte.planning.tasks.tasks import Task, load_task
from forte.planning.terms.reference import base_spectral_cost

ROOT = Path(__file__).resolve().parents[1]
LIFT = ROOT / "examples" / "tasks" / "lift.yaml"


class Solve(NamedTuple):
    form: str  # how J5 was solved (dense, banded, ...)
    iterations: int
    wall: float
    cpu: float
    q: np.ndarray
    j5: float  # J5's exact value on the plan


def solve(task: Task, dct_form: str) -> Solve:
    """The planner's solve (``forte.planning.solve.optimize``) with J5 in ``dct_form``, timed."""
    task = replace(task, settings=task.settings.with_values("base_spectral", form=dct_form))
    method = get_method("forte")
    force, nominal = task.force(), task.nominal()
    guess, options = start_guess(task, nominal), task.solver
    warm = coarse_guess(task, method)
    if warm is not None:
        guess = warm[0]
        options = replace(options, extra={"mu_strategy": "monotone", "mu_init": 1e-4} | options.extra)
    opt = TrajectoryOptimizer(task.robot, task.n, method, task.weights, options=options, limits=task.limits,
                              settings=task.settings)
    cpu = time.process_time()
    sol = opt.solve(task.t, task.targets, force.f, force.r, task.q_init, guess, nominal)
    cpu = time.process_time() - cpu
    if not sol.success:
        print(f"  (N = {task.n}, {dct_form}: {sol.status})")
    j5 = base_spectral_cost(sol.q[:, :3], opt.settings)
    return Solve(opt.quadratic_forms["base_spectral"], sol.iterations, sol.solve_time, cpu, sol.q, j5)


def per_iteration(runs: list[Solve]) -> tuple[float, float]:
    """Wall and CPU seconds per iteration, each the best of the repeats (the least disturbed by
    other processes on a shared machine)."""
    return (min(r.wall / max(r.iterations, 1) for r in runs), min(r.cpu / max(r.iterations, 1) for r in runs))


def cli_wall(repeats: int = 5) -> list[float]:
    """Wall times of ``forte plan lift.yaml --waypoints 100 --no-figures`` (after one warm-up)."""
    times = []
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(repeats + 1):
            out = Path(tmp) / f"plan{i}"
            start = time.perf_counter()
            subprocess.run([sys.executable, "-m", "forte.cli", "plan", str(LIFT), "--waypoints", "100",
                            "--no-figures", "--out", str(out), "--quiet"], check=True, capture_output=True)
            times.append(time.perf_counter() - start)
    return times[1:]


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--waypoints", type=int, nargs="+", default=[25, 50, 100, 200, 400])
    parser.add_argument("--skip-cli", action="store_true")
    args = parser.parse_args()

    forms = ("auto", "dense")
    results: dict[tuple[str, int], list[Solve]] = {}
    print(f"forte on lift.yaml (2.7 kg): the planner's solve of the N-waypoint NLP, {args.repeats} repeats "
          "(the coarse 25-waypoint pass is not counted)")
    print("   N | dct_form      | iterations | solve wall (s), median | per iteration wall / CPU (ms), best")
    for n in args.waypoints:
        task = load_task(LIFT, waypoints=n)
        for form in forms:
            runs = [solve(task, form) for _ in range(args.repeats)]
            results[form, n] = runs
            wall_it, cpu_it = per_iteration(runs)
            label, wall = f"{form} ({runs[0].form})", statistics.median(r.wall for r in runs)
            print(f"{n:4d} | {label:13s} | {runs[0].iterations:10d} | {wall:22.2f} | "
                  f"{1e3 * wall_it:8.1f} / {1e3 * cpu_it:8.1f}", flush=True)

    print("\nthe default form against the formula (J5's exact value on each plan; largest |q difference|):")
    for n in args.waypoints:
        a, d = results["auto", n][0], results["dense", n][0]
        print(f"{n:4d} | J5 {a.j5:.3e} ({a.form}) vs {d.j5:.3e} (dense) | "
              f"max |dq| base {np.abs(a.q - d.q)[:, :3].max():.1e}, arm {np.abs(a.q - d.q)[:, 3:].max():.1e}")

    if {100, 400} <= set(args.waypoints):
        print("\nper-iteration ratio N = 400 / N = 100 (wall, CPU):")
        for form in forms:
            w100, c100 = per_iteration(results[form, 100])
            w400, c400 = per_iteration(results[form, 400])
            print(f"  {form:6s}: {w400 / w100:.2f}, {c400 / c100:.2f}")

    if not args.skip_cli:
        runs = cli_wall()
        print(f"\n`forte plan lift.yaml --waypoints 100 --no-figures` (kernels cached): median "
              f"{statistics.median(runs):.2f} s, runs {', '.join(f'{r:.2f}' for r in runs)} s")


if __name__ == "__main__":
    main()
