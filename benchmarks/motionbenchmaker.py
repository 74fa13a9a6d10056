"""MotionBenchMaker's problems as forte goal tasks: plan, judge, simulate, and the table.

Each problem (a MoveIt ``sceneNNNN.yaml`` + ``requestNNNN.yaml`` pair, one folder per scenario) is
imported as ``forte import moveit`` does (the fixed-base Panda, the fingers at the request's start,
``floor: none``: MotionBenchMaker's worlds have no floor), then:

- ``--stage search``: only the configuration-space search (:func:`forte.planning.search.find_path`);
- ``--stage plan`` (default): ``forte.plan`` (search when the straight motion collides, retiming,
  the NLP with the scene's rows, the verdict), then MuJoCo with the scene (``--no-sim``: not).

Success = a feasible verdict (it includes the exact clearance along the executed motion) and a
MuJoCo run that touches nothing. Writes ``results.csv`` (one row per problem: verdict, failed
requirements, wall time, the time of each stage, duration, path length, minimum clearance, the
MuJoCo outcome) and ``summary.md`` (success per scenario, median and p95 time, failures by
reason) into ``--out``. Usage::

    python benchmarks/motionbenchmaker.py DIR [--out runs/mbm] [--payload 1.5] [--per-scenario N]
        [--workers 2] [--stage plan|search] [--no-sim]

``DIR`` holds one folder per scenario (e.g. ``bookshelf_small_panda/``). Times are per problem in
a worker process, with the kernel cache warm (run once to fill it). The workers run with the
``forte`` command's environment (:data:`forte.system.SINGLE_THREAD_ENV`: one BLAS/OpenMP thread
where the environment says nothing): with a thread per core in each library, 2 workers on 2
cores spent a third more CPU and the median problem took 1.75-1.86 s instead of 1.51-1.53 s
(16 problems, 0020-0023 of 4 scenarios, shared machine).
"""

from __future__ import annotations

import argparse
import csv
import os
import tempfile
import time
import traceback
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

from forte.system import SINGLE_THREAD_ENV

for _name, _value in SINGLE_THREAD_ENV.items():  # before NumPy loads its BLAS (it reads them once)
    os.environ.setdefault(_name, _value)

import numpy as np  # noqa: E402

FIELDS = ["scenario", "problem", "success", "verdict", "failed", "reason", "wall_s", "search_s", "shortcut_s",
          "retime_s", "nlp_s", "verdict_s", "sim_s", "duration_s", "toppra_s", "limiting", "path_length_rad",
          "min_clearance_m",
          "sim", "sim_detail", "searched", "iterations", "route_plan", "sim_ee_error_m"]


def problems(root: Path, per_scenario: int | None, scenarios: list[str] | None) -> list[tuple[str, Path, Path]]:
    out = []
    for folder in sorted(p for p in root.iterdir() if p.is_dir()):
        if scenarios and folder.name not in scenarios:
            continue
        requests = sorted(folder.glob("request*.yaml"))[:per_scenario]
        out += [(folder.name, r, folder / r.name.replace("request", "scene")) for r in requests]
    return out


#: The clearance the tasks keep (m): MotionBenchMaker's goals are grasps, the fingers within 1-2 cm
#: of the object, and its success is no collision (MoveIt's padding 0).
CLEARANCE = 0.0


def load(request: Path, scene: Path, folder: Path, payload: float | None, route_first: bool = False,
         base: str = "fixed") -> Any:
    """The problem as forte's goal task (what ``forte import moveit --floor none`` writes, with
    ``clearance:`` :data:`CLEARANCE`, and ``solver.route_first`` when asked); ``base: holonomic``
    puts the same arm on the authors' base (:func:`on_the_base`)."""
    from forte.io.moveit_import import task_document, write_task
    from forte.planning.tasks.tasks import load_task

    out = folder / "task.yaml"
    doc, _ = task_document(request, scene, out, payload=payload, floor="none")
    doc["clearance"] = CLEARANCE
    if route_first:
        doc.setdefault("solver", {})["route_first"] = True
    if base == "holonomic":
        return on_the_base(doc, request, scene, out)
    write_task(out, doc, (request, scene))
    return load_task(out)


#: The authors' arm mount on their base (m, base frame): the holonomic variant's arm sits here.
AUTHORS_MOUNT = (0.2575, 0.0, 0.52)


def scene_entries(scene: Path, mount: Any) -> list[dict[str, Any]]:
    """The PlanningScene's boxes and cylinders as task ``scene:`` entries, each placed by ``mount``
    (4 x 4): the world of the arm's base becomes the mount's frame on the mobile base."""
    import pinocchio as pin

    from forte.model.scene import Box, Cylinder
    from forte.model.scene_files import read_scene_file

    entries = []
    for body in read_scene_file(scene):
        pose = mount @ body.pose
        shape = ({"box": {"size": [float(x) for x in body.shape.size]}} if isinstance(body.shape, Box) else
                 {"cylinder": {"radius": float(body.shape.radius), "length": float(body.shape.length)}}
                 if isinstance(body.shape, Cylinder) else None)
        if shape is None:
            raise ValueError(f"{scene}: {body.name}: only boxes and cylinders are placed on the base")
        entries.append({"name": body.name, **shape,
                        "pose": [*map(float, pose[:3, 3]), *map(float, pin.rpy.matrixToRpy(pose[:3, :3]))]})
    return entries


def on_the_base(doc: dict[str, Any], request: Path, scene: Path, out: Path) -> Any:
    """The problem with the Panda on the authors' holonomic base (arm at :data:`AUTHORS_MOUNT`, the
    base at the origin at the start, the scene placed relative to the mount) and the goal as the
    hand's pose at the goal configuration (default tolerances): the base may end anywhere."""
    from forte.io.moveit_import import write_task
    from forte.planning.tasks.tasks import load_task

    mount = np.eye(4)
    mount[:3, 3] = AUTHORS_MOUNT
    doc["robot"] |= {"base": "holonomic", "mount": {"xyz": list(AUTHORS_MOUNT)}}
    doc.pop("scene_file")  # written relative to the task file: read the request's own scene instead
    doc["scene"] = scene_entries(scene, mount)
    goal = np.asarray(doc["path"]["configuration"], dtype=float)  # its pose only: may lie beyond the URDF's range
    doc["path"] = {"kind": "goal", "configuration": doc["initial_configuration"]}
    write_task(out, doc, (request, scene))
    pose = load_task(out).robot.ee_pose(goal)
    doc["path"] = {"kind": "goal", "pose": {"position": [float(x) for x in pose[:3, 3]],
                                            "orientation": {"matrix": pose[:3, :3].tolist()}}}
    write_task(out, doc, (request, scene))
    return load_task(out)


def search_only(task: Any) -> dict[str, Any]:
    from forte.planning.search import find_path
    from forte.planning.search.route import SEARCH_CHECKS, SEARCH_TIME_LIMIT

    goal = task.goal.configuration if getattr(task, "goal", None) is not None else None
    result = find_path(task.robot, task.scene, task.q_init, goal, task.clearance, seed=task.solver.hold_seed,
                       time_limit=SEARCH_TIME_LIMIT, checks=SEARCH_CHECKS)  # as forte.plan's search
    return {"success": result.found, "verdict": "found" if result.found else "not found",
            "reason": result.reason or f"{result.checks} checks, kept clearance {result.clearance:.4f} m",
            "search_s": result.time_s, "shortcut_s": result.shortcut_s, "searched": True}


def plan_and_simulate(task: Any, folder: Path, simulate: bool, gains: dict[str, Any] | None = None) -> dict[str, Any]:
    import forte
    from forte.execution.run import simulate_plan
    from forte.io.plandir import write_plan

    begin = time.perf_counter()
    plan = forte.plan(task)
    wall = time.perf_counter() - begin
    info = plan.solver
    search = info.get("search", {})
    row: dict[str, Any] = {
        "verdict": plan.verdict.label, "failed": " ".join(plan.verdict.failed),
        "reason": "" if plan.feasible else plan.verdict.reason()[:200], "wall_s": wall,
        "search_s": search.get("time_s", 0.0), "searched": bool(search.get("searched", False)),
        "shortcut_s": search.get("shortcut_s", np.nan), "retime_s": search.get("retime_s", np.nan),
        "nlp_s": info.get("solve_time_s", np.nan), "duration_s": float(plan.t[-1] - plan.t[0]),
        "toppra_s": search.get("toppra_duration_s", np.nan), "limiting": search.get("limiting", ""),
        "path_length_rad": float(np.abs(np.diff(plan.q[:, 3:], axis=0)).sum()),
        "iterations": info.get("iterations", -1),
        "refine_rounds": len(info.get("refinement", {}).get("rounds", [])),
        "route_plan": bool(info.get("fallback", {}).get("kept", False) or info.get("route_first", {}).get("kept")),
        "min_clearance_m": np.nan if plan.verdict.clearance is None else plan.verdict.clearance.get("min_m",
                                                                                                   np.nan),
    }
    row["success"] = plan.feasible
    if plan.task is not None:  # one verdict of the final plan, timed on its own
        from forte.planning.verdict.verdict import judge_plan

        begin = time.perf_counter()
        judge_plan(plan.task, plan.q, plan.force, plan.solver)
        row["verdict_s"] = time.perf_counter() - begin
    if info.get("path_blocked"):  # the stage that failed: the search (its reason), not the straight line's verdict
        row["failed"] = str(plan.status).split(":")[0] + ": " + str(plan.status).split(":")[1].strip().split(" in ")[0]
        row["reason"] = str(plan.status)[:200]
    if simulate and plan.feasible:
        directory = folder / "plan"
        write_plan(plan, directory)
        begin = time.perf_counter()
        result = simulate_plan(directory, gains=gains)  # a controller: mapping (--base-coupling), else the defaults
        row["sim_s"] = time.perf_counter() - begin
        row["sim"], row["sim_detail"] = ("ok" if result.success else "fail"), ("" if result.success else result.detail)
        row["sim_ee_error_m"] = result.summary.get("max_ee_error_m", np.nan)  # how closely MuJoCo tracked the hand
        row["success"] = bool(result.success)
    return row


def run_one(args: tuple[str, Path, Path, float | None, str, bool, bool, str, dict[str, Any] | None]) -> dict[str, Any]:
    scenario, request, scene, payload, stage, simulate, route_first, base, gains = args
    row: dict[str, Any] = {"scenario": scenario, "problem": request.stem.replace("request", "")}
    try:
        with tempfile.TemporaryDirectory() as tmp:
            task = load(request, scene, Path(tmp), payload, route_first, base)
            row |= search_only(task) if stage == "search" else plan_and_simulate(task, Path(tmp), simulate, gains)
    except Exception as exc:  # a benchmark row, not a crash: the reason is the result
        row |= {"success": False, "verdict": "error", "reason": f"{type(exc).__name__}: {exc}"[:300],
                "sim_detail": traceback.format_exc(limit=2)[-300:]}
    return row


def _num(r: dict[str, Any], key: str) -> float:
    try:
        return float(r.get(key) or "nan")
    except (TypeError, ValueError):
        return float("nan")


def _tracking(feasible: list[dict[str, Any]]) -> str:
    """The hand's largest tracking error in MuJoCo over the simulated plans (median and largest)."""
    errors = [_num(r, "sim_ee_error_m") for r in feasible]
    errors = [e for e in errors if np.isfinite(e)]
    if not errors:
        return ""
    return (f"; the hand tracked the plan to {1000 * np.median(errors):.1f} mm (median of each run's largest "
            f"error), {1000 * max(errors):.1f} mm at most")


def summary(rows: list[dict[str, Any]], command: str) -> str:
    """Success per scenario with the median and p95 wall time, the stages' median times, the
    verdict against MuJoCo, the chosen durations against toppra's, and the failures by reason."""
    ok = [str(r["success"]) == "True" for r in rows]
    lines = [f"Command: `{command}`", "", "| scenario | problems | success | median s | p95 s |",
             "|---|---|---|---|---|"]
    for scenario in sorted({r["scenario"] for r in rows}) + ["all"]:
        sel = [i for i, r in enumerate(rows) if scenario in ("all", r["scenario"])]
        wall = np.array([_num(rows[i], "wall_s") for i in sel])
        good = sum(ok[i] for i in sel)
        lines.append(f"| {scenario} | {len(sel)} | {good} ({100 * good / len(sel):.0f} %) | "
                     f"{np.nanmedian(wall):.2f} | {np.nanpercentile(wall, 95):.2f} |")
    stages = ("search_s", "shortcut_s", "retime_s", "nlp_s", "verdict_s", "sim_s")
    med = {k: np.nanmedian([_num(r, k) for r in rows]) for k in stages}
    searched = sum(str(r.get("searched")) == "True" for r in rows)
    feasible = [r for r in rows if r.get("verdict") == "feasible"]
    sim_ok = sum(r.get("sim") == "ok" for r in feasible)
    ratio = [_num(r, "duration_s") / _num(r, "toppra_s") for r in feasible if _num(r, "toppra_s") > 0]
    solved = [_num(r, "iterations") for r in feasible if _num(r, "iterations") >= 0]  # route plans: no NLP
    lines += ["", f"- Stages (median over the problems that reached them): search {med['search_s']:.2f} s "
              f"({searched} of {len(rows)} problems searched; the others' straight line was free; of it, "
              f"shortcutting {med['shortcut_s']:.2f} s), retiming (toppra) {med['retime_s']:.2f} s, "
              f"NLP solve {med['nlp_s']:.2f} s, one verdict {med['verdict_s']:.2f} s, MuJoCo run {med['sim_s']:.2f} s.",
              f"- Verdict against MuJoCo: {len(feasible)} plans called feasible, {sim_ok} of them ran in MuJoCo "
              f"without a touch or a failure, {len(feasible) - sim_ok} did not{_tracking(feasible)}.",
              f"- Durations: forte's over toppra's time-optimal one along the same route, median "
              f"{np.nanmedian(ratio) if ratio else float('nan'):.2f} (no payload: toppra's x 1.5, longer where "
              "the verdict asked for slower rounds).",
              f"- Plans that are the route itself (the searched route, timed by toppra, judged feasible as it is: "
              f"before any NLP with `--route-first`, else after the optimized plan was not feasible): "
              f"{sum(str(r.get('route_plan')) == 'True' for r in feasible)} of the {len(feasible)} feasible plans.",
              f"- NLP: median {np.nanmedian(solved or [np.nan]):.0f} "
              f"IPOPT iterations in the kept solve; {sum(_num(r, 'refine_rounds') > 0 for r in feasible)} of the "
              f"feasible plans needed a refinement round (the verdict's spline checks after the NLP's rows)."]
    reasons: dict[str, int] = {}
    for r, good in zip(rows, ok, strict=True):
        if not good:
            key = r.get("failed") or r.get("verdict", "")
            if r.get("verdict") == "error":
                key = "refused: " + str(r.get("reason", "")).split("task.yaml: ")[-1].split(" = ")[0]
            elif r.get("verdict") == "feasible":
                key = f"MuJoCo: {str(r.get('sim_detail', ''))[:60]}"
            reasons[key] = reasons.get(key, 0) + 1
    lines += ["", "| failure (failed requirements, or the stage) | problems |", "|---|---|"]
    lines += [f"| {k} | {v} |" for k, v in sorted(reasons.items(), key=lambda kv: -kv[1])]
    return "\n".join(lines) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("root", type=Path)
    ap.add_argument("--out", type=Path, default=Path("runs/mbm"))
    ap.add_argument("--payload", type=float, default=None)
    ap.add_argument("--per-scenario", type=int, default=None)
    ap.add_argument("--scenarios", nargs="*")
    ap.add_argument("--only", nargs="*", metavar="SCENARIO/NNNN", help="only these problems (e.g. cage_panda/0005)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--stage", choices=("plan", "search"), default="plan")
    ap.add_argument("--no-sim", action="store_true")
    ap.add_argument("--base", choices=("fixed", "holonomic"), default="fixed",
                    help="holonomic: the arm on the authors' base, the goal as the hand's pose")
    ap.add_argument("--route-first", action="store_true",
                    help="solver.route_first: a route that passes the verdict is the plan, no NLP")
    ap.add_argument("--base-coupling", action="store_true",
                    help="simulate with controller.base_coupling (the arm's feedforward with the base's motion)")
    ap.add_argument("--summarize", type=Path, help="only write summary.md from this results.csv")
    args = ap.parse_args()
    if args.summarize:
        with open(args.summarize, newline="") as handle:
            rows = list(csv.DictReader(handle))
        text = summary(rows, "python benchmarks/motionbenchmaker.py " + str(args.root) + " --workers 2")
        args.out.mkdir(parents=True, exist_ok=True)
        (args.out / "summary.md").write_text(text)
        print(text)
        return
    gains = {"base_coupling": True} if args.base_coupling else None
    todo = [(s, r, sc, args.payload, args.stage, not args.no_sim, args.route_first, args.base, gains)
            for s, r, sc in problems(args.root, args.per_scenario, args.scenarios)
            if not args.only or f"{s}/{r.stem.replace('request', '')}" in args.only]
    args.out.mkdir(parents=True, exist_ok=True)
    rows = []
    with ProcessPoolExecutor(max_workers=args.workers) as pool, \
            open(args.out / "results.csv", "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=FIELDS, extrasaction="ignore")
        writer.writeheader()
        for row in pool.map(run_one, todo):
            rows.append(row)
            writer.writerow(row)
            handle.flush()
            print(f"{row['scenario']:26s} {row['problem']} {row.get('verdict', ''):14s} "
                  f"{float(row.get('wall_s', row.get('search_s', 0)) or 0):6.2f} s {row.get('failed', '')} "
                  f"{row.get('reason', '')[:100]}", flush=True)
    import sys

    text = summary(rows, "python benchmarks/motionbenchmaker.py " + " ".join(sys.argv[1:]))
    (args.out / "summary.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
