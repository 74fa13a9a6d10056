"""Warm re-planning: same answer as a cold solve, fewer iterations, never an unconverged success."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from forte.exceptions import InvalidInputError
from forte.planning.nlp.layout import shift_rows
from forte.planning.online.replan import Replanner, converged
from forte.planning.planner import plan
from forte.planning.solve import start_guess
from forte.planning.tasks.tasks import load_task

LIFT = Path(__file__).resolve().parents[1] / "examples" / "tasks" / "lift.yaml"


def waypoint_rows(task):
    """``task`` with ``limits.on_spline: false`` written out: the re-planner's default (no spline
    rows online), so that ``forte.plan`` solves the very problem the re-planner does."""
    from dataclasses import replace

    return replace(task, limits=replace(task.limits, on_spline=False))


@pytest.fixture(scope="module")
def task():
    return waypoint_rows(load_task(LIFT, waypoints=15))


def test_the_replanner_keeps_the_waypoint_rows_unless_the_task_asks_for_spline_rows():
    from dataclasses import replace

    task = load_task(LIFT, waypoints=15)
    assert task.limits.on_spline is None
    assert Replanner(task).task.limits.on_spline is False
    asked = replace(task, limits=replace(task.limits, on_spline=True))
    planner = Replanner(asked)
    assert planner.task.limits.on_spline is True and planner.optimizer.on_spline


def test_replan_equals_a_cold_solve_of_the_same_problem(task):
    """The warm start changes how IPOPT gets there, not where: the planner's own cold solve of the
    changed task (same cost, constraints and nominal trajectory) reaches the same point, also
    after other re-plans before it (the problem does not depend on the re-plan history)."""
    planner = Replanner(task)
    for mass in (3.3, 0.5, 2.0):
        warm = planner.replan(mass=mass)
        assert warm.plan.solved and warm.warm and warm.plan.status == "Solve_Succeeded"
        cold = plan(task.with_payload(task.payload.with_mass(mass)), "forte")
        assert cold.solved
        np.testing.assert_allclose(warm.plan.q, cold.q, atol=1e-5)  # both to IPOPT's tolerance
        np.testing.assert_allclose(warm.plan.metrics["d"], cold.metrics["d"], atol=1e-3)
    assert planner.task.payload.mass == 2.0 and planner.task.payload.source == "replan"
    assert warm.latency_s >= warm.solve_s > 0


@pytest.mark.parametrize("name", ["offset-payload.yaml", "tipover.yaml"])
def test_a_replan_solves_what_the_planner_solves(name):
    """The payload's moment (J1 on the wrench) and the task's own terms (tip-over) reach re-plans:
    the re-planner's first solve is the planner's plan, and a warm re-plan after a mass change is a
    solution of the planner's problem for the new mass (solved from it, the planner stays there;
    from its own start it may find a neighbouring optimum: the tip-over task has one 4e-4 rad off)."""
    task = waypoint_rows(load_task(LIFT.parent / name, waypoints=15))
    planner = Replanner(task)
    spec = planner.optimizer.method_spec
    assert ("wrench_capability" in spec.terms) == (name == "offset-payload.yaml")
    assert ("tipover" in spec.terms) == (name == "tipover.yaml")
    np.testing.assert_allclose(planner.last.q, plan(task, "forte").q, atol=1e-5)
    changed = task.with_payload(task.payload.with_mass(task.payload.mass * 0.8))
    warm = planner.replan(mass=changed.payload.mass)
    again = plan(changed, "forte", guess=warm.plan.q)
    assert warm.plan.solved and again.solved
    np.testing.assert_allclose(warm.plan.q, again.q, atol=1e-5)


def test_a_shifted_replan_equals_a_cold_solve_of_the_shifted_problem(task):
    planner = Replanner(task)
    result = planner.shift(3, mass=1.0)
    assert result.plan.solved and result.warm
    t, force, nominal = planner.task, planner.force, planner.nominal
    np.testing.assert_allclose(nominal, shift_rows(task.nominal(), 3))  # the nominal moves with the horizon
    assert t.start_motion is not None  # the new start moves as the last plan did there
    cold = planner.optimizer.solve(t.t, t.targets, force.f, force.r, t.q_init, start_guess(t, nominal), nominal,
                                   start=t.start_motion)
    assert converged(cold)
    np.testing.assert_allclose(result.plan.q, cold.q, atol=1e-5)


def test_shift_moves_the_horizon_and_holds_the_last_target(task):
    planner = Replanner(task)
    before = planner.last.q.copy()
    result = planner.shift(2)
    assert result.plan.solved
    np.testing.assert_allclose(result.plan.q[0], before[2], atol=1e-12)  # the new start is the planned one
    np.testing.assert_allclose(planner.task.targets[-1], planner.task.targets[-3])  # the tail holds
    for qk, Tk in zip(result.plan.q, planner.task.targets, strict=True):
        assert np.linalg.norm(task.robot.ee_pose(qk)[:3, 3] - Tk[:3, 3]) < 1e-6
    with pytest.raises(InvalidInputError, match="steps"):
        planner.shift(0)


def test_a_shifted_plan_is_judged_against_the_shifted_path(task):
    """The shifted task's path (the verdict's tracking reference) samples exactly the shifted
    targets, twice over; before, it stayed the original path and every shifted plan failed
    tracking (0.45 m on the crate task). Tracking holds at every waypoint; on this coarse grid
    (15 waypoints, 0.71 s apart) the spline between them leaves the path (0.10 m), which the
    re-plan's verdict, judged along the motion as a plan's, reports as such."""
    planner = Replanner(task)
    for steps in (3, 2):
        result = planner.shift(steps)
        assert result.plan.solved
        path = planner.task.targets_at(planner.task.t)
        np.testing.assert_allclose(path, planner.task.targets, atol=1e-12)
        tracking = [v for v in result.plan.verdict.violations if v.requirement == "tracking"]
        assert all(v.waypoints == () and "between waypoints only" in v.detail for v in tracking)


def test_a_replan_that_does_not_converge_is_never_a_success(task):
    planner = Replanner(task)
    good = planner.last.q.copy()
    crippled = planner.optimizer._nlp_options | {"ipopt.max_iter": 1}
    planner.optimizer.solver = planner.optimizer._nlpsol(crippled)
    planner.optimizer._warm_solver = planner.optimizer._nlpsol(crippled | {"calc_lam_x": True})
    result = planner.replan(mass=3.5)
    assert not result.plan.solved and not result.warm  # the warm try failed, then the cold retry
    np.testing.assert_array_equal(planner.last.q, good)  # the last good solution is kept
    assert planner.task.payload.mass == task.payload.mass


def test_a_failed_warm_try_falls_back_to_a_cold_solve(task):
    planner = Replanner(task)
    planner.optimizer._warm_solver = planner.optimizer._nlpsol(
        planner.optimizer._nlp_options | {"ipopt.max_iter": 1, "calc_lam_x": True})
    result = planner.replan(mass=2.2)
    assert result.plan.solved and not result.warm


def test_a_replan_stopped_at_ipopts_acceptable_level_is_not_a_success(task):
    """IPOPT (and CasADi's ``success``) accept an "acceptable level" exit with a dual
    infeasibility far above ``tol``; a re-plan does not."""
    planner = Replanner(task)
    good = planner.last.q.copy()
    loose = planner.optimizer._nlp_options | {"ipopt.tol": 1e-20, "ipopt.acceptable_tol": 1e3,
                                              "ipopt.acceptable_iter": 1, "calc_lam_x": True}
    planner.optimizer.solver = planner.optimizer._nlpsol(loose)
    planner.optimizer._warm_solver = planner.optimizer._nlpsol(loose)
    result = planner.replan(mass=1.0)
    assert result.plan.status == "Solved_To_Acceptable_Level"
    assert not result.plan.solved and not result.warm
    np.testing.assert_array_equal(planner.last.q, good)


BLAS_COUNTS = """
import json
from forte.planning.nlp.blas import openblas_builds, single_threaded_blas

builds = openblas_builds()
original = [b.get() for b in builds]
try:
    for b in builds:
        b.set(2)
    with single_threaded_blas():
        inside = [b.get() for b in builds]
    after = [b.get() for b in builds]
finally:
    for b, count in zip(builds, original):
        b.set(count)
print(json.dumps({"builds": len(builds), "inside": inside, "after": after,
                  "restored": [b.get() for b in builds] == original}))
"""


def test_single_threaded_blas_restores_the_thread_counts():
    """In a fresh process: a count raised above 1 starts OpenBLAS worker threads that outlive
    any restore, and the later tests of this process need it free of them (``can_fork``)."""
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", PYTHONPATH=str(Path(__file__).resolve().parents[1] / "src"))
    out = subprocess.run([sys.executable, "-c", BLAS_COUNTS], env=env, capture_output=True, text=True,
                         check=True).stdout
    counts = json.loads(out.splitlines()[-1])
    if not counts["builds"]:
        pytest.skip("no OpenBLAS build found")
    assert counts["inside"] == [1] * counts["builds"]
    assert counts["after"] == [2] * counts["builds"]
    assert counts["restored"]


def test_replanning_needs_an_optimized_method(task):
    with pytest.raises(InvalidInputError, match="optimized method"):
        Replanner(task, "quintic")


def test_new_targets_of_a_pose_path_task_re_derive_its_nominal():
    # A path of poses has an IK nominal trajectory: new targets change it, as plan() would.
    from dataclasses import replace

    path_task = load_task(LIFT.with_name("lift-path.yaml"), mass=1.0, waypoints=12)
    assert path_task.knots is None
    replanner = Replanner(path_task)
    targets = path_task.targets.copy()
    targets[1:, 2, 3] += 0.02  # the path 2 cm higher after its start
    result = replanner.replan(targets=targets)
    cold = plan(replace(path_task, targets=targets), "forte")
    assert result.plan.solved and cold.solved
    np.testing.assert_allclose(result.plan.q, cold.q, atol=1e-5)


def test_a_replan_is_judged_along_the_motion_as_a_plan_is(task):
    """The re-planner's verdict is ``forte plan``'s: the waypoints and the executed spline at 8
    samples per interval. An arm velocity limit set between the re-plan's fastest waypoint/knot
    velocity and its fastest velocity along the spline (above every waypoint's, so the NLP's
    velocity rows stay inactive and the re-plan is the same) fails only between waypoints: the
    waypoint-only verdict the re-planner gave before misses it."""
    from dataclasses import replace

    from forte.model.robot import N_BASE
    from forte.planning.verdict.motion_samples import SAMPLES_PER_INTERVAL, sample_motion
    from forte.planning.verdict.verdict import judge_plan

    mass = task.payload.mass * 1.5
    free = Replanner(task).replan(mass=mass).plan

    def fastest(per_interval: int) -> np.ndarray:  # per arm joint, |dq| over the samples
        s = sample_motion(task.robot, free.task.t, free.q, per_interval, free.task.start_motion)
        return np.abs(s.dq[:, N_BASE:]).max(axis=0)

    at_knots, along = fastest(1), fastest(SAMPLES_PER_INTERVAL)
    joint = int(np.argmax(along / at_knots))
    assert along[joint] > 1.05 * at_knots[joint]  # the spline is faster between its knots
    limits = task.limits.resolve(task.robot)[0][N_BASE:].copy()
    limits[joint] = float(np.sqrt(at_knots[joint] * along[joint]))
    limited = replace(task, limits=replace(task.limits, arm_velocity=tuple(limits)))
    result = Replanner(limited).replan(mass=mass)
    p = result.plan
    assert p.solved and np.abs(p.q - free.q).max() < 1e-5  # the same motion
    assert p.verdict.samples_per_interval == SAMPLES_PER_INTERVAL and not p.feasible
    assert "velocity" in p.verdict.failed
    assert "velocity" not in judge_plan(p.task, p.q, p.force, p.solver, per_interval=1).failed
    violation = next(v for v in p.verdict.violations if v.requirement == "velocity")
    assert "between waypoints only" in violation.detail
    assert result.verdict_s > 0 and p.solver["verdict_s"] == result.verdict_s  # after the latency, not in it
