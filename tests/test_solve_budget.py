"""A plan's NLP solves share a CPU budget (forte.settings.PLAN_SOLVE_CPU_S, nlp/budget.py): a solve
that would run for minutes stops, and the verdict says why."""

from __future__ import annotations

import importlib.util
import time
from pathlib import Path

import forte
from forte.planning.nlp import budget
from forte.planning.nlp.budget import cpu_time_left, solve_budget
from forte.planning.tasks.tasks import task_from_dict
from forte.settings import PLAN_SOLVE_CPU_S

ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location("feasibility_matrix", ROOT / "benchmarks" / "feasibility_matrix.py")
fm = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(fm)


def test_a_budget_is_what_is_left_of_the_outer_one():
    assert cpu_time_left() is None  # none open: IPOPT gets no max_cpu_time
    with solve_budget(50.0):
        left = cpu_time_left()
        assert 49.0 < left <= 50.0
        sum(i * i for i in range(300_000))  # spend some CPU time
        spent = left - cpu_time_left()
        assert spent > 0
        with solve_budget(1000.0):  # an inner budget is the outer one
            assert cpu_time_left() <= left - spent + 1e-3
    assert cpu_time_left() is None
    with solve_budget(0.0):
        assert cpu_time_left() == budget.MIN_SOLVE_CPU_S  # spent: each later solve gets the least
    with solve_budget():
        assert PLAN_SOLVE_CPU_S - 1.0 < cpu_time_left() <= PLAN_SOLVE_CPU_S


def test_ipopt_gets_what_is_left_and_a_users_own_limit_wins():
    from forte.planning.nlp.ipopt_nlp import ipopt_options
    from forte.settings import SolverOptions

    class Opt:  # what ipopt_options reads of a TrajectoryOptimizer
        options, keep_multipliers = SolverOptions(), False

    assert "ipopt.max_cpu_time" not in ipopt_options(Opt())
    with solve_budget(30.0):
        assert 29.0 < ipopt_options(Opt())["ipopt.max_cpu_time"] <= 30.0
        Opt.options = SolverOptions(extra={"max_cpu_time": 5.0})
        assert ipopt_options(Opt())["ipopt.max_cpu_time"] == 5.0


def test_a_plan_whose_budget_is_spent_stops_and_says_why(tmp_path, monkeypatch):
    task = task_from_dict(fm.task_dict(fm.Cell("authors", fm.Reach("forward", 0.3, 5.0), 0.5, 21)),
                          tmp_path / "t.yaml")
    forte.plan(task)  # compiled kernels, so the timed plan below is the solves' own time
    monkeypatch.setattr(budget, "MIN_SOLVE_CPU_S", 1e-3)
    start = time.process_time()
    with solve_budget(0.0):  # the plan's own budget is this one, already spent
        plan = forte.plan(task)
    assert plan.verdict.label == "solver-failed"
    assert plan.status == "Maximum_CpuTime_Exceeded"
    reason = plan.verdict.reason()
    assert "IPOPT stopped with Maximum_CpuTime_Exceeded (a plan's solves have 120 s of CPU time in all, " \
           "forte.settings.PLAN_SOLVE_CPU_S" in reason
    unbounded = forte.plan(task)
    assert unbounded.verdict.feasible and unbounded.solver["iterations"] > plan.solver["iterations"]
    assert time.process_time() - start < 120
