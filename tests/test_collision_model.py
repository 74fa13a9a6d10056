"""The authors' collision term and base velocity term against independent computations; the
``collision_model`` option through task files."""

from __future__ import annotations

import json
from pathlib import Path

import casadi as ca
import numpy as np
import pytest
import yaml
from conftest import authors_ee_in_base

from forte.exceptions import InvalidInputError, TaskFileError
from forte.model.collision import AUTHORS_SPHERES
from forte.model.twin import CasadiTwin
from forte.planning.tasks.tasks import load_task, task_from_dict
from forte.planning.tasks.weights_section import settings_record, weights_record
from forte.planning.terms.costs import Stage, make_terms
from forte.planning.terms.motion_terms import BoxCollision, Collision
from forte.settings import TermSettings

EXAMPLES = Path(__file__).resolve().parents[1] / "examples" / "tasks"

# The authors' configuration, transcribed from their target_pose_generator_params.yaml:
# (frame, centre, radius) of the basket spheres on the end effector and of the base spheres.
BASKET = [((0.0, 0.0, 0.1), 0.15), ((0.0, 0.0, 0.3), 0.18), ((0.106, 0.106, 0.3), 0.18),
          ((-0.106, -0.106, 0.3), 0.18)]
BODY = [((0.0, 0.0, 0.35), 0.52), ((0.2, 0.0, 0.8), 0.15)]
SAFE = 0.08


def stage_function(robot, settings=None, name="collision"):
    """The registered stage term ``name`` as a numeric function of (q_{k-1}, q_k, dt_k)."""
    (term,) = make_terms((name,), settings)
    nq = robot.nq
    s = Stage(CasadiTwin(robot), ca.SX.sym("a", nq), ca.SX.sym("b", nq), ca.SX.sym("c", nq), ca.SX.sym("d1"),
              ca.SX.sym("d0"), ca.SX.sym("f", 3), ca.SX.sym("r"), {}, nominal=ca.SX.sym("n", nq))
    value = term.stage(s)
    fn = ca.Function("t", [s.q1, s.q0, s.dt0], [value, ca.gradient(value, s.q0)])
    return term, lambda q, q1=None, dt=0.25: [np.array(v, dtype=float).ravel() for v in
                                               fn(q if q1 is None else q1, q, dt)]


def ee_world(q):
    """World pose of the authors' end effector (independent of forte's model)."""
    return base_world(q) @ authors_ee_in_base(q[3:])


def base_world(q):
    c, s = np.cos(q[2]), np.sin(q[2])
    T = np.eye(4)
    T[:2, :2] = [[c, -s], [s, c]]
    T[:2, 3] = q[:2]
    return T


def clearances(q):
    """World-frame clearance of every (basket, body) pair, basket-major."""
    T_ee, T_b = ee_world(q), base_world(q)
    out = []
    for c_a, r_a in BASKET:
        p_a = T_ee[:3, :3] @ c_a + T_ee[:3, 3]
        for c_b, r_b in BODY:
            p_b = T_b[:3, :3] @ c_b + T_b[:3, 3]
            out.append(np.linalg.norm(p_a - p_b) - r_a - r_b)
    return np.array(out)


def expected_cost(q):
    return float(np.sum(np.maximum(0.0, SAFE - clearances(q)) ** 2))


def test_authors_spheres_are_the_transcribed_configuration():
    assert [(s.frame, s.centre, s.radius) for s in AUTHORS_SPHERES.basket] == [("ee", c, r) for c, r in BASKET]
    assert [(s.frame, s.centre, s.radius) for s in AUTHORS_SPHERES.body] == [("base", c, r) for c, r in BODY]
    term = make_terms(("collision",))[0]
    assert isinstance(term, Collision) and term.safe_distance == SAFE
    assert Collision.setting_values(TermSettings())["model"] == "authors"


def test_collision_matches_numpy_at_random_configurations(robot):
    _, f = stage_function(robot)
    rng = np.random.default_rng(11)
    values = []
    for _ in range(40):
        q = np.r_[rng.uniform(-2, 2, 2), rng.uniform(-np.pi, np.pi), rng.uniform(robot.lower, robot.upper)]
        value, _ = f(q)
        expected = expected_cost(q)
        assert value[0] == pytest.approx(expected, rel=1e-9, abs=1e-15)
        values.append(expected)
    # the draw covers both penetrating (several pairs) and clear configurations
    assert sum(v > 1e-3 for v in values) >= 5 and sum(v == 0 for v in values) >= 5


def test_collision_penetrating_configuration_and_gradient(robot):
    _, f = stage_function(robot)
    q = np.r_[0.4, -0.3, 0.7, 0.0, 0.3, 0.0, -2.6, 0.0, 2.2, 0.8]  # hand folded down in front of the mount
    assert np.sum(clearances(q) < SAFE) >= 2
    value, grad = f(q)
    assert value[0] == pytest.approx(expected_cost(q), rel=1e-9) and value[0] > 0.01
    # gradient against central differences of the numpy cost
    h = 1e-6
    fd = [(expected_cost(q + h * e) - expected_cost(q - h * e)) / (2 * h) for e in np.eye(robot.nq)]
    np.testing.assert_allclose(grad, fd, rtol=1e-5, atol=1e-8)
    # the base's own rigid motion leaves every clearance, hence the cost, unchanged
    moved = q + np.r_[1.3, -0.7, 2.0, np.zeros(7)]
    assert f(moved)[0][0] == pytest.approx(value[0], rel=1e-12)


def test_collision_is_zero_when_clear(robot):
    _, f = stage_function(robot)
    q = np.r_[0.0, 0.0, 0.0, 0.0, 0.2, 0.0, -1.2, 0.0, 1.4, 0.8]  # reaching forward, hand well out
    assert clearances(q).min() > SAFE + 0.05
    value, grad = f(q)
    assert value[0] == 0.0 and not np.any(grad)


def test_box_model_is_the_named_option(robot):
    term, f = stage_function(robot, TermSettings({"collision": {"model": "box", "radius": 0.1}}))
    assert isinstance(term, BoxCollision) and term.radius == 0.1 and term.name == "collision"
    q = robot.home().copy()
    q[3:] = [2.8, 1.76, 0.0, -0.2, 0.0, 1.5, 0.8]  # arm turned back and down over the base
    assert f(q)[0][0] > 0
    with pytest.raises(InvalidInputError, match="^model: expected one of authors, box, got 'mesh'$"):
        make_terms(("collision",), TermSettings({"collision": {"model": "mesh"}}))


def _lift(tmp_path, weights):
    data = yaml.safe_load((EXAMPLES / "lift.yaml").read_text())
    data["weights"] = weights
    path = tmp_path / "task.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def test_collision_model_round_trips_through_a_task_file(tmp_path):
    task = load_task(_lift(tmp_path, {"collision_model": "box", "collision_safe_distance": 0.05}))
    assert dict(task.settings["collision"]) == {"model": "box", "safe_distance": 0.05}
    assert isinstance(make_terms(("collision",), task.settings)[0], BoxCollision)
    # the weights and settings as plan.json records them load back to the same ones
    recorded = json.loads(json.dumps(weights_record(task.weights, task.settings)))
    again = load_task(_lift(tmp_path, recorded))
    assert again.weights == task.weights and settings_record(again.settings) == settings_record(task.settings)
    default = load_task(_lift(tmp_path, {"preset": "authors-trajectory"})).settings
    assert Collision.setting_values(default)["model"] == "authors"
    # the same setting in the terms' own section
    data = yaml.safe_load(_lift(tmp_path, {}).read_text()) | {"terms": {"collision": {"model": "box"}}}
    assert isinstance(make_terms(("collision",), task_from_dict(data, tmp_path / "t.yaml").settings)[0], BoxCollision)


@pytest.mark.parametrize(("weights", "message"), [
    ({"collision_model": "spheres"}, "weights.collision_model: expected one of authors, box, got 'spheres'"),
    ({"collision_model": 3}, "weights.collision_model: expected one of authors, box, got 3"),
    ({"collision_safe_distance": -0.1}, "weights.collision_safe_distance: expected a finite number >= 0, got -0.1"),
    ({"collision_modl": "box"}, "weights.collision_modl: unknown field; expected one of "),
])
def test_bad_collision_settings_give_one_line_naming_the_field(tmp_path, weights, message):
    path = _lift(tmp_path, weights)
    with pytest.raises(TaskFileError) as err:
        load_task(path)
    text = str(err.value)
    assert message in text and str(path) in text and "\n" not in text


def test_base_velocity_uses_the_metric_linearly_and_wraps_yaw(robot):
    _, f = stage_function(robot, name="base_velocity")
    q1 = np.r_[0.30, -0.20, 3.10, robot.home_arm]
    q0 = np.r_[0.38, -0.14, -3.12, robot.home_arm + 0.1]  # yaw steps across +-pi
    dt = 0.25
    d_yaw = -3.12 - 3.10 + 2 * np.pi  # the short way round: +0.0632 rad
    expected = 0.5 * (1.0 * 0.08**2 + 1.0 * 0.06**2 + 0.5 * d_yaw**2) / dt**2
    assert f(q0, q1, dt)[0][0] == pytest.approx(expected, rel=1e-12)
    # away from the wrap: 0.5 * (dx^2 + dy^2 + 0.5 dyaw^2) / dt^2, the arm ignored
    q0b = np.r_[0.1, 0.2, 0.3, robot.home_arm - 0.2]
    q1b = np.r_[0.0, 0.0, 0.0, robot.home_arm]
    assert f(q0b, q1b, 0.5)[0][0] == pytest.approx(0.5 * (0.01 + 0.04 + 0.5 * 0.09) / 0.25, rel=1e-12)
