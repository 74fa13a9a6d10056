"""``forte plan`` and ``forte compare``."""

from __future__ import annotations

import argparse
import contextlib
import sys
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

from forte.io.figure_worker import figure_worker
from forte.io.figures import figure_format
from forte.io.outputs import check_output, output_lock, replace_directory
from forte.io.plandir import plan_summary, write_plan
from forte.io.reports import write_comparison
from forte.planning.bounds import PayloadBound, replanned_bound
from forte.planning.methods.catalog import method_names
from forte.planning.planner import Plan, compare, methods_for, plan, resolve_payload
from forte.planning.tasks.posture import start_posture
from forte.planning.tasks.tasks import Task, load_task
from forte.planning.verdict.sanity import check_force_capacity
from forte.planning.verdict.verdict import exit_code
from forte.settings import SOLVER_BACKENDS


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
    p.add_argument("--allow-infeasible", action="store_true",
                   help="exit 0 even when a plan is not feasible (exploration); the verdict is still printed "
                   "and recorded")
    p.add_argument("--solver", choices=SOLVER_BACKENDS,
                   help="NLP solver (overrides the task file's solver.backend; default ipopt, the reference; "
                   "stagewise: forte's structure-exploiting interior-point method)")


def _load(args: argparse.Namespace) -> Task:
    task = load_task(args.task, mass=args.mass, waypoints=args.waypoints)
    if args.solver:
        task = replace(task, solver=replace(task.solver, backend=args.solver))
    return task


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("plan", help="plan a whole-body trajectory for a task",
                       description="Plan a task with one method and write trajectory.csv, metrics.csv, "
                       "plan.json and figures to --out.")
    _common(p)
    p.add_argument("--method", default="forte", choices=method_names(), help="planning method (default forte)")
    p.add_argument("--out", type=Path, help="output directory (default runs/<task>-<method>)")
    p.add_argument("--require-capacity", action="store_true", help=argparse.SUPPRESS)  # always on since verdicts
    p.add_argument("--no-bound", action="store_true",
                   help="when the plan lacks capacity, skip the search for the largest payload forte can carry")
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
    near = res.verdict.clearance if res.verdict is not None else None
    clearance = (f", min clearance = {near['min_m']:.3f} m ({near['robot']} vs {near['body']} at t = {near['t']:.2f} s)"
                 if near else "")
    return (f"{res.method}: {res.label} ({res.status}{timing}); min d = {s['min_d']:.2f} N, min capacity - "
            f"(|f| + r) = {s['min_capacity_margin']:.2f} N, mean manipulability = {s['mean_manipulability']:.4f}"
            f"{clearance}")


def _with_bound(args: argparse.Namespace, res: Plan) -> Plan:
    """The plan with forte's re-planned payload bound in its verdict, when the capacity or torque
    requirement failed on a payload task (one solve per bisection step; ``--no-bound`` skips)."""
    bound = res.verdict.payload_bound if res.verdict is not None else None
    if bound is None or args.no_bound or res.task is None:
        return res
    _say(args, f"{res.method} is not feasible at {bound['asked_kg']:g} kg: finding the largest payload forte can "
               "carry on this path (--no-bound skips) ...")
    found = replanned_bound(res.task, "forte")
    bound = bound | {"replanned_kg": found.replanned_kg, "replanned_method": found.method,
                     "unloaded_failed_replanned": list(found.unloaded_failed)}
    return replace(res, verdict=res.verdict._replace(payload_bound=bound))


def _bound_text(res: Plan) -> str:
    """What was tried about the payload, exactly (:func:`~forte.planning.verdict.verdict.judge_plan`'s
    bound: the plan's own motion at lighter loads; :func:`replanned_bound`: re-plans), and what
    would fix the plan where the verdict can tell."""
    verdict = res.verdict
    fixes = "".join(f"; would fix it: {r}" for r in verdict.remedies()) if verdict is not None else ""
    bound = verdict.payload_bound if verdict is not None else None
    if not bound:
        return fixes
    fixed, also = bound["fixed_motion_kg"], bound.get("also_failed") or []
    whatever = f" (it fails {', '.join(also)} whatever the payload)" if also else ""
    text = (f"; this plan's motion carries at most {fixed:.2f} kg{whatever}" if fixed is not None
            else f"; this plan's motion fails {', '.join(bound.get('unloaded_failed') or ['capacity'])} "
                 f"even without payload")
    if "replanned_kg" in bound:
        text += "; " + PayloadBound(bound["replanned_method"], bound["asked_kg"], bound["replanned_kg"],
                                    tuple(bound.get("unloaded_failed_replanned") or ())).sentence()
    return text + fixes


def _verdict_line(res: Plan, where: Path | None, allowed: bool) -> str:
    """The one line a plan that is not feasible gets on standard error."""
    kind = "warning" if allowed else "error"
    reason = res.verdict.reason() if res.verdict is not None else f"{res.label} ({res.status})"
    report = f"; report in {where}/plan.json" if where is not None else ""
    kept = " (exit 0: --allow-infeasible)" if allowed else ""
    return f"forte: {kind}: {res.method}: {reason}{_bound_text(res)}{report}{kept}"


def run_plan(args: argparse.Namespace) -> int:
    start = time.perf_counter()
    task = _load(args)
    out = args.out or Path("runs") / f"{task.name}-{args.method}"
    check_output(out)  # before any work: never plan for minutes and then refuse
    with output_lock(out):  # one writer per --out, from the check to the write
        check_output(out)
        task = resolve_payload(task, _estimator_options(args))
        check_force_capacity(task)  # a certainly impossible force: refused before the solve
        # the figures' process imports matplotlib on the other core while this one plans
        with contextlib.nullcontext() if args.no_figures else figure_worker(task.robot):
            _say(args, f"planning {task.name} ({task.mode}, {task.n} waypoints) with {args.method} ...")
            res = _with_bound(args, plan(task, args.method))
            with figure_format(args.format):
                where = write_plan(res, out, figures=not args.no_figures)
    _say(args, _describe(res))
    if (posture := start_posture(res.task)) is not None and posture.poor:  # a warning, never a failure
        _say(args, f"forte: warning: {posture.warning()}")
    if not res.feasible:
        print(_verdict_line(res, where, args.allow_infeasible), file=sys.stderr)
        return exit_code([res], args.allow_infeasible)
    _say(args, f"wrote {where} in {time.perf_counter() - start:.2f} s")
    return 0


def run_compare(args: argparse.Namespace) -> int:
    task = _load(args)
    out = args.out or Path("runs") / f"{task.name}-compare"
    check_output(out)
    with output_lock(out):  # one writer per --out, from the check to the write
        check_output(out)
        return _compare(args, task, out)


def _compare(args: argparse.Namespace, task: Any, out: Path) -> int:
    task = resolve_payload(task, _estimator_options(args))  # one estimate for every method
    check_force_capacity(task)
    methods = methods_for(task)

    def progress(i: int, res: Plan) -> None:
        _say(args, f"[{i}/{len(methods)}] " + _describe(res))

    results = compare(task, methods, on_plan=progress)

    def build(tmp: Path) -> None:
        for res in results:
            write_plan(res, tmp / res.method, figures=not args.no_figures)
        write_comparison(results, tmp)  # comparison.png is part of a comparison, figures or not

    if not any(r.feasible for r in results) and (out / "summary.csv").exists():
        out = out.with_name(out.name + ".failed")  # never replace an earlier comparison with a total failure
    with figure_format(args.format):
        replace_directory(build, out)
    if not args.quiet:
        print((out / "summary.md").read_text())
    _say(args, f"wrote {out}")
    for res in results:
        if not res.feasible:
            print(_verdict_line(res, None, args.allow_infeasible), file=sys.stderr)
    return exit_code(results, args.allow_infeasible)
