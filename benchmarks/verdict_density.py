"""Is the verdict's grid dense enough? The worst value of every judged quantity at 8 samples per
interval against 64, on the shipped tasks' plans.

    python benchmarks/verdict_density.py

For each task and method the script plans once, samples the executed motion at 8 and at 64 steps
per interval (:mod:`forte.planning.verdict.motion_samples`), and prints, per measure, the worst value on
each grid and their difference (relative to the measure's limit scale: 1 for ratios, the
tolerance for tracking, 1 N for forces).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

from forte.planning.planner import plan
from forte.planning.tasks.tasks import load_task
from forte.planning.verdict.motion_samples import sample_motion
from forte.planning.verdict.requirements import REQUIREMENTS
from forte.planning.verdict.verdict import _task_targets, context

ROOT = Path(__file__).resolve().parents[1]
CASES = (("lift.yaml", 2.7, ("forte", "quintic", "manipulability")), ("lift.yaml", 0.35, ("forte",)),
         ("lift-path.yaml", 0.35, ("forte",)), ("continuous.yaml", None, ("forte", "rfp-radius")))


def worst_values(task, q, force, per_interval: int) -> dict[str, float]:
    samples = sample_motion(task.robot, task.t, q, per_interval)
    ctx = context(task.robot, samples, force, task.settings.alpha, _task_targets(task), task.limits, {}, False)
    out = {}
    for req in REQUIREMENTS:
        for i, m in enumerate(req.measures(ctx)):
            if m.units and m.value.size:
                out[f"{req.name}[{i}] ({m.units})"] = float(np.max(m.value))
    return out


def main() -> int:
    worst_gap = 0.0
    for file, mass, methods in CASES:
        task = load_task(ROOT / "examples" / "tasks" / file, mass=mass)
        for method in methods:
            res = plan(task, method)
            t0 = time.perf_counter()
            coarse = worst_values(task, res.q, res.force, 8)
            spent = time.perf_counter() - t0
            fine = worst_values(task, res.q, res.force, 64)
            print(f"{file} {mass or ''} {method} (N = {task.n}; 8 per interval judged in {spent:.2f} s)")
            for key in coarse:
                gap = fine[key] - coarse[key]
                scale = {"N": 1.0, "m": 0.01, "rad": 0.05}.get(key.split("(")[-1].rstrip(")"), 1.0)
                worst_gap = max(worst_gap, gap / scale)
                print(f"  {key:28s} 8/interval {coarse[key]:10.4g}   64/interval {fine[key]:10.4g}   "
                      f"gap {gap:+.3g}")
    print(f"largest gap relative to its scale (1 N, 1 x limit, 1 cm, 0.05 rad): {worst_gap:.3g}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
