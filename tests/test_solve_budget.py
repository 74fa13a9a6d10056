"""A plan's NLP solves share a CPU budget (forte.settings.PLAN_SOLVE_CPU_S, nlp/budget.py): a solve
that would run for minutes stops, and the verdict says why."""

from __future__ import annotations

import importlib.util
import time
from dataclasses import replace
from pathlib import Path

import forte
from forte.planning.nlp import budget
from forte.planning.nlp.budget import solve_budget, time_left
from forte.planning.tasks.tasks import task_from_dict
from forte.settings import PLAN_SOLVE_CPU_S, PLAN_SOLVE_WALL_S

ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location("feasibility_matrix", ROOT / "benchmarks" / "feasibility_matrix.py")
fm = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(fm)


def test_a_budget_is_what_is_left_of_the_outer_one():
    assert time_left() is None  # none open: IPOPT gets no time limits
    with solve_budget(50.0, 80.0):
        cpu, wall = time_left()
        assert 49.0 < cpu <= 50.0 and 79.0 < wall <= 80.0
        began = time.monotonic()
        sum(i * i for i in range(300_000))  # spend some CPU time
        assert time_left()[0] < cpu
        with solve_budget(1000.0, 1000.0):  # an inner budget is the outer one
            assert time_left()[0] < cpu and time_left()[1] <= wall - (time.monotonic() - began) + 1e-3
    assert time_left() is None
    with solve_budget(0.0, 0.0):
        assert time_left() == (budget.MIN_SOLVE_CPU_S, budget.MIN_SOLVE_CPU_S)  # spent: each later solve the least
    with solve_budget():
        cpu, wall = time_left()
        assert PLAN_SOLVE_CPU_S - 1.0 < cpu <= PLAN_SOLVE_CPU_S and PLAN_SOLVE_WALL_S - 1.0 < wall <= PLAN_SOLVE_WALL_S


def test_ipopt_gets_what_is_left_and_a_users_own_limit_wins():
    from forte.planning.nlp.ipopt_nlp import ipopt_options
    from forte.settings import SolverOptions

    class Opt:  # what ipopt_options reads of a TrajectoryOptimizer
        options, keep_multipliers, goal = SolverOptions(), False, None

    assert "ipopt.max_cpu_time" not in ipopt_options(Opt()) and "ipopt.max_wall_time" not in ipopt_options(Opt())
    with solve_budget(30.0, 60.0):
        options = ipopt_options(Opt())
        assert 29.0 < options["ipopt.max_cpu_time"] <= 30.0 and 59.0 < options["ipopt.max_wall_time"] <= 60.0
        Opt.options = SolverOptions(extra={"max_cpu_time": 5.0})
        assert ipopt_options(Opt())["ipopt.max_cpu_time"] == 5.0


def test_a_plan_whose_budget_is_spent_stops_and_says_why(tmp_path, monkeypatch):
    task = task_from_dict(fm.task_dict(fm.Cell("authors", fm.Reach("forward", 0.3, 5.0), 0.5, 21)),
                          tmp_path / "t.yaml")
    forte.plan(task)  # compiled kernels, so the timed plan below is the solves' own time
    monkeypatch.setattr(budget, "MIN_SOLVE_CPU_S", 1e-3)
    start = time.process_time()
    with solve_budget(0.0, 3600.0):  # the plan's own budget is this one, its CPU time already spent
        plan = forte.plan(task)
    assert plan.verdict.label == "solver-failed"
    assert plan.status == "Maximum_CpuTime_Exceeded"
    reason = plan.verdict.reason()
    assert "IPOPT stopped with Maximum_CpuTime_Exceeded (a plan's solves have 120 s of CPU time in all, " \
           "solver.time_budget_s" in reason
    unbounded = forte.plan(task)
    assert unbounded.verdict.feasible and unbounded.solver["iterations"] > plan.solver["iterations"]
    assert time.process_time() - start < 120
    with solve_budget(3600.0, 0.0):  # its wall time spent
        plan = forte.plan(task)
    assert plan.status == "Maximum_WallTime_Exceeded"
    assert "(a plan's solves have 300 s of wall time in all, 2.5 x solver.time_budget_s" in plan.verdict.reason()


def test_a_goal_task_whose_budget_runs_out_gets_its_route_when_feasible(monkeypatch):
    """A goal task's solves have ``solver.time_budget_s`` (4 s unless given): spent, the optimized
    plan is not feasible and the route, judged as it is, becomes the plan; the facts say why."""
    from forte.planning.tasks.goals import GOAL_SOLVE_BUDGET_S
    from forte.planning.tasks.tasks import load_task

    path = Path(__file__).resolve().parents[1] / "examples" / "tasks" / "around-the-wall.yaml"
    task = load_task(path)
    assert task.solver.time_budget_s == GOAL_SOLVE_BUDGET_S
    spent = replace(task, solver=replace(task.solver, time_budget_s=1e-3))
    monkeypatch.setattr(budget, "MIN_SOLVE_CPU_S", 1e-3)  # else each solve gets 1 s at least
    plan = forte.plan(spent)
    assert plan.solver["time_budget_s"] == 1e-3
    optimized = plan.solver["fallback"]["optimized"]
    assert optimized["status"] in ("Maximum_CpuTime_Exceeded", "Maximum_WallTime_Exceeded")
    assert plan.feasible and str(plan.status).startswith("route:")


def test_the_budget_counts_what_is_used_and_what_it_skipped():
    """Budget accounting: used and left against process time (user + system) and monotonic time,
    spent once either part is, spent_before true (and recorded) only then, once() made once per owner."""
    cpu_s = budget.MIN_SOLVE_CPU_S + 0.2  # spent once less than MIN_SOLVE_CPU_S is left: after 0.2 s
    with solve_budget(cpu_s, 100.0) as b:
        assert budget.open_budget() is b and b.spent() is None
        assert not budget.spent_before("a round") and b.skipped == []
        with solve_budget(5.0, 5.0) as inner:  # the plan's rounds share the plan's budget
            assert inner is b
        c0 = time.process_time()
        while time.process_time() - c0 < 0.25:  # spend the CPU part
            sum(i * i for i in range(10_000))
        cpu_used, wall_used = b.used()
        assert cpu_used >= 0.25 and wall_used >= 0.0 and b.left()[0] <= budget.MIN_SOLVE_CPU_S - 0.05
        assert b.spent() == "cpu" and time_left()[0] == budget.MIN_SOLVE_CPU_S  # a solve then gets the least
        assert budget.spent_before("self-collision re-solve") and budget.spent_before("refinement round 1")
        made = []
        owner, other = object(), object()
        assert b.once("guess", owner, lambda: made.append(1) or "g1") == "g1"
        assert b.once("guess", owner, lambda: made.append(1) or "g2") == "g1" and made == [1]
        assert b.once("guess", other, lambda: "g3") == "g3"
        record = b.record()
    assert record["cpu_s"] == cpu_s and record["wall_s"] == 100.0 and record["spent"] == "cpu"
    assert 0.25 <= record["cpu_used_s"] < cpu_s and record["cpu_over_s"] == 0.0  # ran out, not overrun
    assert record["wall_over_s"] == 0.0 and record["skipped"] == ["self-collision re-solve: not started",
                                                              "refinement round 1: not started"]
    assert budget.open_budget() is None and not budget.spent_before("anything")  # none open: never spent
    assert budget.once("k", owner, lambda: "fresh") == "fresh"  # none open: made each time
    with solve_budget(100.0, budget.MIN_SOLVE_CPU_S - 1e-3) as b:  # under the least a solve gets
        assert b.spent() == "wall" and b.record()["spent"] == "wall"


def _cpu_with_children() -> float:
    import resource

    own, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def test_a_small_time_budget_stops_the_plans_work_and_says_so(tmp_path):
    """The raw Kinova riding its velocity limits without the spline's rows (limits.on_spline:
    false) needs a refinement round to become feasible (tests/test_planned_as_judged.py). With
    solver.time_budget_s = 1 (less than the least a solve is given: spent from the start) its first
    solve runs, no round starts, the plan comes back within the budget plus the overrun budget.py
    states (one solve's least, one verdict, the metrics; asserted with room for a busy machine),
    its verdict says the budget ran out and what it did not start, and its solver.budget records
    the CPU and wall time used."""
    import sys

    sys.path.insert(0, str(Path(__file__).parent))
    from test_planned_as_judged import _kinova

    data = _kinova(on_spline=False) | {"solver": {"time_budget_s": 1.0}}
    task = task_from_dict(data, tmp_path / "t.yaml")
    forte.plan(task)  # kernels compiled (cached after): the plan below is timed on its own work
    cpu0, wall0 = _cpu_with_children(), time.monotonic()
    plan = forte.plan(task)
    cpu, wall = _cpu_with_children() - cpu0, time.monotonic() - wall0
    record = plan.solver["budget"]
    assert record["cpu_s"] == 1.0 and record["wall_s"] == 2.5 and record["spent"] in ("cpu", "wall")
    assert abs(record["cpu_used_s"] - cpu) < 0.5  # the record counts what the plan used
    assert cpu < 1.0 + 3.0 and wall < 2.5 + 15.0
    assert plan.verdict.failed == ("velocity",)
    assert "refinement round 1: not started" in record["skipped"]
    assert "the plan's time budget (1 s of CPU, 2.5 s of wall time: solver.time_budget_s) ran out" \
        in plan.verdict.reason()
    import json

    from forte.io.plan_writer import write_plan

    written = json.loads((write_plan(plan, tmp_path / "plan", figures=False) / "plan.json").read_text())
    assert written["solver"]["budget"] == json.loads(json.dumps(record))  # plan.json: used vs budget


def test_a_plan_ipopt_found_infeasible_is_not_solved_again_with_self_rows(monkeypatch):
    """``apart`` does not re-solve a plan whose solve stopped with Infeasible_Problem_Detected: the
    problem with the robot's own pairs as rows has fewer feasible points, not more (the raw TIAGo's
    out-of-reach down 0.5 m: 500 iterations, 50 s of CPU, for the same verdict). A plan that
    collides and stopped otherwise is still re-solved."""
    import numpy as np

    from forte.planning import rounds
    from forte.planning.methods.catalog import get_method

    task = forte.load_task(ROOT / "examples" / "tasks" / "lift.yaml", mass=0.35, waypoints=9)
    force = task.force()
    calls = []

    def optimize(*args, **kwargs):
        calls.append(kwargs.get("self_rows"))
        return replace(sol, status="Solve_Succeeded", success=True), {}

    monkeypatch.setattr(rounds, "optimize", optimize)
    monkeypatch.setattr(rounds, "judged", lambda task, q, force, info: (colliding, force))
    colliding = type("V", (), {"failed": ("self_collision",), "violations": (), "feasible": False,
                               "reason": lambda self: "self_collision: a pair collides",
                               "label": "infeasible"})()
    sol = rounds.SolverResult(q=np.asarray(task.nominal()), success=False, status=rounds.INFEASIBLE, iterations=86,
                              objective=0.0, constraint_violation=0.33, build_time=0.0, solve_time=0.0,
                              codegen="python")
    kept, info, verdict, _ = rounds.apart(task, get_method("forte"), force, None, sol, {}, colliding)
    assert calls == [] and kept is sol and verdict is colliding
    assert info["self_rows"]["kept"] is False and rounds.INFEASIBLE in info["self_rows"]["skipped"]
    stopped = replace(sol, status="Maximum_Iterations_Exceeded")
    kept, info, _, _ = rounds.apart(task, get_method("forte"), force, None, stopped, {}, colliding)
    assert calls == [True] and info["self_rows"]["status"] == "Solve_Succeeded"
