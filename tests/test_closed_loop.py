"""Closed-loop execution: a misjudged payload is identified and the remaining motion re-planned."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from forte.cli.main import main
from forte.exceptions import InvalidInputError
from forte.execution.closed_loop import ReplanOptions
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
    assert main(["simulate", "x", "--add-mass", "soon"]) == 2  # argparse: one line, exit 2


def test_replan_experiment_writes_its_summary(tmp_path):
    from forte.experiments import run_replan

    doc = run_replan(tmp_path / "replan", waypoints=25)
    runs = doc["runs"]
    misjudged = next(v for k, v in runs.items() if k.startswith("misjudged"))
    assert not misjudged["without"]["success"] and misjudged["with"]["success"]
    assert (tmp_path / "replan" / "replan.png").is_file() and doc["generator"] == "forte"
    assert "| scenario |" in (tmp_path / "replan" / "summary.md").read_text()
