"""Where one plan's time goes: process CPU and wall seconds per phase of ``forte.plan`` (issue 36,
the solve budget).

Each phase is a function of the planner wrapped with a timer; a phase's own time excludes the
phases called inside it (``self``), so the rows add up to the plan's total. Phases: the initial
guess (IK, the nominal path), the problems' build (kernels loaded, CasADi expressions, IPOPT set
up), IPOPT's solves, the verdicts, the clearance and self-collision rows' setup (broad phase,
missing pairs), the failure diagnosis, the cost terms and metrics; ``rest`` is the plan's own time
outside all of them (the rounds' bookkeeping). A re-solve run in a forked child
(:func:`forte.planning.nlp.budget.bounded`) counts in ``children_cpu_s`` and the total, not in the
phases. IPOPT's own user CPU (what its ``max_cpu_time``
counts) is read from CasADi's statistics. A cell of the feasibility matrix by name, or a task file
(``--task``; ``--waypoints`` as ``forte plan``'s), with ``import_cpu_s``: the CPU seconds of the
process before the plan (interpreter and imports, what a cold ``forte plan`` pays first):

    python benchmarks/plan_phases.py tiago-urdf down 0.3 0 41 [--budget 20] [--json out.json]
    python benchmarks/plan_phases.py --task examples/tasks/lift.yaml --waypoints 100
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import resource
import sys
import tempfile
import time
from collections import defaultdict
from dataclasses import replace
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
_spec = importlib.util.spec_from_file_location("feasibility_matrix", HERE / "feasibility_matrix.py")
fm = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(fm)


class Phases:
    """Own (exclusive) CPU and wall seconds and call counts per phase name."""

    def __init__(self) -> None:
        self.cpu: dict[str, float] = defaultdict(float)
        self.wall: dict[str, float] = defaultdict(float)
        self.calls: dict[str, int] = defaultdict(int)
        self._stack: list[list[float]] = []  # per open phase: CPU and wall of its children

    def wrap(self, name: str, fn: Any) -> Any:
        def timed(*args: Any, **kwargs: Any) -> Any:
            c0, w0 = time.process_time(), time.perf_counter()
            self._stack.append([0.0, 0.0])
            try:
                return fn(*args, **kwargs)
            finally:
                child = self._stack.pop()
                dc, dw = time.process_time() - c0, time.perf_counter() - w0
                self.cpu[name] += dc - child[0]
                self.wall[name] += dw - child[1]
                self.calls[name] += 1
                if self._stack:
                    self._stack[-1][0] += dc
                    self._stack[-1][1] += dw
        timed.__wrapped__ = fn
        return timed


class Trace:
    """A progress reporter that keeps the process CPU time of each IPOPT iteration."""

    ipopt_iterations = True

    def __init__(self) -> None:
        self.times: list[float] = []

    def step(self, title: str, expected_s: float | None = None) -> Any:
        import contextlib

        if title.startswith("solving with IPOPT"):
            self.times = [time.process_time()]
        return contextlib.nullcontext()

    def update(self, detail: str) -> None:
        if detail.startswith("IPOPT iteration"):
            self.times.append(time.process_time())

    def note(self, text: str) -> None:
        pass

    def longest(self) -> float | None:
        """The longest CPU time between two iterations of the last solve (s)."""
        gaps = [b - a for a, b in zip(self.times, self.times[1:], strict=False)]
        return round(max(gaps), 2) if gaps else None


TRACE = Trace()


def patch(phases: Phases) -> dict[str, float]:
    """Wrap the planner's phases wherever a loaded forte module refers to them; returns IPOPT's own
    CPU and wall seconds (filled as solves run)."""
    from forte.planning import planner, solve
    from forte.planning.nlp.optimizer import TrajectoryOptimizer
    from forte.planning.scene import diagnosis, scene_guess, scene_solve
    from forte.planning.tasks import ik
    from forte.planning.verdict import evaluation, verdict

    targets = {
        "initial guess": [(solve, "start_guess"), (ik, "initial_guess")],
        "clear start": [(scene_guess, "clear_start")],
        "verdict": [(verdict, "judge_plan")],
        "rows setup": [(scene_solve, "assign_slots"), (scene_solve, "missing_pairs")],
        "diagnosis": [(diagnosis, "failed_rows")],
        "metrics": [(evaluation, "evaluate")],
        "optimize": [(solve, "optimize")],
        "start and goal loads": [(planner, "said_at_start"), (planner, "said_at_goal")],
        "plan": [(planner, "plan")],
    }
    for name, places in targets.items():
        for module, attr in places:
            orig = getattr(module, attr)
            wrapped = phases.wrap(name, orig)
            for mod in list(sys.modules.values()):  # every `from x import f` binding
                if getattr(mod, "__name__", "").startswith("forte") and getattr(mod, attr, None) is orig:
                    setattr(mod, attr, wrapped)
    TrajectoryOptimizer.__init__ = phases.wrap("build", TrajectoryOptimizer.__init__)
    TrajectoryOptimizer.cost_terms = phases.wrap("cost terms", TrajectoryOptimizer.cost_terms)
    ipopt: dict[str, Any] = {"cpu_user": 0.0, "wall": 0.0, "solves": 0, "iterations": 0, "each": []}
    solve_fn = TrajectoryOptimizer.solve

    def solve_with_stats(self: Any, *args: Any, **kwargs: Any) -> Any:
        u0, w0 = resource.getrusage(resource.RUSAGE_SELF).ru_utime, time.perf_counter()
        sol = solve_fn(self, *args, **kwargs)
        user, wall = resource.getrusage(resource.RUSAGE_SELF).ru_utime - u0, time.perf_counter() - w0
        ipopt["cpu_user"] += user
        ipopt["wall"] += wall
        ipopt["solves"] += 1
        ipopt["iterations"] += sol.iterations
        given = self._nlp_options.get("ipopt.max_cpu_time"), self._nlp_options.get("ipopt.max_wall_time")
        ipopt["each"].append({"status": sol.status, "iterations": sol.iterations, "user_s": round(user, 2),
                              "wall_s": round(wall, 2), "max_cpu_time": given[0], "max_wall_time": given[1],
                              "slots": bool(self.slots), "longest_iteration_s": TRACE.longest()})
        return sol
    TrajectoryOptimizer.solve = phases.wrap("IPOPT", solve_with_stats)
    return ipopt


def load(args: argparse.Namespace) -> tuple[Any, list[Any]]:
    """The task of ``--task`` or of the feasibility-matrix cell named by the positional arguments."""
    from forte.planning.tasks.tasks import load_task, task_from_dict

    if args.task is not None:
        task = load_task(args.task, waypoints=args.waypoints)
        if args.budget is not None:
            task = replace(task, solver=replace(task.solver, time_budget_s=args.budget))
        return task, [str(args.task), task.n]
    if args.samples is None:
        raise SystemExit("give a cell (robot kind distance payload samples) or --task")
    cell = fm.Cell(args.robot, fm.Reach(args.kind, args.distance, fm.SIZES[args.distance]), args.payload,
                   args.samples)
    data = fm.task_dict(cell)
    if args.budget is not None:
        data["solver"] = dict(data.get("solver", {})) | {"time_budget_s": args.budget}
    return task_from_dict(data, HERE / "plan_phases.yaml"), list(cell[:1]) + [args.kind, args.distance,
                                                                              args.payload, args.samples]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("robot", nargs="?")
    parser.add_argument("kind", nargs="?")
    parser.add_argument("distance", type=float, nargs="?")
    parser.add_argument("payload", type=float, nargs="?")
    parser.add_argument("samples", type=int, nargs="?")
    parser.add_argument("--task", type=Path, default=None, help="a task file instead of a matrix cell")
    parser.add_argument("--waypoints", type=int, default=None, help="N of --task (as forte plan's)")
    parser.add_argument("--budget", type=float, default=None, help="solver.time_budget_s (CPU s)")
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args(argv)
    import forte
    from forte.io.plandir import write_plan
    from forte.planning.tasks.tasks import load_task  # noqa: F401

    import_cpu = time.process_time()  # interpreter, forte and its libraries (and this script's matrix module)
    task, cell = load(args)
    load_cpu = time.process_time() - import_cpu
    phases = Phases()
    ipopt = patch(phases)
    r0, k0 = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    c0, w0 = time.process_time(), time.perf_counter()
    from forte import progress

    with progress.activate(TRACE):
        plan = forte.plan(task)
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    r1, k1 = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    children = (k1.ru_utime - k0.ru_utime) + (k1.ru_stime - k0.ru_stime)  # re-solves run in forked children
    with tempfile.TemporaryDirectory() as tmp:
        c1 = time.process_time()
        write_plan(plan, Path(tmp) / "plan", figures=False)
        write_cpu = time.process_time() - c1
    out = {"cell": cell, "budget_s": args.budget, "verdict": plan.verdict.label, "failed": list(plan.verdict.failed),
           "status": plan.status, "import_cpu_s": round(import_cpu, 2),
           "task_load_cpu_s": round(load_cpu, 3), "cpu_s": cpu + children,
           "children_cpu_s": children, "wall_s": wall, "user_s": r1.ru_utime - r0.ru_utime,
           "system_s": r1.ru_stime - r0.ru_stime, "write_cpu_s": round(write_cpu, 3), "ipopt": ipopt,
           "phases": {k: {"cpu_s": round(phases.cpu[k], 3), "wall_s": round(phases.wall[k], 3),
                          "calls": phases.calls[k]} for k in sorted(phases.cpu, key=lambda k: -phases.cpu[k])},
           "solver_budget": plan.solver.get("budget")}
    print(json.dumps(out, indent=1))
    if args.json is not None:
        args.json.write_text(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
