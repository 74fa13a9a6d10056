"""What a closed loop should do with a converged re-plan whose verdict is not feasible (issue 36).

Run: python benchmarks/replan_on_infeasible.py [--loops replan,mpc] [--rules keep,splice,stop]
     [--scenarios 0,1,2] [--modes NAME,...]

Runs the existing experiment cases with each rule of
:data:`forte.execution.closed_loop.ON_INFEASIBLE` and prints, per case and rule, the MuJoCo
verdict, the re-plans judged infeasible and what was done with them:

- ``replan``: the 10 Hz re-planner on the waypoint lift (``forte experiment replan``'s two
  scenarios, N = 41, planned for 0.35 kg);
- ``mpc``: the 100 Hz MPC with converged solves (``forte experiment mpc``'s three scenarios on
  the authors' lift, its ``converged`` modes; real-time iterations have no verdict).

Every run stops at its first failure. Nothing is asserted.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from collections import Counter
from dataclasses import replace
from pathlib import Path

from forte.execution.closed_loop import ON_INFEASIBLE, ReplanOptions
from forte.execution.run import simulate_plan
from forte.experiments import mpc as mpc_exp
from forte.experiments import replan as replan_exp
from forte.experiments.common import task_path
from forte.io.plandir import write_plan
from forte.planning.planner import plan
from forte.planning.tasks.tasks import load_task


def _plan_dir(tmp: Path, task_name: str) -> Path:
    task = load_task(task_path(task_name), mass=replan_exp.PLANNED_MASS, waypoints=41)
    return write_plan(plan(task, "forte"), tmp / task_name, figures=False)


def _row(case: str, rule: str, result, loop: dict, seconds: float) -> str:
    log = loop["log"]
    judged = [e for e in log if e.get("solved", e.get("success")) and "failed" in e]  # converged solves
    bad = [e for e in judged if e["verdict"] != "feasible"]
    failed = sorted({r for e in bad for r in e["failed"]})
    applied = Counter(e["applied"] for e in log if e.get("applied") not in (None, "none"))
    verdict = "success" if result.success else f"{result.reason} at {result.failure_time:.2f} s"
    stop = loop.get("stopped_at_waypoint")
    return (f"| {case} | {rule} | {verdict} | {len(judged)} | {len(bad)} ({', '.join(failed) or '-'}) | "
            f"{dict(applied)} | {'-' if stop is None else stop} | {seconds:.0f} |")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--loops", default="replan,mpc")
    ap.add_argument("--rules", default=",".join(ON_INFEASIBLE))
    ap.add_argument("--scenarios", default="0,1,2")
    ap.add_argument("--modes", default="MPC 100 Hz, converged stagewise, misses delayed")
    args = ap.parse_args()
    rules, picks = args.rules.split(","), [int(i) for i in args.scenarios.split(",")]
    print("| case | rule | MuJoCo | converged re-plans | not feasible (failed) | applied | stopped at waypoint | "
          "wall s |")
    print("|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        if "replan" in args.loops:
            plan_dir = _plan_dir(Path(tmp), "lift-path")
            for name in [n for i, n in enumerate(replan_exp.SCENARIOS) if i in picks]:
                sc = replan_exp.SCENARIOS[name]
                for rule in rules:
                    start = time.perf_counter()
                    options = ReplanOptions(add_mass=sc["add_mass"], on_infeasible=rule)
                    res = simulate_plan(plan_dir, mass=sc["mass"], write=False, stop_on_failure=True, replan=options)
                    print(_row(f"re-planner 10 Hz: {name}", rule, res, res.summary["replanning"],
                               time.perf_counter() - start), flush=True)
        if "mpc" in args.loops:
            plan_dir = _plan_dir(Path(tmp), "lift")
            for name in [n for i, n in enumerate(mpc_exp.SCENARIOS) if i in picks]:
                for mode in args.modes.split(";"):
                    for rule in rules:
                        start = time.perf_counter()
                        kw = mpc_exp._loop_options(mpc_exp.SCENARIOS[name], mpc_exp.MODES[mode][2])
                        kw["mpc"] = replace(kw["mpc"], on_infeasible=rule)
                        res = simulate_plan(plan_dir, mass=mpc_exp.SCENARIOS[name][0], write=False,
                                            stop_on_failure=True, **kw)
                        print(_row(f"{mode}: {name}", rule, res, res.summary["mpc"], time.perf_counter() - start),
                              flush=True)


if __name__ == "__main__":
    main()
