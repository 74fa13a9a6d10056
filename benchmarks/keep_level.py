"""keep_level on examples/tasks/carry-level.yaml: the plan without ``path.keep_level`` and with it,
the exact tilt on the executed spline (the verdict's samples) and at the waypoints.

    python benchmarks/keep_level.py [TASK]
"""

from __future__ import annotations

import copy
import sys
import time
from pathlib import Path

import numpy as np
import yaml

from forte.planning.planner import plan
from forte.planning.tasks.keep_level import read_keep_level, tilt_angles
from forte.planning.tasks.schema import Reader
from forte.planning.tasks.tasks import task_from_dict
from forte.planning.verdict.motion_samples import sample_motion

ROOT = Path(__file__).resolve().parents[1]


def main(path: Path) -> None:
    spec = yaml.safe_load(path.read_text())
    keep = read_keep_level(Reader(spec["path"], path, "path."))
    for constrained in (False, True):
        data = copy.deepcopy(spec)
        if not constrained:
            data["path"].pop("keep_level")
        task = task_from_dict(data, path)
        start = time.perf_counter()
        result = plan(task)
        wall = time.perf_counter() - start
        samples = sample_motion(task.robot, result.t, result.q)
        tilt = np.degrees(tilt_angles(keep, samples.ee[:, :3, :3]))
        rounds = result.solver.get("refinement", {}).get("rounds", [])
        print(f"keep_level {'on ' if constrained else 'off'}: {result.verdict.label}; tilt on the spline "
              f"{tilt.max():.2f} deg, at the waypoints {tilt[samples.waypoint].max():.2f} deg (limit "
              f"{np.degrees(keep.max_tilt):g}); duration {result.t[-1]:.2f} s; {len(rounds)} refinement "
              f"round(s); wall {wall:.2f} s")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "examples" / "tasks" / "carry-level.yaml")
