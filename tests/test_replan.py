"""Warm re-planning: same answer as a cold solve, fewer iterations, never an unconverged success."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from forte.exceptions import InvalidInputError
from forte.planning.planner import plan
from forte.planning.replan import Replanner
from forte.planning.tasks import load_task

LIFT = Path(__file__).resolve().parents[1] / "examples" / "tasks" / "lift.yaml"


@pytest.fixture(scope="module")
def task():
    return load_task(LIFT, waypoints=15)


def test_replan_equals_a_cold_solve_of_the_same_problem(task):
    """The warm start changes how IPOPT gets there, not where: a cold solve of the same NLP from
    the same primal guess (no multipliers, default barrier) reaches the same point."""
    planner = Replanner(task)
    guess = planner.last.q.copy()
    warm = planner.replan(mass=2.0)
    heavy = task.with_payload(task.payload.with_mass(2.0))
    force = heavy.force()
    cold = planner.optimizer.solve(heavy.t, heavy.targets, force.f, force.r, heavy.q_init, guess)
    assert warm.plan.success and warm.warm and cold.success
    np.testing.assert_allclose(warm.plan.q, cold.q, atol=1e-4)  # both to IPOPT's tolerance
    reference = plan(heavy, "forte")  # and the plan is as good as the planner's own
    assert reference.success and np.min(warm.plan.metrics["d"]) > np.min(reference.metrics["d"]) - 1.0
    assert planner.task.payload.mass == 2.0 and planner.task.payload.source == "replan"


def test_shift_moves_the_horizon_and_holds_the_last_target(task):
    planner = Replanner(task)
    before = planner.last.q.copy()
    result = planner.shift(2)
    assert result.plan.success
    np.testing.assert_allclose(result.plan.q[0], before[2], atol=1e-12)  # the new start is the planned one
    np.testing.assert_allclose(planner.task.targets[-1], planner.task.targets[-3])  # the tail holds
    for qk, Tk in zip(result.plan.q, planner.task.targets, strict=True):
        assert np.linalg.norm(task.robot.ee_pose(qk)[:3, 3] - Tk[:3, 3]) < 1e-6
    with pytest.raises(InvalidInputError, match="steps"):
        planner.shift(0)


def test_a_replan_that_does_not_converge_is_never_a_success(task):
    planner = Replanner(task)
    good = planner.last.q.copy()
    crippled = planner.optimizer._nlp_options | {"ipopt.max_iter": 1}
    planner.optimizer.solver = planner.optimizer._nlpsol(crippled)
    planner.optimizer._warm_solver = planner.optimizer._nlpsol(crippled | {"calc_lam_x": True})
    result = planner.replan(mass=3.5)
    assert not result.plan.success and not result.warm  # the warm try failed, then the cold retry
    np.testing.assert_array_equal(planner.last.q, good)  # the last good solution is kept
    assert planner.task.payload.mass == task.payload.mass


def test_a_failed_warm_try_falls_back_to_a_cold_solve(task):
    planner = Replanner(task)
    planner.optimizer._warm_solver = planner.optimizer._nlpsol(
        planner.optimizer._nlp_options | {"ipopt.max_iter": 1, "calc_lam_x": True})
    result = planner.replan(mass=2.2)
    assert result.plan.success and not result.warm


def test_replanning_needs_an_optimized_method(task):
    with pytest.raises(InvalidInputError, match="optimized method"):
        Replanner(task, "quintic")
