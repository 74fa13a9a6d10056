"""A plan's NLP solves share a CPU budget (forte.settings.PLAN_SOLVE_CPU_S, nlp/budget.py): a solve
that would run for minutes stops, and the verdict says why."""

from __future__ import annotations

import importlib.util
import time
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
           "forte.settings.PLAN_SOLVE_CPU_S" in reason
    unbounded = forte.plan(task)
    assert unbounded.verdict.feasible and unbounded.solver["iterations"] > plan.solver["iterations"]
    assert time.process_time() - start < 120
    with solve_budget(3600.0, 0.0):  # its wall time spent
        plan = forte.plan(task)
    assert plan.status == "Maximum_WallTime_Exceeded"
    assert "(a plan's solves have 300 s of wall time in all, forte.settings.PLAN_SOLVE_WALL_S" in plan.verdict.reason()


def test_a_solve_whose_multipliers_run_away_is_stopped_with_its_reason():
    """``min x`` s.t. ``x^4 <= 0``: no constraint qualification at the only feasible point, so the
    multiplier ``1 / (4 |x|^3)`` grows without bound as IPOPT closes in; unwatched, IPOPT ends with
    a multiplier over 1e11. Watched (forte's iteration callback), it stops once one passes
    :data:`~forte.settings.MULTIPLIER_LIMIT`, and says so."""
    import casadi as ca
    import numpy as np

    from forte.planning.nlp.ipopt_progress import IpoptProgress
    from forte.settings import MULTIPLIER_LIMIT

    x = ca.MX.sym("x")
    nlp = {"x": x, "f": x, "g": x**4}
    options = {"ipopt.print_level": 0, "print_time": False, "ipopt.sb": "yes", "ipopt.tol": 1e-20,
               "ipopt.constr_viol_tol": 1e-20, "ipopt.nlp_scaling_method": "none"}
    free = ca.nlpsol("free", "ipopt", nlp, options)
    assert abs(float(free(x0=1.0, lbg=-np.inf, ubg=0.0)["lam_g"])) > 10 * MULTIPLIER_LIMIT
    watch = IpoptProgress(1, 1, 0)
    watched = ca.nlpsol("watched", "ipopt", nlp, options | {"iteration_callback": watch})
    watch.start(np.array([-np.inf]), np.array([0.0]))
    result = watched(x0=1.0, lbg=-np.inf, ubg=0.0)
    assert watched.stats()["return_status"] == "User_Requested_Stop"
    assert MULTIPLIER_LIMIT < abs(float(result["lam_g"])) < 10 * MULTIPLIER_LIMIT
    assert watch.stopped.startswith(f"forte stopped IPOPT at iteration {watch.iteration}: a multiplier reached")
    assert watched.stats()["iter_count"] < free.stats()["iter_count"]
    watch.start(np.array([-np.inf]), np.array([0.0]))  # each solve starts unstopped
    assert watch.stopped is None and watch.iteration == 0


def test_a_plan_stopped_for_runaway_multipliers_says_so(tmp_path, monkeypatch):
    """The watch is on every plan's solves (no progress reporter needed): with the limit below the
    multipliers of an ordinary reach, the first iterate with one stops the solve, reported as
    :data:`~forte.settings.DIVERGED` with the limit named."""
    from forte.planning.nlp import ipopt_progress
    from forte.settings import DIVERGED

    task = task_from_dict(fm.task_dict(fm.Cell("authors", fm.Reach("forward", 0.3, 5.0), 0.5, 21)),
                          tmp_path / "t.yaml")
    monkeypatch.setattr(ipopt_progress, "MULTIPLIER_LIMIT", 1e-6)
    plan = forte.plan(task)
    assert plan.status == DIVERGED and plan.verdict.label == "solver-failed"
    assert "forte stopped IPOPT: a multiplier exceeded 1e+10 (forte.settings.MULTIPLIER_LIMIT" in plan.verdict.reason()
    assert plan.solver["iterations"] < 5
    monkeypatch.setattr(ipopt_progress, "MULTIPLIER_LIMIT", 1e10)
    assert forte.plan(task).verdict.feasible
