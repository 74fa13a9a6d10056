"""Does the plan's clearance verdict agree with MuJoCo's contacts? The three scene examples.

For each scene example (``around-the-crate``, ``table-to-shelf``, ``through-the-doorway``) every
method that applies (``forte compare``'s list) plans twice:

- ``scene``: the task as written, among its bodies;
- ``no scene``: the same task without its bodies (``replace(task, scene=Scene())``), then judged
  and simulated WITH them: the plan does not know the bodies are there, so some of these hit.

Each plan is judged (:mod:`forte.planning.verdict.verdict`: the ``clearance`` requirement measures the real
meshes with coal on the dense grid and asks for the task's ``clearance:`` margin) and executed in
MuJoCo with the scene built in and contacts on (``forte simulate``'s defaults,
:func:`forte.execution.run.simulate_plan`; the run does not stop at the first failure, so every
pair that touches is recorded; a plan whose solve failed is run on its last iterate, the motion
its verdict judged). Prints one row per plan and the agreement of the clearance
requirement with MuJoCo's touches of a scene body (a touch of the floor is counted apart: the
clearance requirement is about the scene, not the floor), over every run and over the runs that
followed the plan up to their first touch (no earlier failure: a run whose arm saturated and
sagged has left the motion the verdict judged). A run that touches after another failure, while
its clearance passes, is run once more with the robot's torque limits times
:data:`STRONG` (the same plan, executed faithfully): no touch then means the planned motion
was clear. ``--out FILE.json`` keeps the rows.

    python benchmarks/scene_vs_mujoco.py                       # 3 tasks x 7 methods x 2, ~3 min on 2 cores
    python benchmarks/scene_vs_mujoco.py --tasks around-the-crate --methods forte quintic
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TASKS = ("around-the-crate", "table-to-shelf", "through-the-doorway")
VARIANTS = ("scene", "no scene")
#: Torque limits times this in the rerun of a run that touched after another failure.
STRONG = 10.0


def without_scene_judged_with(task, method: str):
    """Plan ``task`` without its bodies, then judge it (and record it) among them."""
    from forte.model.scene import Scene
    from forte.planning.methods.catalog import get_method
    from forte.planning.planner import evaluate, plan
    from forte.planning.verdict.verdict import judge_plan

    blind = plan(replace(task, scene=Scene()), method)
    seen = replace(blind.task, scene=task.scene)  # the resolved task (payload), with the bodies back
    verdict = judge_plan(seen, blind.q, blind.force, blind.solver if get_method(method).optimized else None)
    metrics = evaluate(seen.robot, blind.q, seen.t, blind.force, seen.settings.capability_params, seen.scene)
    return replace(blind, task=seen, scene=task.scene, verdict=verdict, metrics=metrics)


def one_case(task_name: str, variant: str, methods: tuple[str, ...] | None,
             base_model: str = "kinematic") -> list[dict]:
    """Plan every method on one task (with or without its scene) and simulate each plan (on ``base_model``)."""
    from forte.execution.run import simulate_plan
    from forte.io.plandir import LAST_ITERATE_FILE, TRAJECTORY_FILE, write_plan
    from forte.planning.planner import methods_for, plan
    from forte.planning.tasks.tasks import load_task

    task = load_task(ROOT / "examples/tasks" / f"{task_name}.yaml")
    rows = []
    for method in methods or methods_for(task):
        start = time.perf_counter()
        res = plan(task, method) if variant == "scene" else without_scene_judged_with(task, method)
        c = res.verdict.clearance
        row = {"task": task_name, "planned": variant, "method": method, "verdict": res.label,
               "motion": hashlib.sha1(res.q.round(9).tobytes()).hexdigest()[:12], "solver_status": res.status,
               "failed": list(res.verdict.failed),
               "clearance_ok": "clearance" not in res.verdict.failed, "required_m": c["required_m"],
               "min_clearance_m": c["min_m"], "closest": f"{c['robot']} / {c['body']}", "closest_t": c["t"]}
        with tempfile.TemporaryDirectory() as tmp:
            plan_dir = write_plan(res, Path(tmp) / "plan", figures=False)
            if not res.solved:  # a failed solve writes its last iterate: run that motion all the same
                (plan_dir / LAST_ITERATE_FILE).rename(plan_dir / TRAJECTORY_FILE)
            sim = simulate_plan(plan_dir, write=False, base_model=base_model)
            contacts = sim.summary["contacts"]
            row |= {"sim_success": sim.success, "sim_reason": sim.reason, "sim_time": sim.failure_time,
                    "sim_detail": sim.detail, "contact_checked": sim.summary["contact_checked"],
                    "scene_touches": [c for c in contacts if c["world"] != "floor"],
                    "floor_touches": [c for c in contacts if c["world"] == "floor"]}
            if row["clearance_ok"] and row["scene_touches"] and not followed(row):
                strong = simulate_plan(plan_dir, write=False, torque_limits=STRONG * res.robot.torque_limits,
                                       base_model=base_model)
                row["strong"] = {"success": strong.success, "reason": strong.reason,
                                 "scene_touches": [c for c in strong.summary["contacts"] if c["world"] != "floor"]}
        row["seconds"] = time.perf_counter() - start
        rows.append(row)
    return rows


def followed(row: dict) -> bool:
    """The run followed the plan up to its first touch: no other failure came first."""
    return row["sim_reason"] in (None, "contact")


def touch_text(touches: list[dict]) -> str:
    """The pairs that touched: robot part / body, first time, peak normal force."""
    if not touches:
        return "none"
    return "; ".join(f"{t['robot']} / {t['world'].removeprefix('scene/')} at {t['first_time']:.2f} s, "
                     f"peak {t['peak_force_N']:.0f} N" for t in touches)


def confusion(rows: list[dict], title: str) -> list[str]:
    """The clearance requirement against MuJoCo's touches of a scene body, over ``rows``."""
    def count(ok: bool, touched: bool) -> int:
        return sum(1 for r in rows if r["clearance_ok"] == ok and bool(r["scene_touches"]) == touched)
    return ["", f"{title}:", "", "| clearance \\ MuJoCo | no touch | touch |", "|---|---|---|",
            f"| passes | {count(True, False)} (both say clear) | {count(True, True)} (verdict passes but touch) |",
            f"| fails | {count(False, False)} (verdict fails but no touch) | {count(False, True)} (both say touch) |",
            "", f"agreement: {count(True, False) + count(False, True)} of {len(rows)}"]


def table(rows: list[dict]) -> str:
    """The table of every plan, the agreement counts and the disagreements."""
    lines = ["| task | planned | method | verdict | clearance requirement | min clearance m (closest pair) "
             "| MuJoCo touch | run |", "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        failed = f" ({', '.join(r['failed'])})" if r["failed"] else ""
        run = "success" if r["sim_success"] else f"failure ({r['sim_reason']} at {r['sim_time']:.2f} s)"
        if r["verdict"] == "solver-failed":
            run += ", the last iterate"
        touches = r["scene_touches"] + r["floor_touches"]
        lines.append(f"| {r['task']} | {r['planned']} | {r['method']} | {r['verdict']}{failed} "
                     f"| {'pass' if r['clearance_ok'] else 'FAIL'} | {r['min_clearance_m']:.3f} ({r['closest']}) "
                     f"| {touch_text(touches)} | {run} |")

    lines += confusion(rows, "clearance requirement vs MuJoCo (a touch of a scene body), every run")
    lines += confusion([r for r in rows if followed(r)], "the same, over the runs with no failure but a touch (a run "
                       "that saturated or lost track first has left the motion the verdict judged)")
    motions = len({(r["task"], r["motion"]) for r in rows})
    lines.append(f"distinct motions among the {len(rows)} runs: {motions} (quintic and ik-path run the same motion "
                 "on a waypoint task, and a method gives the same motion with and without the scene when it "
                 "does not use it)")
    floor = [r for r in rows if r["floor_touches"]]
    lines.append(f"runs that touched the floor (not part of the clearance requirement): {len(floor)}")
    unchecked = [r for r in rows if not r["contact_checked"]]
    if unchecked:
        lines.append(f"runs without the contact check: {len(unchecked)}")
    odd = [r for r in rows if r["clearance_ok"] == bool(r["scene_touches"])]
    lines += ["", "disagreements:" if odd else "disagreements: none"]
    for r in odd:
        side = "passes, MuJoCo touch" if r["clearance_ok"] else "fails, no touch in MuJoCo"
        line = (f"- {r['task']} {r['planned']} {r['method']}: clearance {side}; min clearance "
                f"{r['min_clearance_m']:.4f} m ({r['closest']}, t = {r['closest_t']:.2f} s); "
                f"touch: {touch_text(r['scene_touches'])}")
        if not followed(r):
            line += f"; the run had failed before: {r['sim_detail']}"
        if "strong" in r:
            again = r["strong"]
            line += (f"; with {STRONG:g}x the torque limits: {'success' if again['success'] else again['reason']}, "
                     f"touch: {touch_text(again['scene_touches'])}")
        lines.append(line)
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tasks", nargs="+", choices=TASKS, default=list(TASKS))
    parser.add_argument("--methods", nargs="+", default=None, help="default: every method that applies")
    parser.add_argument("--variants", nargs="+", choices=VARIANTS, default=list(VARIANTS))
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", type=Path, default=None, help="write the rows as JSON")
    parser.add_argument("--base-model", choices=("kinematic", "floor"), default="kinematic",
                        help="forte simulate's base: on slide joints (default) or on wheels and casters on the floor")
    args = parser.parse_args(argv)
    start = time.perf_counter()
    cases = [(t, v, tuple(args.methods) if args.methods else None, args.base_model)
             for t in args.tasks for v in args.variants]
    if args.workers > 1:
        with ProcessPoolExecutor(args.workers) as pool:
            results = list(pool.map(one_case, *zip(*cases, strict=True)))
    else:
        results = [one_case(*case) for case in cases]
    rows = [row for result in results for row in result]
    print(table(rows))
    print(f"\n({time.perf_counter() - start:.0f} s)")
    if args.out:
        args.out.write_text(json.dumps(rows, indent=2, default=float) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
