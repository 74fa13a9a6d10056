"""The task file's ``controller:`` block: read, stored in plan.json, used by ``forte simulate``."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import pytest
import yaml

from forte.cli.simulate import _gains
from forte.exceptions import TaskFileError
from forte.execution.gains import gains_from_mapping
from forte.io.plandir import read_controller, write_plan
from forte.model.robot import N_BASE
from forte.planning.planner import plan
from forte.planning.tasks.tasks import load_task

LIFT = Path(__file__).resolve().parents[1] / "examples" / "tasks" / "lift.yaml"


def _task_file(tmp_path: Path, controller: object) -> Path:
    data = yaml.safe_load(LIFT.read_text())
    data["controller"] = controller
    path = tmp_path / "lift.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def _args(plan_dir: Path, **kw: object) -> argparse.Namespace:
    return argparse.Namespace(plan_dir=plan_dir, gains=kw.get("gains"), bandwidth=kw.get("bandwidth"),
                              damping_ratio=kw.get("damping_ratio"))


def test_controller_block_reaches_plan_json_and_simulate(tmp_path: Path) -> None:
    task = load_task(_task_file(tmp_path, {"bandwidth_hz": 2.5, "damping_ratio": 0.9}), waypoints=10)
    assert task.controller == {"bandwidth_hz": 2.5, "damping_ratio": 0.9}
    res = plan(task, "quintic")
    out = write_plan(res, tmp_path / "plan", figures=False)
    assert json.loads((out / "plan.json").read_text())["controller"] == task.controller
    assert read_controller(out) == task.controller
    gains = _gains(_args(out))
    expected = gains_from_mapping(task.controller, res.robot, q_a=res.q[0, N_BASE:])
    np.testing.assert_allclose(gains.K_a, expected.K_a)
    np.testing.assert_allclose(gains.D_a, expected.D_a)
    # the CLI's --bandwidth goes on top of the task's block
    faster = _gains(_args(out, bandwidth=5.0))
    assert np.all(faster.K_a > gains.K_a)


def test_no_controller_block_means_defaults(tmp_path: Path) -> None:
    task = load_task(LIFT, waypoints=10)
    assert task.controller == {}
    out = write_plan(plan(task, "quintic"), tmp_path / "plan", figures=False)
    assert _gains(_args(out)) is None


def test_unknown_controller_field_is_an_error(tmp_path: Path) -> None:
    with pytest.raises(TaskFileError, match=r"controller\.Kp: unknown field; expected one of .*K_a"):
        load_task(_task_file(tmp_path, {"Kp": 1.0}))
