"""``forte experiment base`` (issue 39): its cases and its confusion table; the run itself is the
committed summary (docs/experiments/base/)."""

from __future__ import annotations

import pytest

from forte.cli.main import main
from forte.experiments.base import HEAVY_KG, base_task, confusion


def test_the_cases_carry_the_light_or_heavy_base_and_the_term():
    light = base_task("tipover", 3.0, "light", False)
    heavy = base_task("lift", 2.7, "heavy", True)
    assert light.robot.base_support.mass == 40.0 and "tipover" not in light.terms
    assert heavy.robot.base_support.mass == HEAVY_KG and heavy.terms["tipover"] == {"margin": 0.02}
    assert heavy.robot.base_support.footprint == light.robot.base_support.footprint
    assert light.payload.mass == 3.0 and heavy.payload.mass == 2.7


def test_the_confusion_table_counts_each_pair_once():
    rows = [{"verdict_tips": v, "mujoco_tipped": m} for v, m in
            ((True, True), (True, True), (True, False), (False, False), (False, False), (False, False), (False, True))]
    assert confusion(rows) == {"tips_tipped": 2, "tips_stood": 1, "stands_tipped": 1, "stands_stood": 3}


@pytest.mark.parametrize("name", ["lift", "wrench"])
def test_quick_is_the_base_experiments_only(tmp_path, capsys, name):
    assert main(["experiment", name, "--quick", "--out", str(tmp_path / "x"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--quick: only the base experiment" in err, err


def test_lateral_travel_is_the_step_across_the_heading():
    """At heading 0.4 rad a step along the heading has no sideways part; one at right angles to it
    is all sideways."""
    import numpy as np

    from forte.experiments.base import lateral_travel

    yaw = 0.4
    q = np.zeros((3, 10))
    q[:, 2] = yaw
    q[1, :2] = 0.2 * np.array([np.cos(yaw), np.sin(yaw)])
    q[2, :2] = q[1, :2] + 0.05 * np.array([-np.sin(yaw), np.cos(yaw)])
    assert np.allclose(lateral_travel(q), [0.0, 0.05], atol=1e-15)
