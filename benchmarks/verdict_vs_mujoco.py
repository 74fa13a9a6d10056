"""Does the plan's verdict agree with MuJoCo? The confusion table over tasks, payloads and methods.

Every method that applies plans the lift (Section 5.3) and the hold (Section 5.4) at each payload
mass; the plan is judged (:mod:`forte.planning.verdict.verdict`) and executed in MuJoCo with the same
payload (``forte simulate``'s defaults: the Section 3.1 controllers, the judge's thresholds). A
*feasible* verdict agrees when the run succeeds, an *infeasible* or *solver-failed* one when it
fails. Prints the table and every disagreement with the failed requirements and the run's outcome;
``--out FILE.json`` keeps the rows.

The capacity requirement includes the safety margin (the ball of radius r around f, inside the
alpha-scaled RFP), which a run at the nominal mass does not exercise. So a plan that fails only the
margin and succeeds in MuJoCo is run once more at the heaviest static payload its ball covers,
``m + r / g``: if that run fails, the margin was needed. A second table judges the plans on the
requirements without a margin (every requirement but capacity: torque with the task force,
limits, tracking, self-collision, solver).

    python benchmarks/verdict_vs_mujoco.py                 # lift and hold, 0.35-6 kg (~15 min on 2 cores)
    python benchmarks/verdict_vs_mujoco.py --tasks hold --masses 0.35 2.7
    python benchmarks/verdict_vs_mujoco.py --base-model floor   # the base on its wheels (issue 39)
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TASKS = {"lift": ROOT / "examples/tasks/lift.yaml", "hold": ROOT / "examples/tasks/hold.yaml"}
MASSES = (0.35, 1.0, 2.0, 2.7, 4.0, 6.0)


def one_case(task_name: str, mass: float, base_model: str = "kinematic") -> list[dict]:
    """Plan every method at ``mass`` and simulate each plan that has a trajectory (on ``base_model``)."""
    from forte.execution.run import simulate_plan
    from forte.io.plandir import write_plan
    from forte.planning.planner import methods_for, plan
    from forte.planning.tasks.tasks import load_task

    task = load_task(TASKS[task_name], mass=mass)
    rows = []
    for method in methods_for(task):
        res = plan(task, method)
        row = {"task": task_name, "mass": mass, "method": method, "verdict": res.label,
               "failed": list(res.verdict.failed), "reason": res.verdict.reason()}
        if res.solved:
            with tempfile.TemporaryDirectory() as tmp:
                plan_dir = write_plan(res, Path(tmp) / "plan", figures=False)
                sim = simulate_plan(plan_dir, write=False, base_model=base_model)
                row |= {"sim": "success" if sim.success else "failure", "sim_reason": sim.reason,
                        "sim_time": sim.failure_time}
                if sim.success and "capacity" in row["failed"] and "torque" not in row["failed"]:
                    ball = mass + float(max(res.force.r)) / task.robot.gravity
                    heavy = simulate_plan(plan_dir, ball, write=False, base_model=base_model)
                    row |= {"ball_mass": ball, "sim_ball": "success" if heavy.success else "failure",
                            "sim_ball_reason": heavy.reason}
        else:
            row |= {"sim": "not run (no trajectory)", "sim_reason": None, "sim_time": None}
        rows.append(row)
    return rows


def confusion(ran: list[dict], feasible, title: str) -> list[str]:
    """One confusion table: ``feasible(row)`` against the nominal MuJoCo run."""
    def count(v: bool, s: str) -> int:
        return sum(1 for r in ran if feasible(r) == v and r["sim"] == s)
    agree = count(True, "success") + count(False, "failure")
    return [f"{title}:", "", "| verdict \\ MuJoCo | run succeeds | run fails |", "|---|---|---|",
            f"| feasible | {count(True, 'success')} | {count(True, 'failure')} |",
            f"| infeasible or solver-failed | {count(False, 'success')} | {count(False, 'failure')} |", "",
            f"agreement: {agree} of {len(ran)}", ""]


def table(rows: list[dict]) -> str:
    """The confusion tables (verdict x simulation) and the disagreements."""
    ran = [r for r in rows if r["sim"] in ("success", "failure")]
    lines = confusion(ran, lambda r: r["verdict"] == "feasible", "the verdict (every requirement)")
    lines += confusion(ran, lambda r: not set(r["failed"]) - {"capacity"},
                       "the requirements without the safety margin (all but capacity)")
    lines += [f"({len(rows) - len(ran)} plans not simulated: no trajectory)", "", "disagreements of the verdict:"]
    for r in ran:
        if (r["verdict"] == "feasible") != (r["sim"] == "success"):
            when = f" at {r['sim_time']:.2f} s" if r["sim_time"] is not None else ""
            ball = (f"; at m + r/g = {r['ball_mass']:.2f} kg: {r['sim_ball']}"
                    f"{' (' + str(r['sim_ball_reason']) + ')' if r.get('sim_ball_reason') else ''}"
                    if "sim_ball" in r else "")
            lines.append(f"- {r['task']} {r['mass']:g} kg {r['method']}: verdict {r['verdict']} "
                         f"({', '.join(r['failed']) or '-'}), MuJoCo {r['sim']}"
                         f"{' (' + str(r['sim_reason']) + when + ')' if r['sim_reason'] else ''}{ball}")
    margin = [r for r in ran if "sim_ball" in r]
    lines += ["", f"plans short of the margin only that succeed nominally: {len(margin)}; of them, "
              f"{sum(r['sim_ball'] == 'failure' for r in margin)} fail at m + r/g"]
    return "\n".join(lines)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tasks", nargs="+", default=list(TASKS), choices=list(TASKS))
    ap.add_argument("--masses", nargs="+", type=float, default=list(MASSES))
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", type=Path, help="write the rows as JSON")
    ap.add_argument("--base-model", choices=("kinematic", "floor"), default="kinematic",
                    help="forte simulate's base: on slide joints (default) or on wheels and casters on the floor")
    args = ap.parse_args()
    start = time.perf_counter()
    cases = [(t, m, args.base_model) for t in args.tasks for m in args.masses]
    with ProcessPoolExecutor(args.workers) as pool:
        rows = [row for part in pool.map(one_case, *zip(*cases, strict=True)) for row in part]
    for r in rows:
        print(f"{r['task']:5s} {r['mass']:5.2f} kg {r['method']:16s} {r['verdict']:13s} "
              f"{','.join(r['failed']) or '-':40s} {r['sim']} {r['sim_reason'] or ''}", file=sys.stderr)
    print(table(rows))
    print(f"\n({time.perf_counter() - start:.0f} s)")
    if args.out:
        args.out.write_text(json.dumps(rows, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
