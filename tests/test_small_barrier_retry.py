"""A failed solve is solved again from the same start with a small, monotone barrier parameter
(:func:`forte.planning.solve._small_barrier_retry`): IPOPT's adaptive barrier starts near
``mu = 1`` and its first step from a start on the pose constraints can leave them by most of a
metre, which a start on the constraints does not need."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import forte
from forte.planning import solve
from forte.planning.methods.catalog import get_method
from forte.planning.nlp.optimizer import SolverResult
from forte.planning.tasks.tasks import task_from_dict


def _sideways(tmp_path: Path, samples: int = 21):
    """The ``moca-like`` preset's 0.3 m sideways reach in 5 s, no load (a row of the feasibility matrix)."""
    return task_from_dict({
        "name": "moca-sideways", "robot": {"preset": "moca-like"},
        "force": {"kind": "constant", "vector": [0.0, 0.0, 0.0]},
        "path": {"kind": "waypoints", "relative": True, "samples": samples,
                 "waypoints": [{"t": 0.0, "position": [0.0, 0.0, 0.0]}, {"t": 5.0, "position": [0.0, 0.3, 0.0]}]},
    }, tmp_path / "task.yaml")


def _failed(q: np.ndarray, status: str = "Infeasible_Problem_Detected", violation: float = 0.97) -> SolverResult:
    return SolverResult(q=q, success=False, status=status, iterations=124, objective=0.0,
                        constraint_violation=violation, build_time=0.0, solve_time=0.0, codegen="python")


def test_a_failed_solve_is_solved_again_with_the_small_barrier_from_its_start(tmp_path):
    task = _sideways(tmp_path)
    method, force, nominal = get_method("forte"), task.force(), task.nominal()
    guess = solve.start_guess(task, nominal)
    retry = solve._small_barrier_retry(task, method, force, guess, nominal, task.solver, _failed(guess), False)
    assert retry is not None and retry.options.extra == solve.SMALL_BARRIER
    assert retry.sol.success and retry.facts["kept"]
    assert retry.facts["first_status"] == "Infeasible_Problem_Detected"
    assert retry.sol.iterations < 40  # from a start on the constraints: a handful of iterations
    np.testing.assert_array_equal(retry.sol.q[0], task.q_init)


def test_no_retry_for_a_success_a_spent_budget_a_start_off_the_path_or_a_small_barrier_already(tmp_path):
    task = _sideways(tmp_path)
    method, force, nominal = get_method("forte"), task.force(), task.nominal()
    q = np.repeat(task.q_init[None], task.n, axis=0)
    ok = replace(_failed(q), success=True, status="Solve_Succeeded", constraint_violation=0.0)
    assert solve._small_barrier_retry(task, method, force, q, nominal, task.solver, ok, False) is None
    for status in solve.OUT_OF_TIME:
        spent = _failed(q, status)
        assert solve._small_barrier_retry(task, method, force, q, nominal, task.solver, spent, False) is None
    assert not solve._on_the_path(task, q)  # standing still while the path moves 0.3 m
    assert solve._small_barrier_retry(task, method, force, q, nominal, task.solver, _failed(q), False) is None
    guess = solve.start_guess(task, nominal)
    assert solve._on_the_path(task, guess)
    small = replace(task.solver, extra={"mu_init": 1e-3})
    assert solve._small_barrier_retry(task, method, force, q, nominal, small, _failed(q), False) is None


@pytest.mark.parametrize("samples", [21, 41])
def test_the_sideways_reach_plans_feasible_at_both_resolutions(samples, tmp_path):
    """The matrix's ``moca-like`` sideways 0.3 m ended ``Infeasible_Problem_Detected`` (constraint
    violation 0.97 m) at one resolution or the other; with the retry it is feasible at both, and a
    retry, where one ran, is recorded with the first solve's status."""
    plan = forte.plan(_sideways(tmp_path, samples))
    assert plan.feasible, plan.verdict.reason()
    retry = plan.solver.get("small_barrier_retry")
    if retry is not None:
        assert retry["kept"] and retry["first_status"] != "Solve_Succeeded"
