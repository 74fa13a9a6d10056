"""The planner plans what the verdict checks (issue 36): the paper's lift at any resolution, a short
last segment, a user's own URDF riding its velocity limits, and violations that name the joint and
the waypoint."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

import forte
from forte.planning.tasks.paths import HOLD_TOLERANCE, HeldPath, ending_at_rest, hold_cut
from forte.planning.tasks.tasks import task_from_dict
from forte.planning.verdict.requirements import TRACKING_ORIENTATION_TOL, TRACKING_POSITION_TOL
from forte.planning.verdict.verdict import judge_plan
from forte.settings import KinematicLimits

LIFT = Path("examples/tasks/lift.yaml")


def _simulate(plan: forte.Plan, directory: Path):
    from forte.execution.run import simulate_plan
    from forte.io.plandir import write_plan

    return simulate_plan(write_plan(plan, directory, figures=False), hold=0.3, write=False)


def _line(x: float) -> np.ndarray:
    """A toy path: the pose at x(t) = min(t, 1)^2 along the world x axis."""
    def at(ts):
        out = np.repeat(np.eye(4)[None], len(ts), axis=0)
        out[:, 0, 3] = np.minimum(np.asarray(ts), 1.0) ** 2 * x
        return out
    return at


def test_the_hold_tolerance_is_the_verdicts_tracking_tolerance():
    assert HOLD_TOLERANCE == (TRACKING_POSITION_TOL, TRACKING_ORIENTATION_TOL)


def test_a_small_final_hold_keeps_the_grid_and_holds_from_the_third_last_sample():
    path, t = _line(0.004), np.linspace(0.0, 1.0, 11)
    assert hold_cut(path, t)[0] == pytest.approx(0.004 * (1 - 0.8**2))  # what the hold cuts
    grid, held = ending_at_rest(path, t)
    np.testing.assert_array_equal(grid, t)
    ts = np.array([0.0, 0.45, 0.79, 0.8, 0.85, 0.95, 1.0])
    x = held(ts)[:, 0, 3]
    np.testing.assert_allclose(x[:3], 0.004 * ts[:3] ** 2)  # the path itself before t_{N-2}
    np.testing.assert_allclose(x[3:], 0.004)  # its final pose from t_{N-2} on: what q_N = q_{N-1} = q_{N-2} plans
    # the resampled task holds on its own grid
    other = held.on(np.linspace(0.0, 1.0, 21))
    assert other(np.array([0.89]))[0, 0, 3] == pytest.approx(0.004 * 0.89**2)
    assert other(np.array([0.9]))[0, 0, 3] == pytest.approx(0.004)


def test_a_hold_that_would_cut_the_path_moves_after_its_end():
    path, t = _line(0.1), np.linspace(0.0, 1.0, 11)  # the hold would cut 3.6 cm
    assert hold_cut(path, t)[0] > TRACKING_POSITION_TOL
    grid, held = ending_at_rest(path, t)
    assert isinstance(held, HeldPath) and held.end == 1.0
    assert grid.size == t.size  # as many samples as asked for
    np.testing.assert_allclose(grid[:-2], np.linspace(0.0, 1.0, 9))
    np.testing.assert_allclose(grid[-2:], [1.125, 1.25])  # two hold samples, h and 2 h after the end
    x = held(grid)[:, 0, 3]
    np.testing.assert_allclose(x[:-2], 0.1 * grid[:-2] ** 2)  # nothing of the path is cut
    np.testing.assert_allclose(x[-3:], 0.1)


@pytest.mark.slow
@pytest.mark.parametrize("waypoints", [11, 21, 31, 61, 81])
def test_the_papers_lift_is_feasible_and_executes_at_any_resolution(waypoints, tmp_path):
    task = forte.load_task(LIFT, waypoints=waypoints)
    assert task.n == waypoints
    plan = forte.plan(task)
    assert plan.feasible, plan.verdict.reason()
    result = _simulate(plan, tmp_path / "lift")
    assert result.success, result.detail


def test_the_default_lift_keeps_its_grid():
    task = forte.load_task(LIFT)
    np.testing.assert_array_equal(task.t, np.linspace(0.0, 10.0, 41))  # the paper's 41 samples over 10 s


@pytest.mark.slow
def test_a_short_last_segment_is_feasible(tmp_path):
    task = task_from_dict({
        "name": "short-last", "payload": {"mass": 1.0},
        "path": {"kind": "waypoints", "relative": True, "samples": 49,
                 "waypoints": [{"t": 0.0, "position": [0.0, 0.0, 0.0]}, {"t": 10.5, "position": [0.1, 0.3, 0.1]},
                               {"t": 12.0, "position": [0.1, 0.3, 0.0]}]}}, tmp_path / "task.yaml")
    assert task.t[-3] == pytest.approx(12.0) and task.n == 49  # the hold moved after the path's end
    plan = forte.plan(task)
    assert plan.feasible, plan.verdict.reason()


def _kinova(rounds: int | None = None, on_spline: bool | None = None) -> dict:
    task = {"name": "kinova-urdf",
            "robot": {"urdf": "erd:kinova_description/robots/kinova.urdf", "ee_frame": "j2s6s200_end_effector",
                      "mount": {"xyz": [0.2575, 0.0, 0.52]}},
            "initial_configuration": [0, 0, 0, 4.80, 2.92, 1.00, 4.20, 1.44, 1.32],
            "path": {"kind": "waypoints", "relative": True, "samples": 31,
                     "waypoints": [{"t": 0.0, "position": [0.0, 0.0, 0.0]}, {"t": 5.0, "position": [0.3, 0.0, 0.0]}]},
            "payload": {"mass": 1.5}}
    task |= {} if on_spline is None else {"limits": {"on_spline": on_spline}}
    return task if rounds is None else task | {"solver": {"refine_rounds": rounds}}


@pytest.mark.slow
def test_an_own_urdf_riding_its_velocity_limits_keeps_them_on_the_executed_spline(tmp_path):
    """The NLP bounds the executed spline's velocities (limits.on_spline, on by default): the
    first solve is feasible, without a refinement round, and the spline (sampled 50 times per
    interval here, not at the verdict's samples) rides the limits without passing them."""
    from forte.model.trajectory import clamped_spline

    plan = forte.plan(task_from_dict(_kinova(), tmp_path / "task.yaml"))
    assert plan.feasible, plan.verdict.reason()
    assert not plan.solver.get("refinement", {}).get("rounds")
    t = plan.task.t
    dense = np.unique(np.concatenate([np.linspace(a, b, 50) for a, b in zip(t[:-1], t[1:], strict=True)]))
    _, v, _ = clamped_spline(t, plan.q, dense)
    ratio = np.max(np.abs(v[:, 3:]), axis=0) / np.asarray(plan.robot.model.velocityLimit)  # the URDF's
    assert np.max(ratio) <= 1.0 + 1e-6
    assert np.max(ratio) > 0.95  # it rides them: without the rows this plan's spline passes them
    result = _simulate(plan, tmp_path / "kinova")
    assert result.success, result.detail


@pytest.mark.slow
def test_an_own_urdf_riding_its_velocity_limits_is_refined_until_it_executes(tmp_path):
    """Without the spline's rows (limits.on_spline: false) the waypoint rows let the spline pass
    the limits between waypoints; the refinement rounds tighten the NLP's bounds until it executes."""
    unrefined = forte.plan(task_from_dict(_kinova(rounds=0, on_spline=False), tmp_path / "task.yaml"))
    assert unrefined.verdict.failed == ("velocity",)
    detail = unrefined.verdict.violations[0].detail
    assert "between waypoints only" in detail and "(j2s6s200_joint_" in detail and "(between waypoints " in detail
    plan = forte.plan(task_from_dict(_kinova(on_spline=False), tmp_path / "task.yaml"))
    assert plan.feasible, plan.verdict.reason()
    rounds = plan.solver["refinement"]["rounds"]
    assert rounds and all(r["failed"] in ([], ["velocity"]) for r in rounds)
    limit = np.asarray(plan.robot.model.velocityLimit)
    assert np.any(np.asarray(rounds[-1]["velocity"])[3:] < limit)  # an NLP bound below the URDF's
    result = _simulate(plan, tmp_path / "kinova")
    assert result.success, result.detail


def test_a_limit_violation_names_the_joint_the_waypoint_and_the_time():
    task = forte.load_task(LIFT)
    plan = forte.plan(task, "quintic")  # the taught interpolation, not optimized
    vel = np.max(np.abs(np.diff(plan.q[:, 3:], axis=0) / 0.25), axis=0)
    j = int(np.argmax(vel))
    tight = np.full(7, 10.0)
    tight[j] = 0.5 * vel[j]  # only joint j too fast
    verdict = judge_plan(task.__class__(**{**task.__dict__, "limits": KinematicLimits(arm_velocity=tuple(tight))}),
                         plan.q, task.force())
    found = {v.requirement: v for v in verdict.violations}["velocity"]
    name = plan.robot.arm_joints[j]
    assert f"({name})" in found.detail and "at t = " in found.detail
    assert "(waypoint " in found.detail or "(between waypoints " in found.detail
    assert found.worst == pytest.approx(2.0, rel=0.3)


def test_a_task_file_keeps_its_sample_count_when_the_hold_moves(tmp_path):
    text = yaml.safe_dump({"name": "x", "payload": {"mass": 1.0},
                           "path": {"kind": "waypoints", "relative": True, "samples": 9,
                                    "waypoints": [{"t": 0.0, "position": [0, 0, 0]},
                                                  {"t": 2.0, "position": [0.1, 0, 0]}]}})
    (tmp_path / "t.yaml").write_text(text)
    task = forte.load_task(tmp_path / "t.yaml")
    assert task.n == 9 and task.t[-1] > 2.0  # 9 samples on a 2 s blend: the hold cuts more than 1 cm
    np.testing.assert_allclose(task.targets[-3:, :3, 3], np.repeat(task.targets[-1:, :3, 3], 3, axis=0))


def test_a_resampled_task_decides_its_hold_as_a_loaded_one():
    loaded = forte.load_task(LIFT, waypoints=12)
    assert loaded.t[-1] > 10.0  # 12 samples: the hold would cut 5 cm, so it moves after the path's end
    resampled = forte.load_task(LIFT).resampled(12)
    np.testing.assert_allclose(resampled.t, loaded.t, atol=1e-12)
    np.testing.assert_allclose(resampled.targets, loaded.targets, atol=1e-12)
    assert forte.load_task(LIFT, waypoints=12).resampled(41).t[-1] == pytest.approx(10.0)


@pytest.mark.slow
def test_an_arm_that_would_pass_through_the_torso_gets_self_collision_rows_and_goes_around(tmp_path):
    """TIAGo from its own URDF (with its hand and the hand's safety box) and a start posture of the
    user's: the plan without rows brings the hand's box through the torso column; solved again with
    the robot's own pairs as rows (those whose covers overlap at the start keep their start
    distance) it goes around, and executes."""
    task = task_from_dict({
        "name": "tiago-urdf",
        "robot": {"urdf": "erd:tiago_description/robots/tiago.urdf", "ee_frame": "arm_tool_link",
                  "base": "differential",
                  "arm_joints": ["torso_lift_joint", *(f"arm_{i}_joint" for i in range(1, 8))]},
        "initial_configuration": [0, 0, 0, 0.15, 0.2, -1.34, -0.2, 1.94, -1.57, 1.37, 0.0],
        "path": {"kind": "waypoints", "relative": True, "samples": 31,
                 "waypoints": [{"t": 0.0, "position": [0.0, 0.0, 0.0]}, {"t": 5.0, "position": [0.3, 0.0, 0.0]}]},
        "payload": {"mass": 0.5}}, tmp_path / "task.yaml")
    plan = forte.plan(task)
    assert plan.feasible, plan.verdict.reason()
    record = plan.solver["self_rows"]
    assert record["kept"] and record["verdict"] == "feasible"
    assert "clearance_rows" in plan.solver  # the kept plan is the one solved with rows
    result = _simulate(plan, tmp_path / "tiago")
    assert result.success, result.detail


def test_a_force_profile_holds_its_end_value_over_hold_samples_after_the_path():
    task = forte.load_task("examples/tasks/continuous.yaml", waypoints=9)  # the hold would cut the sine
    end = task.targets_at.end
    assert task.t[-3] == pytest.approx(end) and task.t[-1] > end
    at_end = task.force_at(np.array([end]))
    np.testing.assert_array_equal(task.force_profile.t, task.t)
    np.testing.assert_allclose(task.force_profile.f[-3:], np.repeat(at_end.f, 3, axis=0))
    np.testing.assert_allclose(task.force_profile.r[-3:], at_end.r[0])
    # on the path the profile is the file's windowed sine, unchanged
    raw = forte.load_task("examples/tasks/continuous.yaml")
    np.testing.assert_allclose(task.force_profile.f[:-2], raw.force_at(task.t[:-2]).f)


def test_refinement_rounds_keep_the_self_collision_rows_of_a_plan_kept_apart(monkeypatch):
    """A plan that self-collision rows kept apart is re-solved by the velocity rounds with those rows
    (without them, a round's re-solve could bring the arm back through the robot)."""
    from forte.planning import rounds
    from forte.planning.methods.catalog import get_method

    task = forte.load_task(LIFT, mass=0.35, waypoints=9)
    force = task.force()
    q = task.nominal()
    sol = rounds.SolverResult(q=q, success=True, status="Solve_Succeeded", iterations=1, objective=0.0,
                               constraint_violation=0.0, build_time=0.0, solve_time=0.0, codegen="python")
    calls = []

    def optimize(*args, self_rows=False, **kwargs):
        calls.append(self_rows)
        return sol, {}

    monkeypatch.setattr(rounds, "optimize", optimize)
    monkeypatch.setattr(rounds, "limit_ratios", lambda task, q: (np.full(task.robot.nq, 1.2),
                                                                    np.full(task.robot.n_arm, 0.5)))
    verdict = type("V", (), {"failed": ("velocity",), "violations": (), "feasible": False, "label": "infeasible"})()
    feasible = type("V", (), {"failed": (), "violations": (), "feasible": True, "label": "feasible"})()
    monkeypatch.setattr(rounds, "judge_plan", lambda *a, **k: feasible)
    for kept in (True, False):
        calls.clear()
        rounds.refine(task, get_method("forte"), force, sol, {"self_rows": {"kept": kept}}, verdict)
        assert calls == [kept]


def test_a_self_collision_re_solve_that_did_not_converge_replaces_only_an_unconverged_plan(monkeypatch):
    """``apart`` keeps a collision-free re-solve when it converged, or when the plan it would
    replace did not converge either; an unconverged re-solve never replaces a converged plan."""
    from forte.planning import rounds
    from forte.planning.methods.catalog import get_method

    task = forte.load_task(LIFT, mass=0.35, waypoints=9)
    force = task.force()

    def result(success: bool, offset: float):
        return rounds.SolverResult(q=task.nominal() + offset, success=success,
                                   status="Solve_Succeeded" if success else "Maximum_CpuTime_Exceeded",
                                   iterations=3, objective=0.0, constraint_violation=0.0, build_time=0.0,
                                   solve_time=0.0, codegen="python")

    def verdict(failed):
        label = "infeasible" if failed else "feasible"
        return type("V", (), {"failed": failed, "violations": (), "feasible": not failed, "label": label,
                              "reason": lambda self: f"{label}: {', '.join(failed)}"})()

    colliding = verdict(("self_collision",))
    cases = {(True, True): True, (True, False): False, (False, True): True, (False, False): True}
    for (original_converged, trial_converged), keep in cases.items():
        sol, trial = result(original_converged, 0.0), result(trial_converged, 0.01)
        monkeypatch.setattr(rounds, "optimize", lambda *a, trial=trial, **k: (trial, {"clearance_rows": 1}))
        monkeypatch.setattr(rounds, "judged", lambda task, q, force, info: (verdict(("velocity",)), force))
        kept, info, kept_verdict, _ = rounds.apart(task, get_method("forte"), force, None, sol, {}, colliding)
        assert info["self_rows"]["kept"] is keep, (original_converged, trial_converged)
        assert (kept is trial) is keep and (kept_verdict is colliding) is not keep
        assert info["self_rows"]["status"] == trial.status and info["self_rows"]["reason"] == "infeasible: velocity"
    # a re-solve that still collides is never kept
    monkeypatch.setattr(rounds, "judged", lambda task, q, force, info: (colliding, force))
    kept, info, _, _ = rounds.apart(task, get_method("forte"), force, None, result(False, 0.0), {}, colliding)
    assert not info["self_rows"]["kept"] and kept is not trial


@pytest.mark.slow
def test_the_tiago_reaches_down_with_its_arm_and_clear_of_its_column(tmp_path):
    """The preset TIAGo reaching 0.3 m down in 5 s: its reference posture (the IK, a prismatic joint
    weighted by the fraction of its range it uses) lowers the hand with the arm, so the plan keeps
    the torso lift above where its URDF's arm_1_link meets the column's box (~0.115 m) and within
    its 0.07 m/s; it is feasible and executes (before: the torso raced down into the column)."""
    task = task_from_dict({
        "name": "tiago-down", "robot": {"preset": "tiago"},
        "path": {"kind": "waypoints", "relative": True, "samples": 21,
                 "waypoints": [{"t": 0.0, "position": [0.0, 0.0, 0.0]}, {"t": 5.0, "position": [0.0, 0.0, -0.3]}]},
        "payload": {"mass": 0.5}}, tmp_path / "task.yaml")
    plan = forte.plan(task)
    assert plan.feasible, plan.verdict.reason()
    assert plan.q[:, 3].min() > 0.12
    result = _simulate(plan, tmp_path / "tiago")
    assert result.success, result.detail
