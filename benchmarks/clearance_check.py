"""What the exact clearance check costs: N = 100 waypoints, 0, 10 and 100 scene bodies.

    python benchmarks/clearance_check.py

The plan is the lift task's quintic baseline at N = 100 (the check does not depend on how the
plan was made). The bodies are boxes, cylinders, spheres and capsules of 5-40 cm at seeded random
poses within 3 m of the path (the 10-body scene is the first 10 of the 100). Printed per scene,
best of 3 runs:

- ``check``: the exact clearance at every sample the verdict judges (the waypoints and 8 steps
  per interval of the executed spline: 893 samples), :class:`forte.model.clearance.ClearanceChecker`;
- ``verdict``: the whole verdict with the scene (:func:`forte.planning.verdict.verdict.judge_plan`), and
  its increase over the empty scene;
- ``narrow``: the coal distance calls the broad phase lets through, per sample;
- ``min 8 / 64``: the minimum clearance on the verdict's grid and on one 8 times finer.

Then, is the verdict's grid dense enough for clearance? Over 40 seeded scenes of 30 bodies, on
the lift's quintic plan at N = 41 (the shipped density), the largest amount by which the minimum
clearance on a grid of 64 steps per interval falls below the minimum on the verdict's 8, among
the scenes the plan clears.
"""

from __future__ import annotations

import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from forte.model.clearance import ClearanceChecker
from forte.model.scene import Box, Capsule, Cylinder, Scene, SceneObject, Sphere, pose_matrix
from forte.planning.planner import plan
from forte.planning.tasks.tasks import load_task
from forte.planning.verdict.motion_samples import sample_motion
from forte.planning.verdict.verdict import judge_plan

ROOT = Path(__file__).resolve().parents[1]
REPEATS = 3


def random_scene(n: int, seed: int = 0) -> Scene:
    rng = np.random.default_rng(seed)
    objects = []
    for i in range(n):
        size = rng.uniform(0.05, 0.4, 3)
        shape = [Box(tuple(size)), Cylinder(size[0] / 2, size[2]), Sphere(size[0] / 2),
                 Capsule(size[0] / 2, size[2])][i % 4]
        centre = [rng.uniform(-2.0, 3.0), rng.uniform(-2.5, 2.5), rng.uniform(0.0, 2.0)]
        objects.append(SceneObject(f"body{i}", shape, pose_matrix([*centre, *rng.uniform(-np.pi, np.pi, 3)])))
    return Scene(tuple(objects))


def best_of(fn) -> tuple[float, object]:
    times, out = [], None
    for _ in range(REPEATS):
        start = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - start)
    return min(times), out


def main() -> int:
    task = load_task(ROOT / "examples" / "tasks" / "lift.yaml", waypoints=100)
    res = plan(task, "quintic")
    samples = sample_motion(task.robot, task.t, res.q)
    fine = sample_motion(task.robot, task.t, res.q, 64).q
    full = random_scene(100)
    base_verdict = None
    print(f"lift, quintic, N = {task.n}: {len(samples.t)} samples judged (8 per interval)")
    for n in (0, 10, 100):
        scene = Scene(full.objects[:n])
        t_check, found = best_of(lambda s=scene: ClearanceChecker(task.robot, s).evaluate(samples.q))
        t_verdict, _ = best_of(lambda s=scene: judge_plan(replace(task, scene=s), res.q, res.force))
        base_verdict = t_verdict if base_verdict is None else base_verdict
        calls = count_narrow(task.robot, scene, samples.q)
        fine_min = ClearanceChecker(task.robot, scene).evaluate(fine).distance.min()
        print(f"  {n:3d} bodies: check {1e3 * t_check:7.1f} ms ({1e6 * t_check / len(samples.t):5.0f} us/sample), "
              f"verdict {1e3 * t_verdict:7.1f} ms (+{1e3 * (t_verdict - base_verdict):6.1f} ms), "
              f"narrow {calls:5.2f} calls/sample, min 8 / 64: {found.distance.min():.4f} / {fine_min:.4f} m")
    grid_gap()
    return 0


def grid_gap(scenes: int = 40) -> None:
    task = load_task(ROOT / "examples" / "tasks" / "lift.yaml")
    q = plan(task, "quintic").q
    coarse, fine = (sample_motion(task.robot, task.t, q, k).q for k in (8, 64))
    gaps = []
    for seed in range(scenes):
        scene = random_scene(30, seed)
        at_8 = ClearanceChecker(task.robot, scene).evaluate(coarse).distance.min()
        if at_8 > 0:
            gaps.append(at_8 - ClearanceChecker(task.robot, scene).evaluate(fine).distance.min())
    print(f"grid: lift, quintic, N = {task.n}: {len(gaps)} of {scenes} scenes cleared; min clearance at 64 "
          f"per interval below the one at 8 by at most {1e3 * max(gaps):.3f} mm")


def count_narrow(robot, scene: Scene, Q: np.ndarray) -> float:
    """Mean number of coal distance calls per sample (the pairs the broad phase lets through)."""
    import coal

    calls = 0
    original = coal.distance

    def counted(*args):
        nonlocal calls
        calls += 1
        return original(*args)

    coal.distance = counted
    try:
        ClearanceChecker(robot, scene).evaluate(Q)
    finally:
        coal.distance = original
    return calls / len(Q)


if __name__ == "__main__":
    sys.exit(main())
