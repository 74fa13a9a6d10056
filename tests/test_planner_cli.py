"""forte plan / compare end to end: outputs, failure behaviour, atomic writes, unreachable poses."""

from __future__ import annotations

import csv
import json
import re
from pathlib import Path

import numpy as np
import pytest
import yaml

from forte.cli.main import main
from forte.exceptions import InfeasibleTaskError
from forte.planning.planner import methods_for, plan
from forte.planning.tasks.tasks import load_task

EXAMPLES = Path(__file__).resolve().parents[1] / "examples" / "tasks"


def test_plan_writes_every_output(tmp_path):
    out = tmp_path / "lift"
    # 9 waypoints over 6 s: the spline between them leaves the path by more than 1 cm (tracking),
    # so the plan is written for inspection and the command exits 1
    assert main(["plan", str(EXAMPLES / "lift-path.yaml"), "--waypoints", "9", "--out", str(out), "--quiet"]) == 1
    names = {p.name for p in out.iterdir()}
    assert {"trajectory.csv", "metrics.csv", "plan.json", "capacity.png", "manipulability.png",
            "rfp_worst.png", "ellipsoid.png"} <= names
    rows = list(csv.reader((out / "trajectory.csv").open()))
    assert rows[0] == ["t", "x_b", "y_b", "yaw", *[f"q{i}" for i in range(1, 8)]] and len(rows) == 10
    header = next(csv.reader((out / "metrics.csv").open()))
    for col in ("t", "fx", "fy", "fz", "radius", "d", "directional_capacity", "inscribed_radius",
                "manipulability", "max_torque_ratio"):
        assert col in header
    doc = json.loads((out / "plan.json").read_text())
    assert doc["status"] == "infeasible" and doc["method"] == "forte" and doc["solver_status"] == "Solve_Succeeded"
    assert "tracking" in [v["requirement"] for v in doc["verdict"]["failed"]]
    assert doc["robot"]["torque_limits"] == [60, 60, 60, 60, 12, 12, 12]
    # alpha has one place in plan.json: the capability parameters
    assert doc["weights"]["capability_params"]["alpha"] == 0.9 and doc["robot"]["tool"]["mass"] > 0  # authors' set
    assert "alpha" not in doc["robot"] and doc["generator"] == "forte" and doc["format_version"] == 4
    assert doc["solver"]["iterations"] > 0 and doc["solver"]["constraint_violation"] < 1e-6
    assert doc["weights"]["preset"] == "forte-trajectory" and doc["weights"]["capability"] == 5.0
    assert "casadi" in doc["versions"]
    # every term's settings, by term, as the terms declare them (the weights block keeps the older names)
    assert doc["term_settings"]["manipulability"]["lambda"] == doc["weights"]["manipulability_lambda"] == 1e-6
    assert doc["term_settings"]["base_spectral"]["cutoff"] == doc["weights"]["dct_cutoff"] == 0.1
    assert doc["solver"]["term_settings"]["joint_limits"]["margin_fraction"] == {"value": 0.05, "unit": "1",
                                                                                "default": 0.05}
    # a plan.json written before the terms declared their settings reads the same
    old = {k: v for k, v in doc.items() if k != "term_settings"}
    old["solver"] = {k: v for k, v in doc["solver"].items() if k != "term_settings"}
    (out / "plan.json").write_text(json.dumps(old))
    from forte.io.plandir import read_plan_dir
    np.testing.assert_array_equal(read_plan_dir(out).q, np.loadtxt(out / "trajectory.csv", delimiter=",",
                                                                    skiprows=1)[:, 1:])
    # the metrics in the CSV are the exact ones, recomputed from the trajectory
    task = load_task(EXAMPLES / "lift-path.yaml", waypoints=9)
    q = np.loadtxt(out / "trajectory.csv", delimiter=",", skiprows=1)[:, 1:]
    from forte.planning.planner import evaluate
    m = evaluate(task.robot, q, task.t, task.force(), task.settings.capability_params)
    np.testing.assert_allclose(np.loadtxt(out / "metrics.csv", delimiter=",", skiprows=1)[:, header.index("d")],
                               m["d"], rtol=1e-9)


def test_failed_optimization_never_replaces_a_good_plan(tmp_path, capsys):
    out = tmp_path / "lift"
    args = ["plan", str(EXAMPLES / "lift.yaml"), "--mass", "0.35", "--out", str(out), "--quiet", "--no-figures"]
    assert main(args) == 0
    good = (out / "trajectory.csv").read_text()
    data = yaml.safe_load((EXAMPLES / "lift.yaml").read_text())
    data["solver"] = {"max_iter": 1}
    bad_task = tmp_path / "lift_bad.yaml"
    bad_task.write_text(yaml.safe_dump(data))
    capsys.readouterr()
    assert main(["plan", str(bad_task), "--mass", "0.35", "--out", str(out), "--quiet", "--no-figures"]) == 1
    assert "solver-failed: solver: IPOPT stopped with Maximum_Iterations_Exceeded" in capsys.readouterr().err
    assert (out / "trajectory.csv").read_text() == good
    failed = tmp_path / "lift.failed"
    doc = json.loads((failed / "plan.json").read_text())
    assert doc["status"] == "solver-failed" and doc["solver_status"] == "Maximum_Iterations_Exceeded"
    assert not (failed / "trajectory.csv").exists() and (failed / "last_iterate.csv").exists()
    # a fresh directory receives the failure report itself
    fresh = tmp_path / "fresh"
    assert main(["plan", str(bad_task), "--mass", "0.35", "--out", str(fresh), "--quiet", "--no-figures"]) == 1
    assert json.loads((fresh / "plan.json").read_text())["status"] == "solver-failed"
    assert not (fresh / "trajectory.csv").exists()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no temporary leftovers


def test_unreachable_waypoint_is_named(tmp_path, capsys):
    data = yaml.safe_load((EXAMPLES / "lift-path.yaml").read_text())
    data["path"]["waypoints"][1]["position"] = [0.0, 0.0, 3.0]
    path = tmp_path / "far.yaml"
    path.write_text(yaml.safe_dump(data))
    task = load_task(path, waypoints=12)
    # named as the user wrote the path: the sample's time and the task file's waypoints around it
    with pytest.raises(InfeasibleTaskError, match=r"waypoint \d+ \(t = [0-9.]+ s, between path\.waypoints\[0\] "
                       r"and path\.waypoints\[1\]\): end-effector pose unreachable, position error"):
        plan(task, "forte")
    assert main(["plan", str(path), "--waypoints", "12", "--out", str(tmp_path / "o"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("forte: error: waypoint") and "Traceback" not in err
    assert not (tmp_path / "o").exists()


def _tiago_reach(tmp_path: Path, end: list[float]) -> Path:
    """The TIAGo from its URDF on its differential base, a 0.3 m reach in 5 s from the user's posture."""
    doc = {"name": "tiago-reach", "payload": {"mass": 1.0},
           "robot": {"urdf": "erd:tiago_description/robots/tiago.urdf", "base": "differential",
                     "ee_frame": "arm_tool_link",
                     "arm_joints": ["torso_lift_joint", *(f"arm_{i}_joint" for i in range(1, 8))]},
           "initial_configuration": [0, 0, 0, 0.15, 0.2, -1.34, -0.2, 1.94, -1.57, 1.37, 0.0],
           "path": {"kind": "waypoints", "relative": True, "samples": 31,
                    "waypoints": [{"t": 0.0, "position": [0.0, 0.0, 0.0]}, {"t": 5.0, "position": end}]}}
    path = tmp_path / "tiago.yaml"
    path.write_text(yaml.safe_dump(doc))
    return path


def test_millimetres_of_ik_residual_are_a_start_not_an_unreachable_pose(tmp_path, capsys):
    from forte.planning.tasks.ik import REACH_POSITION_M, initial_guess, pose_error, position_reach, solve_pose

    task = load_task(_tiago_reach(tmp_path, [0.2, 0.0, -0.2]))
    guess = initial_guess(task)  # the tracking IK alone stalls 5.9 mm short at waypoint 21 (exit 2 before)
    stalled = solve_pose(task.robot, task.targets[21], guess[20])[1]
    assert 1e-4 < np.linalg.norm(stalled[:3]) < REACH_POSITION_M
    residual = max(np.linalg.norm(pose_error(task.robot, q, T)[:3]) for q, T in zip(guess, task.targets, strict=True))
    assert residual < REACH_POSITION_M
    # farther down the IK's guess stays over 5 cm off the pose (0.4 m down: 5.6 cm; 0.3 m: 2.9 cm since
    # the IK weighs the torso lift by its range), yet the point itself is in reach (the hand turned):
    # the NLP tries from the best guess
    far = load_task(_tiago_reach(tmp_path, [0.0, 0.0, -0.4]))
    guess = initial_guess(far)
    errors = [pose_error(far.robot, q, T) for q, T in zip(guess, far.targets, strict=True)]
    assert max(np.linalg.norm(e[:3]) for e in errors) > REACH_POSITION_M
    assert position_reach(far.robot, far.targets[-1], guess[-1]) < 1e-4


def test_only_a_point_the_whole_body_cannot_reach_is_refused_with_its_distance(tmp_path, capsys):
    from forte.planning.tasks.ik import REACH_POSITION_M, position_reach

    up = load_task(_tiago_reach(tmp_path, [0.0, 0.0, 1.5]))  # 1.5 m above a hand at 0.62 m
    assert main(["plan", str(_tiago_reach(tmp_path, [0.0, 0.0, 1.5])), "--out", str(tmp_path / "o"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    found = re.search(r"waypoint (\d+) \(t = [0-9.]+ s, between path\.waypoints\[0\] and path\.waypoints\[1\]\): "
                      r"end-effector pose unreachable, position error ([0-9.e-]+) m: no posture of the whole body "
                      r"brings the end effector nearer", err)
    assert found, err
    k, distance = int(found.group(1)), float(found.group(2))
    assert distance > REACH_POSITION_M
    # the distance is to the nearest point the hand reaches: a point that much closer, along the
    # way up from the hand's best posture, is within reach (an independent check of the number)
    best_height = up.targets[k, 2, 3] - distance
    closer = up.targets[k].copy()
    closer[2, 3] = best_height - 0.01
    assert position_reach(up.robot, closer, up.q_init) < 1e-4
    assert 0 < k < up.n


def test_compare_hold_runs_every_method(tmp_path):
    out = tmp_path / "cmp"
    # at 2.7 kg only forte's posture holds the ball: the others are infeasible, so the command exits 1
    assert main(["compare", str(EXAMPLES / "hold.yaml"), "--out", str(out), "--quiet"]) == 1
    rows = list(csv.DictReader((out / "summary.csv").open()))
    methods = [r["method"] for r in rows]
    assert methods == list(methods_for(load_task(EXAMPLES / "hold.yaml")))  # every method that applies
    assert {"forte", "manipulability", "rfp-radius", "rfp-cone", "teaching"} <= set(methods)
    assert (out / "comparison.png").stat().st_size > 1000
    summary = (out / "summary.md").read_text()
    assert "| forte | feasible |  |" in summary and "| teaching | infeasible | capacity (" in summary
    assert "success" not in summary
    for r in rows:
        assert (out / r["method"] / "plan.json").exists()


def test_method_must_fit_the_mode(tmp_path, capsys):
    assert main(["plan", str(EXAMPLES / "hold.yaml"), "--method", "quintic", "--out", str(tmp_path / "x")]) == 2
    assert "does not apply to mode 'hold'" in capsys.readouterr().err


def test_demo_command(capsys):
    assert main(["demo", "--mass", "1.0"]) == 0
    assert "residual force polytope" in capsys.readouterr().out
    assert main(["demo", "--mass", "-1"]) == 2
    assert "mass: expected a finite number > 0" in capsys.readouterr().err


def test_payload_description_goes_through_the_estimator(tmp_path):
    data = yaml.safe_load((EXAMPLES / "lift-path.yaml").read_text())
    data["payload"] = {"description": "two 1.5 L bottles of water in the basket"}
    path = tmp_path / "est.yaml"
    path.write_text(yaml.safe_dump(data))
    out = tmp_path / "plan"
    assert main(["plan", str(path), "--waypoints", "10", "--out", str(out), "--quiet", "--no-figures",
                 "--allow-infeasible", "--no-bound"]) == 0
    doc = json.loads((out / "plan.json").read_text())
    estimate = doc["payload"]["estimate"]
    assert estimate["source"].startswith("offline")
    assert 3.0 <= doc["payload"]["mass"] <= 3.3  # 3 L of water plus the bottles
    assert doc["payload"]["mass"] == estimate["mass_kg"]
    assert doc["force"]["f"][0][2] == pytest.approx(doc["payload"]["mass"] * 9.81)
    # an explicit --mass wins over the estimator
    assert main(["plan", str(path), "--waypoints", "10", "--out", str(out), "--quiet", "--no-figures",
                 "--mass", "1.0", "--allow-infeasible", "--no-bound"]) == 0
    doc = json.loads((out / "plan.json").read_text())
    assert doc["payload"]["mass"] == 1.0 and doc["payload"]["estimate"] is None


def test_payload_without_quantity_is_refused(tmp_path, capsys):
    data = yaml.safe_load((EXAMPLES / "lift.yaml").read_text())
    data["payload"] = {"description": "some drinks"}
    path = tmp_path / "vague.yaml"
    path.write_text(yaml.safe_dump(data))
    assert main(["plan", str(path), "--waypoints", "10", "--out", str(tmp_path / "o"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "--mass" in err and "Traceback" not in err


def test_another_urdf_arm_plans(tmp_path):
    """The planner is not tied to the Panda: a UR5 on the same holonomic base lifts a payload."""
    data = yaml.safe_load((EXAMPLES / "lift-path.yaml").read_text())
    data["robot"] = {"urdf": "erd:ur_description/urdf/ur5_robot.urdf", "ee_frame": "tool0",
                     "mount": {"xyz": [0.2, 0.0, 0.45]}, "tool": None}
    data["initial_configuration"] = [0, 0, 0, 0.0, -1.2, 1.5, -1.87, -1.57, 0.0]
    data["weights"] = {"preset": "paper-demo"}  # the authors' sets carry Panda-specific DoF weights
    data["path"]["waypoints"] = [{"t": 0.0, "position": [0, 0, 0]}, {"t": 3.0, "position": [0.1, 0.0, -0.2]}]
    path = tmp_path / "ur5.yaml"
    path.write_text(yaml.safe_dump(data))
    task = load_task(path, waypoints=12)
    res = plan(task, "forte")
    assert res.solved, res.status
    assert res.q.shape == (12, 9)
    for qk, Tk in zip(res.q, task.targets, strict=True):
        assert np.linalg.norm(task.robot.ee_pose(qk)[:3, 3] - Tk[:3, 3]) < 1e-6
    assert np.all(res.metrics["d"] > -1.0)  # the 2.7 kg ball fits (up to the surrogate's slack)
    # and it executes: the same task file (no controller block) planned and simulated end to end
    out = tmp_path / "ur5-plan"
    assert main(["plan", str(path), "--waypoints", "12", "--out", str(out), "--quiet", "--no-figures",
                 "--allow-infeasible"]) == 0  # judged (the coarse spline may leave the path); executed anyway
    assert main(["simulate", str(out), "--quiet"]) == 0
    sim = json.loads((out / "sim.json").read_text())
    assert sim["verdict"] == "success" and len(sim["gains"]["K_a"]) == 6


def test_tutorial_example_runs():
    import runpy

    from forte.planning.methods.catalog import METHODS
    from forte.planning.terms.costs import COST_TERMS

    saved = dict(METHODS), dict(COST_TERMS)
    try:
        runpy.run_path(str(EXAMPLES.parent / "tutorial.py"), run_name="__main__")
        assert "forte-stay" in METHODS and "base_distance" in COST_TERMS  # its registry section ran
    finally:  # the tutorial's toy term and method must not leak into later tests
        for registry, before in zip((METHODS, COST_TERMS), saved, strict=True):
            registry.clear()
            registry.update(before)


def test_compare_hold_without_teaching_runs_the_optimized_methods(tmp_path):
    data = yaml.safe_load((EXAMPLES / "hold.yaml").read_text())
    data["pose"] = {"position": [0.05, 0.0, -0.2], "relative": True}
    data.pop("teaching_configuration")
    path = tmp_path / "hold.yaml"
    path.write_text(yaml.safe_dump(data))
    out = tmp_path / "cmp"
    assert main(["compare", str(path), "--out", str(out), "--quiet", "--no-figures", "--allow-infeasible"]) == 0
    rows = list(csv.DictReader((out / "summary.csv").open()))
    methods = [r["method"] for r in rows]
    assert "teaching" not in methods and methods == list(methods_for(load_task(path)))
    assert {"forte", "manipulability", "rfp-radius", "rfp-cone"} <= set(methods)
    assert main(["plan", str(path), "--method", "teaching", "--out", str(tmp_path / "t")]) == 2


def test_failed_comparison_never_replaces_an_earlier_one(tmp_path):
    out = tmp_path / "cmp"
    assert main(["compare", str(EXAMPLES / "hold.yaml"), "--out", str(out), "--quiet", "--no-figures",
                 "--allow-infeasible"]) == 0
    before = (out / "summary.csv").read_text()
    data = yaml.safe_load((EXAMPLES / "hold.yaml").read_text())
    data["solver"] = {"max_iter": 1}
    data.pop("teaching_configuration")
    data["pose"] = {"position": [0.05, 0.0, -0.2], "relative": True}
    bad = tmp_path / "bad.yaml"
    bad.write_text(yaml.safe_dump(data))
    assert main(["compare", str(bad), "--out", str(out), "--quiet", "--no-figures"]) == 1
    assert (out / "summary.csv").read_text() == before
    assert "solver-failed" in (tmp_path / "cmp.failed" / "summary.csv").read_text()


def test_out_never_replaces_what_forte_did_not_write(tmp_path, capsys):
    """--out refuses a folder of the user's and a plain file before planning, exit 2, nothing touched."""
    mine = tmp_path / "mydata"
    mine.mkdir()
    (mine / "thesis.tex").write_text("years of work")
    plain = tmp_path / "afile"
    plain.write_text("keep me")
    for out in (mine, plain):
        code = main(["plan", str(EXAMPLES / "hold.yaml"), "--method", "teaching", "--mass", "1", "--out", str(out),
                     "--quiet", "--no-figures"])
        err = capsys.readouterr().err
        assert code == 2 and err.count("\n") == 1, err
        assert "forte did not write" in err or "not a directory forte wrote" in err
    assert (mine / "thesis.tex").read_text() == "years of work" and plain.read_text() == "keep me"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["afile", "mydata"]  # no stray temporary directory


def test_out_replaces_its_own_plan_and_an_empty_folder(tmp_path):
    out = tmp_path / "plan"
    out.mkdir()  # empty: nothing to lose
    args = ["plan", str(EXAMPLES / "hold.yaml"), "--method", "teaching", "--out", str(out), "--quiet", "--no-figures",
            "--allow-infeasible", "--no-bound"]
    assert main([*args, "--mass", "1"]) == 0
    assert main([*args, "--mass", "2"]) == 0  # forte's own plan is replaced
    assert json.loads((out / "plan.json").read_text())["payload"]["mass"] == 2.0
