"""Closed-loop execution: a misjudged payload is identified and the remaining motion re-planned."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from forte.cli.main import main
from forte.exceptions import InvalidInputError
from forte.execution.closed_loop import ON_INFEASIBLE, ReplanOptions
from forte.execution.run import simulate_plan

LIFT = Path(__file__).resolve().parents[1] / "examples" / "tasks" / "lift-path.yaml"  # moca-like robot


@pytest.fixture(scope="module")
def light_plan(tmp_path_factory):
    out = tmp_path_factory.mktemp("closed") / "light"
    assert main(["plan", str(LIFT), "--mass", "0.35", "--out", str(out), "--quiet",
                 "--no-figures"]) == 0
    return out


def test_a_misjudged_payload_fails_open_loop_and_succeeds_with_replanning(light_plan, capsys):
    open_loop = simulate_plan(light_plan, mass=2.7, write=False, stop_on_failure=True)
    assert not open_loop.success and open_loop.reason == "torque saturation"
    code = main(["simulate", str(light_plan), "--true-mass", "2.7", "--replan", "--out",
                 str(light_plan.parent / "replanned")])
    err = capsys.readouterr().err
    assert code == 0, err
    summary = json.loads((light_plan.parent / "replanned" / "sim.json").read_text())
    replanning = summary["summary"]["replanning"] if "summary" in summary else summary["replanning"]
    assert replanning["replans"] >= 1 and replanning["replans_failed"] == 0
    assert abs(replanning["final_mass_estimate"] - 2.7) < 0.05
    first = replanning["log"][0]
    assert first["t"] <= 0.2 and first["planned_mass"] == 0.35 and first["warm"]
    assert "re-plans" in err and "latency median" in err


def test_mass_added_mid_motion_is_identified(light_plan):
    result = simulate_plan(light_plan, mass=0.35, write=False,
                           replan=ReplanOptions(enabled=False, add_mass=(1.0, 1.5)))
    estimates = result.summary["replanning"]["estimates"]
    before = [e["mass"] for e in estimates if 0.7 <= e["t"] < 1.0]
    after = [e["mass"] for e in estimates if e["t"] >= 1.8]
    assert all(abs(m - 0.35) < 0.1 for m in before), before
    assert all(abs(m - 1.85) < 0.05 for m in after), after  # within 0.8 s of the change, and after
    assert result.summary["replanning"]["replans"] == 0  # identification only


def test_bad_replan_options():
    with pytest.raises(InvalidInputError, match="add_mass"):
        ReplanOptions(add_mass=(1.0, -2.0))
    with pytest.raises(InvalidInputError, match="^on_infeasible: expected one of splice, keep, stop"):
        ReplanOptions(on_infeasible="slow")
    assert main(["simulate", "x", "--add-mass", "soon"]) == 2  # argparse: one line, exit 2


def test_replan_experiment_writes_its_summary(tmp_path):
    from forte.experiments import run_replan

    doc = run_replan(tmp_path / "replan", waypoints=25)
    runs = doc["runs"]
    misjudged = next(v for k, v in runs.items() if k.startswith("misjudged"))
    assert not misjudged["without"]["success"] and misjudged["with"]["success"]
    assert (tmp_path / "replan" / "replan.png").is_file() and doc["generator"] == "forte"
    assert "| scenario |" in (tmp_path / "replan" / "summary.md").read_text()


@pytest.mark.parametrize("rule", ON_INFEASIBLE)
def test_an_infeasible_replan_gets_the_loops_rule(light_plan, rule):
    """The first re-plan for the identified 2.7 kg converges but its verdict (waypoints and 8
    samples per interval) is infeasible. ``splice`` (the default) follows it anyway; ``keep``
    leaves the 0.35 kg plan in force, so the next re-plan still starts from 0.35 kg; ``stop``
    holds the plan in force at the re-plan's first waypoint: no more re-plans, the robot ends there."""
    from forte.io.plandir import read_plan_dir

    assert ReplanOptions().on_infeasible == "splice"
    result = simulate_plan(light_plan, mass=2.7, write=False, replan=ReplanOptions(on_infeasible=rule))
    r = result.summary["replanning"]
    first = r["log"][0]
    assert first["success"] and first["verdict"] == "infeasible" and first["failed"] and r["replans_infeasible"] >= 1
    assert first["applied"] == {"splice": "spliced", "keep": "kept", "stop": "stopped"}[rule]
    assert r["on_infeasible"] == rule
    if rule == "splice":
        assert all(e["planned_mass"] != 0.35 for e in r["log"][1:])  # the plan in force is 2.7 kg's
    if rule == "keep":
        assert len(r["log"]) >= 2 and r["log"][1]["planned_mass"] == 0.35
    if rule == "stop":
        j = first["waypoint"]
        assert len(r["log"]) == 1 and r["stopped_at_waypoint"] == j
        final = np.array([result.log[c][-1] for c in ("x_b", "y_b", "yaw")] +
                         [result.log[f"q{i}"][-1] for i in range(1, 8)])
        assert np.abs(final - read_plan_dir(light_plan).q[j]).max() < 0.02  # held at waypoint j
