"""Planner benchmark (issue 3). Prints its figures; nothing is asserted.

Run: python benchmarks/bench_planner.py [--skip-slsqp] [--skip-first-ever]

1. cold ``forte plan examples/tasks/lift.yaml --waypoints 100`` in a fresh process, wall time
   including Python start-up, task loading, problem construction, solving and writing (kernels
   already compiled and cached), with and without figures; and the first-ever run (empty cache);
2. solve times of the forte NLP for N = 25, 50, 100, 200;
3. a naive SciPy SLSQP with finite-difference gradients on the same NLP at N = 25 (the
   comparison baseline, benchmarks/slsqp_baseline.py) against IPOPT with exact derivatives.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
LIFT = ROOT / "examples" / "tasks" / "lift.yaml"


def cold_run(extra: list[str], env: dict[str, str] | None = None) -> float:
    with tempfile.TemporaryDirectory() as out:
        start = time.perf_counter()
        subprocess.run([sys.executable, "-m", "forte.cli", "plan", str(LIFT), "--waypoints", "100", "--out",
                        str(Path(out) / "plan"), "--quiet", *extra], check=True, env=env)
        return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--skip-slsqp", action="store_true")
    parser.add_argument("--skip-first-ever", action="store_true")
    args = parser.parse_args()

    cold_run(["--no-figures"])  # make sure the kernels are cached
    runs = [cold_run(["--no-figures"]) for _ in range(3)]
    print(f"cold `forte plan lift.yaml --waypoints 100 --no-figures`: best {min(runs):.2f} s, "
          f"runs {', '.join(f'{r:.2f}' for r in runs)} s")
    runs = [cold_run([]) for _ in range(2)]
    print(f"cold `forte plan lift.yaml --waypoints 100` with the four figures: best {min(runs):.2f} s")
    if not args.skip_first_ever:
        with tempfile.TemporaryDirectory() as cache:
            env = dict(os.environ, FORTE_CACHE=cache)
            first = cold_run(["--no-figures"], env)
            print(f"first-ever run (empty kernel cache, compiles the forte kernels): {first:.2f} s")

    from forte.planning.planner import plan
    from forte.planning.tasks.tasks import load_task

    print("\nforte NLP solve times (IPOPT, exact derivatives, lift.yaml, 2.7 kg):")
    print("   N | iterations | solve (s) | coarse pass (s) | status")
    for n in (25, 50, 100, 200):
        res = plan(load_task(LIFT, waypoints=n), "forte")
        coarse = res.solver.get("coarse", {}).get("solve_time_s", 0.0)
        print(f"{n:4d} | {res.solver['iterations']:10d} | {res.solver['solve_time_s']:9.2f} | {coarse:15.2f} | "
              f"{res.status}")

    if not args.skip_slsqp:
        from slsqp_baseline import compare

        compare(25)


if __name__ == "__main__":
    sys.path.insert(0, str(Path(__file__).parent))
    main()
