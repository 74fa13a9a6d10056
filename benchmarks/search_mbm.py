"""Configuration-space search (forte.planning.search) on MotionBenchMaker's Panda problems.

Per problem: search time, states sampled, collision checks, time per check, found or not; then
the medians. Usage::

    python benchmarks/search_mbm.py [--per-scenario 2] [--time-limit 2.0] [--seed 0]

TEMPORARY: ``read_problem`` below is a minimal reader of MoveIt's PlanningScene and
MotionPlanRequest YAML (primitives with quaternion poses), only for this measurement; the real
reader is forte's MoveIt import (issue 38, item 7).
"""

from __future__ import annotations

import argparse
import time
from functools import partial
from pathlib import Path

import numpy as np
import yaml

from forte.model.robot import MobileManipulator
from forte.model.scene import Box, Cylinder, Scene, SceneObject, Sphere
from forte.planning.search import sampling
from forte.planning.search.sampling import find_path
from forte.planning.search.validity import StateChecker

ROOT = Path(__file__).resolve().parents[1]
FINGERS_OPEN = {"panda_finger_joint1": 0.04, "panda_finger_joint2": 0.04}
PROBLEMS = Path("/work/shared/benchmarks/motionbenchmaker/panda")


def _pose(p: dict) -> np.ndarray:
    """A MoveIt pose (position, quaternion x y z w) as 4x4."""
    x, y, z, w = p["orientation"]
    T = np.eye(4)
    T[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                 [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                 [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    T[:3, 3] = p["position"]
    return T


def read_problem(scene_file: Path, request_file: Path) -> tuple[Scene, np.ndarray, np.ndarray]:
    """TEMPORARY minimal reader: the scene (no floor) and forte's start and goal (base at 0)."""
    objects = []
    for obj in yaml.safe_load(scene_file.read_text())["world"]["collision_objects"]:
        frame = _pose(obj["pose"]) if "pose" in obj else np.eye(4)
        for k, (prim, pose) in enumerate(zip(obj["primitives"], obj["primitive_poses"], strict=True)):
            d = prim["dimensions"]
            kind = prim["type"]
            shape = Box(tuple(d)) if kind == "box" else Cylinder(d[1], d[0]) if kind == "cylinder" else Sphere(d[0])
            name = obj["id"] if len(obj["primitives"]) == 1 else f"{obj['id']}_{k}"
            objects.append(SceneObject(name, shape, frame @ _pose(pose)))
    request = yaml.safe_load(request_file.read_text())
    start = np.array(request["start_state"]["joint_state"]["position"][:7], dtype=float)
    goal = {c["joint_name"]: c["position"] for c in request["goal_constraints"][0]["joint_constraints"]}
    goal_q = np.array([goal[f"panda_joint{i}"] for i in range(1, 8)])
    return Scene(tuple(objects), None), np.r_[0.0, 0.0, 0.0, start], np.r_[0.0, 0.0, 0.0, goal_q]


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--per-scenario", type=int, default=2)
    ap.add_argument("--time-limit", type=float, default=2.0)
    ap.add_argument("--clearance", type=float, default=0.0)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--mbm-geometry", action="store_true",
                    help="the fingers open at 0.04 m (the request's 0.065 clipped to the URDF) and no base box, "
                         "as MotionBenchMaker's robot; default: forte's model (fingers closed, base box)")
    args = ap.parse_args()
    robot = MobileManipulator(urdf="erd:panda_description/urdf/panda.urdf", ee_frame="panda_hand", base="fixed")
    if args.mbm_geometry:
        sampling.StateChecker = partial(StateChecker, locked=FINGERS_OPEN, base_box=False)
    rows = []
    for scenario in sorted(PROBLEMS.iterdir()):
        for i in range(1, args.per_scenario + 1):
            scene, start, goal = read_problem(scenario / f"scene{i:04d}.yaml", scenario / f"request{i:04d}.yaml")
            checker = sampling.StateChecker(robot, scene, args.clearance)
            probe = np.random.default_rng(i).uniform(robot.lower, robot.upper, (300, 7))
            t0 = time.perf_counter()
            for qa in probe:
                checker.valid(np.r_[0.0, 0.0, 0.0, qa])
            per_check = (time.perf_counter() - t0) / len(probe)
            r = find_path(robot, scene, start, goal, args.clearance, time_limit=args.time_limit, seed=args.seed)
            rows.append((scenario.name, i, r.found, r.time_s, r.states, r.checks, per_check, r.reason))
            print(f"{scenario.name:26s} {i:04d} found={r.found!s:5s} {r.time_s * 1e3:8.1f} ms states={r.states:6d} "
                  f"checks={r.checks:7d} check={per_check * 1e6:6.1f} us "
                  f"waypoints={0 if r.q is None else len(r.q):3d} {r.reason}", flush=True)
    found = [r for r in rows if r[2]]
    times = np.array([r[3] for r in rows])
    print(f"\nfound {len(found)}/{len(rows)}; search time median {np.median(times) * 1e3:.0f} ms, "
          f"p95 {np.percentile(times, 95) * 1e3:.0f} ms; states median {np.median([r[4] for r in rows]):.0f}; "
          f"checks median {np.median([r[5] for r in rows]):.0f}; check time median "
          f"{np.median([r[6] for r in rows]) * 1e6:.1f} us (random states)")


if __name__ == "__main__":
    main()
