"""Planning time with 0, 1, 10 and 100 scene bodies, at N = 41 and N = 100.

    python benchmarks/scene_planning.py [--repeats 3]

The task drives the end effector 2.4 m forward past a crate that stands on the straight base
path (examples/tasks/around-the-crate.yaml); the other bodies (boxes, cylinders and spheres,
seeded) stand at least 1.2 m to the side of the path, where the broad phase should drop them. For
each size the script plans once to compile the kernels, then reports the median wall time of
``forte.plan`` (solve, broad phase, verdict and metrics) over the repeats, the clearance rows and
IPOPT's iterations. Scenes: "empty" (the straight path through where the crate would be: a plan
in free space); "100 away from the path" (the same motion is clear, so only the broad phase and
the checks cost: the 2x target is against "empty"); "crate" (the base must go around it: a
different, harder problem); "crate + 9" and "crate + 99" (the broad phase's cost on top of the
crate's).
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from forte.model.scene import Box, Cylinder, Scene, SceneObject, Sphere, pose_matrix
from forte.planning.planner import plan
from forte.planning.tasks.tasks import load_task

ROOT = Path(__file__).resolve().parents[1]


def clutter(count: int, seed: int = 0) -> tuple[SceneObject, ...]:
    """``count`` seeded bodies at least 1.2 m to the side of the path (|y| >= 1.2 m)."""
    rng = np.random.default_rng(seed)
    out = []
    for i in range(count):
        side = rng.choice([-1.0, 1.0])
        x, y = rng.uniform(-1.0, 4.0), side * rng.uniform(1.2, 4.0)
        kind = i % 3
        shape = (Box(tuple(rng.uniform(0.1, 0.5, 3))), Cylinder(rng.uniform(0.05, 0.2), rng.uniform(0.2, 1.5)),
                 Sphere(rng.uniform(0.05, 0.25)))[kind]
        out.append(SceneObject(f"clutter{i}", shape, pose_matrix([x, y, rng.uniform(0.2, 1.2), 0, 0,
                                                                  rng.uniform(-np.pi, np.pi)])))
    return tuple(out)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    base = load_task(ROOT / "examples" / "tasks" / "around-the-crate.yaml")
    crate = base.scene.objects
    print(f"{'N':>4} {'scene':>22} {'median s':>9} {'rows':>6} {'iters':>6} {'verdict':>11}")
    cases = (("empty", Scene()), ("100 away from the path", Scene(clutter(100))), ("crate", Scene(crate)),
             ("crate + 9", Scene(crate + clutter(9))), ("crate + 99", Scene(crate + clutter(99))))
    for n in (41, 100):
        for label, scene in cases:
            task = replace(base.resampled(n), scene=scene)
            plan(task)  # compile the kernels of this size once
            times = []
            for _ in range(args.repeats):
                start = time.perf_counter()
                result = plan(task)
                times.append(time.perf_counter() - start)
            rounds = result.solver.get("clearance_rows", {}).get("rounds", [{}])
            print(f"{n:>4} {label:>22} {np.median(times):>9.2f} {rounds[-1].get('rows', 0):>6} "
                  f"{result.solver.get('iterations', -1):>6} {result.label:>11}")


if __name__ == "__main__":
    main()
