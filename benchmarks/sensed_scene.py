"""Planning among sensed scenes: time and clearance against occupied cells and voxel size (issue 40).

    python benchmarks/sensed_scene.py [--voxels 0.06 0.02 0.0067] [--merge exact cover] [--slack 0.04]
                                      [--cover-boxes 128] [--max-boxes 5000] [--out FILE.md]

The task is examples/tasks/sensed-crate.yaml's motion (1 kg carried 2.4 m forward; the base
must drive around a crate, a table stands to its right); its scene is the truth of
examples/sensed_scene.py given four ways:

- ``primitives``: the crate and the table as two boxes (the reference);
- ``faces``: a cloud sampled on every face of both (spacing voxel / 3), as a scanner that saw
  all around them would give;
- ``faces + 1 cm``: that cloud with 1 cm Gaussian noise on every coordinate;
- ``depth``: one depth image from the example's camera (its resolution scaled so that a pixel
  covers about a third of a voxel at 2 m: 320 x 240 at 2 cm), ray-cast by MuJoCo without the robot.

Each sensed scene is read at each voxel size (floor points dropped, as a task file does), so the
occupied cells go from ~1k to ~400k, and its cells become boxes two ways: ``exact`` (the greedy
merge: the boxes' union is the cells) and ``cover`` (the default coarse cover: every cell in a
box, free space only within ``--slack`` of a cell (default two voxels, at least 4 cm), at most ``--cover-boxes`` boxes;
:mod:`forte.model.occupancy_cover`). A row reports the cells, the boxes, the cover's excess (the
farthest a box's point lies from an occupied cell) and added free volume, the time to make the
boxes, the wall time of ``forte.plan`` and its ratio to the primitives' planned just before it
(the machine's load drifts; a plan that compiled a new kernel, ``~/.cache/forte`` grew, is
planned again and the second time reported), and the
smallest exact clearance (coal; the waypoints and the executed spline between them) to the boxes
and to the true crate and table; primitives' and cover rows are also run in MuJoCo among the
boxes planned against (``touch``: a contact failed the run). A scene with more than
``--max-boxes`` boxes is reported, not planned. Nothing is asserted.
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from forte.execution.depth_camera import ray_depth
from forte.execution.run import simulate_plan
from forte.io.plandir import write_plan
from forte.model.clearance import clearances
from forte.model.occupancy import Intrinsics, boxes_as_objects, depth_points, occupancy, sensed_boxes
from forte.model.occupancy_cover import DEFAULT_MAX_BOXES, CoverSettings
from forte.model.scene import Scene, pose_matrix
from forte.planning.planner import plan
from forte.planning.tasks.tasks import load_task
from forte.planning.verdict.motion_samples import sample_motion

ROOT = Path(__file__).resolve().parents[1]


def example():
    spec = importlib.util.spec_from_file_location("sensed_example", ROOT / "examples" / "sensed_scene.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def face_points(scene: Scene, step: float) -> np.ndarray:
    """Points on every face of the scene's boxes, a grid of spacing <= ``step``, edges included."""
    out = []
    for o in scene.objects:
        lo, hi = o.pose[:3, 3] - np.array(o.shape.size) / 2, o.pose[:3, 3] + np.array(o.shape.size) / 2
        axes = [np.linspace(a, b, int(np.ceil((b - a) / step)) + 1) for a, b in zip(lo, hi, strict=True)]
        for k in range(3):
            i, j = [a for a in range(3) if a != k]
            u, v = np.meshgrid(axes[i], axes[j], indexing="ij")
            for side in (lo[k], hi[k]):
                face = np.empty((u.size, 3))
                face[:, i], face[:, j], face[:, k] = u.ravel(), v.ravel(), side
                out.append(face)
    return np.vstack(out)


def sensed_points(source: str, voxel: float, ex) -> np.ndarray:
    """The world points of one sensed ``source`` at ``voxel`` (m), the floor's dropped."""
    if source == "depth":
        s = 0.02 / voxel
        width, height = int(320 * s), int(240 * s)
        k = Intrinsics(200 * s, 200 * s, (width - 1) / 2, (height - 1) / 2)
        pose = pose_matrix(ex.CAMERA_POSE)
        points = depth_points(ray_depth(ex.TRUE_SCENE, pose, k, width, height, ex.MAX_RANGE), k, ex.MAX_RANGE, pose)
    else:
        points = face_points(ex.TRUE_SCENE, voxel / 3)
        if source == "faces + 1 cm":
            points = points + np.random.default_rng(0).normal(0.0, 0.01, points.shape)
    return points[points[:, 2] >= voxel]


def _kernels() -> int:
    root = Path(os.environ.get("FORTE_CACHE") or Path.home() / ".cache" / "forte")
    return len(list(root.glob("*.so"))) if root.is_dir() else 0


def planned(task, scene: Scene, truth: Scene, simulate: bool) -> dict:
    for _ in range(2):  # a plan that compiled a kernel is timed again
        before, t0 = _kernels(), time.perf_counter()
        result = plan(replace(task, scene=scene))
        seconds = time.perf_counter() - t0
        if _kernels() == before:
            break
    q = sample_motion(result.robot, result.t, result.q).q
    out = {"plan_s": seconds, "feasible": result.feasible,
           "own_m": float(clearances(result.robot, scene, q).distance.min()),
           "true_m": float(clearances(result.robot, truth, q).distance.min())}
    if simulate and result.feasible:
        with tempfile.TemporaryDirectory() as tmp:
            run = simulate_plan(write_plan(result, Path(tmp) / "plan", figures=False), hold=0.3, write=False)
        out["mujoco"] = "ok" if run.success and not run.summary.get("contacts") else f"touch ({run.detail})"
    return out


def rows(args: argparse.Namespace) -> list[dict]:
    ex = example()
    task = load_task(ROOT / "examples" / "tasks" / "sensed-crate.yaml")
    truth = ex.TRUE_SCENE
    plan(replace(task, scene=truth))  # compiles the kernels
    out = [{"source": "primitives", "voxel": "-", "cells": "-", "merge": "-", "boxes": len(truth.objects),
            "excess": 0.0, "added": 0.0, "boxes_s": 0.0, **planned(task, truth, truth, True)}]
    print(out[-1], flush=True)
    for source in ("faces", "faces + 1 cm", "depth"):
        for voxel in args.voxels:
            occ = occupancy(sensed_points(source, voxel, ex), voxel)
            for merge in args.merge:
                t0 = time.perf_counter()
                made = sensed_boxes(occ, CoverSettings(args.slack, args.cover_boxes) if merge == "cover" else None)
                objects = boxes_as_objects("sensed", occ, made.boxes)
                row = {"source": source, "voxel": voxel, "cells": occ.cells, "merge": merge, "boxes": len(objects),
                       "excess": made.excess, "added": made.free_cells * voxel**3,
                       "boxes_s": time.perf_counter() - t0}
                if len(objects) <= args.max_boxes:
                    row["primitives_s"] = planned(task, truth, truth, False)["plan_s"]  # the same load, just before
                    row.update(planned(task, Scene(objects, truth.floor), truth, merge == "cover"))
                out.append(row)
                print(row, flush=True)
    return out


def table(found: list[dict]) -> str:
    lines = ["| scene | voxel (m) | occupied cells | merge | boxes | excess (m) | added free (m^3) | boxes made (s) |"
             " plan (s) | x primitives | feasible | clearance to its boxes (m) | clearance to the truth (m) | MuJoCo |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in found:
        head = (f"| {r['source']} | {r['voxel']} | {r['cells']} | {r['merge']} | {r['boxes']} | {r['excess']:.3f} | "
                f"{r['added']:.3f} | {r['boxes_s']:.2f} |")
        if "plan_s" in r:
            ratio = r["plan_s"] / r.get("primitives_s", r["plan_s"])
            tail = (f" {r['plan_s']:.1f} | {ratio:.1f} | {'yes' if r['feasible'] else 'no'} | "
                    f"{r['own_m']:.3f} | {r['true_m']:.3f} | {r.get('mujoco', '-')} |")
        else:
            tail = " not planned (more boxes than --max-boxes) | | | | | |"
        lines.append(head + tail)
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--voxels", type=float, nargs="+", default=[0.06, 0.02, 0.0067])
    parser.add_argument("--merge", nargs="+", choices=("exact", "cover"), default=["exact", "cover"])
    parser.add_argument("--slack", type=float, help="the cover's slack (m; default: two voxels, at least 0.04)")
    parser.add_argument("--cover-boxes", type=int, default=DEFAULT_MAX_BOXES, help="the cover's box budget")
    parser.add_argument("--max-boxes", type=int, default=5000, help="scenes with more boxes are not planned")
    parser.add_argument("--out", type=Path)
    args = parser.parse_args()
    text = table(rows(args))
    print(text)
    if args.out:
        args.out.write_text(text)


if __name__ == "__main__":
    main()
