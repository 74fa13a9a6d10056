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
