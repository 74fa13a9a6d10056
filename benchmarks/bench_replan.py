"""Re-planning benchmark (issue 14). Prints its figures; nothing is asserted.

Run: python benchmarks/bench_replan.py [--replans 60] [--waypoints 41]

1. latency of warm re-plans (:class:`forte.planning.replan.Replanner`) after payload-mass
   changes on the lift task: a seeded sequence of masses between 0.3 and 3.3 kg, each re-plan
   starting from the previous solution (median, p95, max, iterations, failures);
2. the same for a shifted receding horizon (one waypoint per re-plan, wrapping around);
3. the cold solve of the same problem for reference.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from forte.planning.planner import plan
from forte.planning.replan import Replanner
from forte.planning.tasks import load_task

LIFT = Path(__file__).resolve().parents[1] / "examples" / "tasks" / "lift.yaml"


def report(name: str, latencies: list[float], iterations: list[int], failures: int) -> None:
    ms = 1000 * np.asarray(latencies)
    print(f"{name}: {len(ms)} re-plans, median {np.median(ms):.1f} ms, p95 {np.percentile(ms, 95):.1f} ms, "
          f"max {ms.max():.1f} ms; iterations median {int(np.median(iterations))}, max {max(iterations)}; "
          f"not converged: {failures}")


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--replans", type=int, default=60)
    parser.add_argument("--waypoints", type=int, default=41)
    args = parser.parse_args()
    task = load_task(LIFT, waypoints=args.waypoints)
    start = time.perf_counter()
    planner = Replanner(task)
    print(f"lift, N = {task.n}: first solve (build + cold) {time.perf_counter() - start:.2f} s, "
          f"{planner.last.iterations} iterations")
    cold = plan(task, "forte")
    print(f"cold `plan` of the same task: {cold.solver['solve_time_s'] * 1000:.0f} ms solve, "
          f"{cold.solver['iterations']} iterations")

    rng = np.random.default_rng(0)
    lat, its, fails = [], [], 0
    for mass in rng.uniform(0.3, 3.3, args.replans):
        r = planner.replan(mass=float(mass))
        lat.append(r.latency_s)
        its.append(r.iterations)
        fails += not r.plan.success
    report("mass changes (0.3-3.3 kg, seeded)", lat, its, fails)

    planner = Replanner(task)
    lat, its, fails = [], [], 0
    for _ in range(args.replans):
        r = planner.shift(1)
        lat.append(r.latency_s)
        its.append(r.iterations)
        fails += not r.plan.success
    report("receding horizon, shifted one waypoint per re-plan", lat, its, fails)


if __name__ == "__main__":
    main()
