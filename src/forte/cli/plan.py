"""``forte plan`` and ``forte compare``."""

from __future__ import annotations

import argparse
import contextlib
import sys
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

from forte.io.figure_processes import figure_worker
from forte.io.figures import figure_format
from forte.io.outputs import check_output, output_lock, replace_directory
from forte.io.plandir import plan_summary, write_plan
from forte.io.reports import write_comparison
from forte.planning.methods import method_names
from forte.planning.planner import Plan, methods_for, plan, resolve_payload
from forte.planning.sanity import check_force_capacity, describe_negative, negative_margins
from forte.planning.tasks import load_task


def _common(p: argparse.ArgumentParser) -> None:
    p.add_argument("task", type=Path, help="task file (YAML), e.g. examples/tasks/lift.yaml")
    p.add_argument("--mass", type=float, help="payload mass in kg (overrides the task file and the estimator)")
    p.add_argument("--waypoints", type=int, help="number of waypoints N (trajectory mode)")
    p.add_argument("--no-figures", action="store_true", help="skip the figures")
    p.add_argument("--format", default="png", choices=("png", "pdf", "svg"),
                   help="figure file format (default png; pdf and svg are vector)")
    p.add_argument("--quiet", action="store_true", help="print nothing but errors")
    p.add_argument("--vlm-base-url", help="OpenAI-compatible server for the mass estimate (else offline)")
    p.add_argument("--model", default="gpt-4o", help="VLM model name (default gpt-4o)")
    p.add_argument("--api-key-env", default="OPENAI_API_KEY", help="environment variable holding the API key")
    p.add_argument("--no-cache", action="store_true", help="ask the VLM server every time (no answer cache)")


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("plan", help="plan a whole-body trajectory for a task",
                       description="Plan a task with one method and write trajectory.csv, metrics.csv, "
                       "plan.json and figures to --out.")
    _common(p)
    p.add_argument("--method", default="forte", choices=method_names(), help="planning method (default forte)")
    p.add_argument("--out", type=Path, help="output directory (default runs/<task>-<method>)")
    p.add_argument("--require-capacity", action="store_true",
                   help="fail (exit 1) when the force ball leaves the RFP (d < 0) at some waypoint; the task "
                   "field require_capacity: true does the same")
    p.set_defaults(func=run_plan)
    c = sub.add_parser("compare", help="plan a task with every method and compare them",
                       description="Run every method that applies to the task and write one directory per "
                       "method plus summary.md, summary.csv and the comparison figure to --out.")
    _common(c)
    c.add_argument("--out", type=Path, help="output directory (default runs/<task>-compare)")
    c.set_defaults(func=run_compare)


def _estimator_options(args: argparse.Namespace) -> dict[str, Any]:
    if not args.vlm_base_url:
        return {}
    from forte.force.vlm import VLMConfig
    from forte.force.vlm_cache import default_cache_dir

    config = VLMConfig(base_url=args.vlm_base_url, model=args.model, api_key_env=args.api_key_env,
                       cache=not args.no_cache)
    return {"vlm": config, "cache_dir": None if args.no_cache else default_cache_dir()}


def _say(args: argparse.Namespace, text: str) -> None:
    if not args.quiet:
        print(text, file=sys.stderr, flush=True)


def _describe(res: Plan) -> str:
    s = plan_summary(res)
    solve = res.solver.get("solve_time_s")
    timing = f", solved in {solve:.2f} s ({res.solver.get('iterations')} it.)" if solve is not None else ""
    return (f"{res.method}: {res.status}{timing}; min d = {s['min_d']:.2f} N, min capacity - (|f| + r) = "
            f"{s['min_capacity_margin']:.2f} N, mean manipulability = {s['mean_manipulability']:.4f}")


def _capacity_shortfall(res: Plan) -> str:
    """'' when the force ball stays in the RFP at every waypoint, else where it leaves it."""
    if not res.metrics:
        return ""
    info = negative_margins(res.metrics)
    return "" if info["sufficient"] else describe_negative(info, len(res.t))


def run_plan(args: argparse.Namespace) -> int:
    start = time.perf_counter()
    task = load_task(args.task, mass=args.mass, waypoints=args.waypoints)
    out = args.out or Path("runs") / f"{task.name}-{args.method}"
    check_output(out)  # before any work: never plan for minutes and then refuse
    with output_lock(out):  # one writer per --out, from the check to the write
        check_output(out)
        task = resolve_payload(task, _estimator_options(args))
        check_force_capacity(task)  # a certainly impossible force: refused before the solve
        # the figures' process imports matplotlib on the other core while this one plans
        with contextlib.nullcontext() if args.no_figures else figure_worker(task.robot):
            _say(args, f"planning {task.name} ({task.mode}, {task.n} waypoints) with {args.method} ...")
            res = plan(task, args.method)
            required = args.require_capacity or getattr(task, "require_capacity", False)
            short = _capacity_shortfall(res)
            if short and required and res.success:  # a failure by the user's rule: status and file names say so
                res = replace(res, success=False, status="insufficient_capacity")
            with figure_format(args.format):
                where = write_plan(res, out, figures=not args.no_figures)
    _say(args, _describe(res))
    if short:
        print(f"forte: {'error' if required else 'warning'}: {res.method}: {short}"
              + (f"; report in {where}/plan.json" if required else ""), file=sys.stderr)
        if required:
            return 1
    if not res.success:
        print(f"forte: error: optimization failed ({res.status}); report in {where}/plan.json, "
              "no trajectory.csv written", file=sys.stderr)
        return 1
    _say(args, f"wrote {where} in {time.perf_counter() - start:.2f} s")
    return 0


def run_compare(args: argparse.Namespace) -> int:
    task = load_task(args.task, mass=args.mass, waypoints=args.waypoints)
    out = args.out or Path("runs") / f"{task.name}-compare"
    check_output(out)
    with output_lock(out):  # one writer per --out, from the check to the write
        check_output(out)
        return _compare(args, task, out)


def _compare(args: argparse.Namespace, task: Any, out: Path) -> int:
    task = resolve_payload(task, _estimator_options(args))  # one estimate for every method
    check_force_capacity(task)
    methods = methods_for(task)
    results: list[Plan] = []
    for i, method in enumerate(methods, 1):
        _say(args, f"[{i}/{len(methods)}] {method} ...")
        res = plan(task, method)
        results.append(res)
        _say(args, "      " + _describe(res))
        short = _capacity_shortfall(res)
        if short:
            print(f"forte: warning: {method}: {short}", file=sys.stderr)

    def build(tmp: Path) -> None:
        for res in results:
            write_plan(res, tmp / res.method, figures=not args.no_figures)
        write_comparison(results, tmp)  # comparison.png is part of a comparison, figures or not

    if not any(r.success for r in results) and (out / "summary.csv").exists():
        out = out.with_name(out.name + ".failed")  # never replace an earlier comparison with a total failure
    with figure_format(args.format):
        replace_directory(build, out)
    if not args.quiet:
        print((out / "summary.md").read_text())
    _say(args, f"wrote {out}")
    failed = [r.method for r in results if not r.success]
    if failed:
        print(f"forte: error: optimization failed for {', '.join(failed)}", file=sys.stderr)
        return 1
    return 0
