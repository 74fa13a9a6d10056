"""``forte experiment wrench`` (issue 25, item 5) end to end at a small size."""

from __future__ import annotations

import json

from forte.cli.main import main
from forte.experiments import run_wrench
from forte.experiments.wrench import FORCE_ONLY


def test_wrench_experiment_at_one_offset(tmp_path):
    out = tmp_path / "wrench"
    # the task's 41 waypoints: at 21 the spline between them leaves the path by more than 1 cm (tracking)
    doc = run_wrench(out, offsets=(0.2,), rows=("forte", FORCE_ONLY, "quintic"))
    assert json.loads((out / "summary.json").read_text()) == doc
    assert sorted(p.name for p in out.iterdir() if not p.name.startswith(".")) == \
        ["README.md", "summary.json", "wrench.png"]  # no plan directories kept
    rows = {r["method"]: r for r in doc["rows"]}
    forte, force_only, quintic = rows["forte"], rows[FORCE_ONLY], rows["quintic"]
    assert forte["verdict"] == "feasible" and forte["min_d_n"] >= 0 and forte["sims"][1]["success"]
    assert force_only["min_d_n"] < 0 and "capacity" in force_only["failed"]  # judged on the true wrench
    assert quintic["verdict"] == "infeasible" and not quintic["sims"][0]["success"]
    assert quintic["unscaled_verdict"] == "infeasible"  # not optimized: no solver requirement
    assert all(0.1 < r["min_tipover_margin_m"] < 0.2225 for r in doc["rows"])
    assert doc["agreement"]["all"]["plans"] == 3
    text = (out / "README.md").read_text()
    assert "| 0.2 | forte (force only) |" in text and "![offset payloads](wrench.png)" in text
    # the hold, whose posture is free: the wrench plan keeps d >= 0 and holds in MuJoCo, the
    # force-only plan loads a wrist joint past its limit and saturates there in MuJoCo too
    hold = {r["method"]: r for r in doc["hold"]["rows"]}
    wrench, force_only = hold["forte"], hold[FORCE_ONLY]
    assert wrench["verdict"] == "feasible" and wrench["min_d_n"] >= 0 and wrench["max_torque_ratio"] < 1
    assert all(sim["success"] for sim in wrench["sims"])
    assert force_only["max_torque_ratio"] > 1 and force_only["worst_joint"] in (5, 6, 7)
    assert "torque" in force_only["failed"] or "capacity" in force_only["failed"]
    assert not force_only["sims"][0]["success"] and force_only["sims"][0]["reason"] == "torque saturation"
    assert "## Holding 4 kg 0.2 m to the side of the hand" in text


def test_offsets_only_for_the_wrench_experiment(tmp_path, capsys):
    assert main(["experiment", "replan", "--offsets", "0.1", "--out", str(tmp_path / "x")]) == 2
    assert "--offsets" in capsys.readouterr().err
    assert main(["experiment", "wrench", "--offsets", "-0.1", "--out", str(tmp_path / "y")]) == 2
