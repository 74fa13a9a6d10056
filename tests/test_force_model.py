"""``force_model``: the paper's desired force (default) and the authors' blended static load."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import yaml

from forte.exceptions import TaskFileError
from forte.force.taskforce import FORCE_MODELS, authors_force, payload_force
from forte.planning.planner import Plan
from forte.planning.tasks.tasks import load_task, task_from_dict

EXAMPLES = Path(__file__).resolve().parents[1] / "examples" / "tasks"
G = 9.81
TOOL = 1.146  # the built-in robot's tool_force_mass (kg)
# 10 x^3 - 15 x^4 + 6 x^5 worked by hand at x = 0, 1/4, 1/2, 3/4, 1 and (clipped) 2
RAMP = {0.0: 0.0, 0.25: 0.103515625, 0.5: 0.5, 0.75: 0.896484375, 1.0: 1.0, 2.0: 1.0}


def task_file(tmp_path: Path, name: str, **fields) -> Path:
    data = yaml.safe_load((EXAMPLES / name).read_text())
    data.update(fields)
    path = tmp_path / name
    path.write_text(yaml.safe_dump(data))
    return path


def test_the_blend_takes_the_quintic_values_worked_by_hand():
    t = np.array(list(RAMP))
    force = authors_force(t, 3.0, radius=10.0, gravity=G)
    np.testing.assert_allclose(force.f[:, 2], [RAMP[tk] * 3.0 * G for tk in t], rtol=0, atol=1e-12)
    np.testing.assert_array_equal(force.f[:, :2], 0.0)
    np.testing.assert_array_equal(force.r, 10.0)  # the radius is not blended
    # no blend (ramp 0): the static load at every sample; a blend already 0.5 s in goes on from there
    np.testing.assert_allclose(authors_force(t, 3.0, gravity=G, ramp=0.0).f[:, 2], 3.0 * G)
    np.testing.assert_allclose(authors_force(t[:2], 3.0, gravity=G, elapsed=0.5).f[:, 2],
                               [0.5 * 3.0 * G, RAMP[0.75] * 3.0 * G])


def test_the_authors_lift_force_is_the_static_load_blended_in(tmp_path):
    task = load_task(task_file(tmp_path, "lift.yaml", force_model="authors"))
    assert task.force_model == "authors" and task.robot.gravity == G and task.t[1] == 0.25
    force = task.force()
    M = 2.7 + TOOL
    for tk, s in RAMP.items():
        k = int(np.flatnonzero(np.isclose(task.t, tk))[0])
        np.testing.assert_allclose(force.f[k], [0.0, 0.0, s * M * G], rtol=0, atol=1e-12)
    # after the blend: (m + m_tool) g up at every waypoint, whatever the path's acceleration
    np.testing.assert_allclose(force.f[task.t >= 1.0], np.tile([0.0, 0.0, M * G], (37, 1)), rtol=0, atol=1e-12)
    assert np.abs(load_task(EXAMPLES / "lift.yaml").force().f[4:, :2]).max() > 1e-3  # the paper's has p''
    # --mass overrides the payload in the authors' force too
    light = load_task(task_file(tmp_path, "lift.yaml", force_model="authors"), mass=0.35).force()
    np.testing.assert_allclose(light.f[-1], [0.0, 0.0, (0.35 + TOOL) * G], rtol=0, atol=1e-12)


def test_the_default_is_the_paper_s_force_bit_for_bit(tmp_path):
    default = load_task(EXAMPLES / "lift.yaml")
    assert default.force_model == "paper"
    expected = payload_force(default.t, default.targets[:, :3, 3], 2.7 + TOOL, default.radius, default.robot.gravity)
    for task in (default, load_task(task_file(tmp_path, "lift.yaml", force_model="paper"))):
        force = task.force()
        assert np.array_equal(force.f, expected.f) and np.array_equal(force.r, expected.r)


@pytest.mark.parametrize("value", ["Authors", "text", 1, ["paper"]])
def test_a_bad_force_model_is_one_line_naming_the_field(tmp_path, value):
    path = task_file(tmp_path, "lift.yaml", force_model=value)
    with pytest.raises(TaskFileError) as err:
        load_task(path)
    message = str(err.value)
    assert "\n" not in message and str(path) in message
    assert f"force_model: expected one of {', '.join(FORCE_MODELS)}, got {value!r}" in message


def test_force_model_with_a_given_force_profile_is_an_error(tmp_path):
    with pytest.raises(TaskFileError, match="force_model: sets a payload's force"):
        load_task(task_file(tmp_path, "continuous.yaml", force_model="paper"))


def test_a_hold_task_gets_the_static_load_without_a_blend(tmp_path):
    task = load_task(task_file(tmp_path, "hold.yaml", force_model="authors"))
    paper = load_task(EXAMPLES / "hold.yaml")
    assert task.mode == "hold" and task.n == 1
    M = paper.payload.mass + TOOL
    np.testing.assert_allclose(task.force().f, [[0.0, 0.0, M * G]], rtol=0, atol=1e-12)
    np.testing.assert_allclose(task.force().f, paper.force().f, rtol=0, atol=1e-12)


def test_mass_range_radius_follows_the_blended_force(tmp_path):
    task = load_task(task_file(tmp_path, "lift.yaml", force_model="authors", uncertainty_rule="mass-range"))
    ranged = task.with_payload(replace(task.payload, mass=2.7, mass_range=(1.0, 4.5)))
    force = ranged.force()
    # r_k = max(10, dm s_k g) with dm = 1.8 kg: the ball holds the force of every mass of the range
    s = np.array([RAMP[tk] for tk in (0.0, 0.25, 0.5, 0.75, 1.0)])
    np.testing.assert_allclose(force.r[:5], np.maximum(10.0, 1.8 * s * G), rtol=0, atol=1e-12)
    for m in (1.0, 4.5):
        gap = np.linalg.norm(ranged.force(mass=m).f - force.f, axis=1)
        assert np.all(gap <= force.r + 1e-9)


def test_the_option_round_trips_through_the_task_file_and_plan_json(tmp_path):
    from forte.io.plandir import plan_document

    task = load_task(task_file(tmp_path, "lift.yaml", force_model="authors"), waypoints=9)
    plan = Plan(method="manual", robot=task.robot, t=task.t, q=task.nominal(), force=task.force(),
                payload=task.payload, task=task)
    doc = json.loads(json.dumps(plan_document(plan)))
    assert doc["force"]["model"] == "authors" and doc["task"]["definition"]["force_model"] == "authors"
    again = task_from_dict(doc["task"]["definition"], task.source, waypoints=9)  # as a re-plan rebuilds it
    assert again.force_model == "authors"
    np.testing.assert_array_equal(again.force().f, doc["force"]["f"])
    paper = load_task(EXAMPLES / "lift.yaml", waypoints=9)
    doc = plan_document(replace(plan, force=paper.force(), task=paper))
    assert doc["force"]["model"] == "paper" and "force_model" not in doc["task"]["definition"]


@pytest.mark.slow
def test_a_replan_keeps_the_task_s_force_model_and_a_shift_continues_the_blend(tmp_path):
    from forte.planning.online.replan import Replanner

    task = load_task(task_file(tmp_path, "lift.yaml", force_model="authors"), waypoints=15)
    planner = Replanner(task)
    dt = float(task.t[1] - task.t[0])
    result = planner.replan(mass=1.0)
    assert result.plan.solved
    np.testing.assert_allclose(planner.force.f, authors_force(task.t, 1.0 + TOOL, gravity=G).f, atol=1e-12)
    result = planner.shift(1)
    assert result.plan.solved and planner.task.force_ramp_elapsed == pytest.approx(dt)
    s = min(dt, 1.0) ** 3 * (10 - 15 * min(dt, 1.0) + 6 * min(dt, 1.0) ** 2)
    assert result.plan.force.f[0, 2] == pytest.approx(s * (1.0 + TOOL) * G, abs=1e-12)  # not back to zero
