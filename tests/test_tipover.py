"""Base stability (issue 25, item 3): the whole robot's zero-moment point, the tip-over margin, the
``tipover`` requirement and metrics column, and the ``tipover`` term."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import casadi as ca
import numpy as np
import pinocchio as pin
import pytest
import yaml

import forte
from forte.cli.main import main
from forte.exceptions import InvalidInputError, TaskFileError
from forte.model.base_support import AUTHORS_BASE, TIAGO_BASE, BaseSupport, rectangle
from forte.model.presets import preset_robot
from forte.model.stability import ground_wrench, root_motion, tipover_margin, whole_body_model, zero_moment_point
from forte.model.twin import CasadiTwin
from forte.planning.tasks.tasks import task_from_dict

ROOT = Path(__file__).resolve().parents[1]
TIPOVER_TASK = ROOT / "examples" / "tasks" / "tipover.yaml"


def test_static_zmp_is_the_centre_of_pressure_computed_by_hand(robot):
    """Arm still, a known payload: the ZMP is the ground projection of the centre of mass of base,
    arm (link by link from the kinematics, not from RNEA) and payload."""
    q = robot.home()
    m_payload = 2.7 + robot.tool_force_mass
    data = robot.model.createData()
    pin.forwardKinematics(robot.model, data, q[3:])
    masses = [AUTHORS_BASE.mass]
    points = [np.array(AUTHORS_BASE.com)]
    universe = robot.model.inertias[0]
    masses.append(universe.mass)
    points.append(robot.mount[:3, :3] @ universe.lever + robot.mount[:3, 3])  # panda_link0 on the mount
    for j in range(1, robot.model.njoints):
        masses.append(robot.model.inertias[j].mass)
        points.append(data.oMi[j].act(robot.model.inertias[j].lever))
    masses.append(m_payload)
    points.append(robot.ee_position(q))
    by_hand = np.sum(np.array(masses)[:, None] * np.array(points), axis=0)[:2] / sum(masses)
    still = np.zeros((1, robot.nq))
    wrench = np.array([[0.0, 0.0, m_payload * robot.gravity, 0.0, 0.0, 0.0]])
    ground = ground_wrench(robot, q[None], still, still, wrench)
    assert ground[0, 2] == pytest.approx(sum(masses) * robot.gravity, rel=1e-12)
    assert np.allclose(zero_moment_point(ground)[0], by_hand, atol=1e-9)
    # the nearest edge of the MOCA's wheel rectangle is the front one, at x = 0.2225 m
    margin = tipover_margin(robot, q[None], still, still, wrench)[0]
    assert margin == pytest.approx(0.2225 - by_hand[0], abs=1e-9)
    assert 0.15 < margin < 0.2


def test_ground_wrench_is_the_rate_of_momentum_plus_the_task_wrench(robot):
    """In motion (base turning and accelerating, arm moving): F = M (a_com - g) + f and
    N_O = c x M (a_com - g) + dh_ang/dt + m + p_ee x f from Pinocchio's centroidal quantities."""
    rng = np.random.default_rng(3)
    model, ee = whole_body_model(robot)
    data = model.createData()
    for _ in range(3):
        q = np.r_[rng.uniform(-1, 1, 3), robot.home_arm + rng.uniform(-0.4, 0.4, 7)]
        dq, ddq, w = rng.normal(size=10), rng.normal(size=10), rng.normal(size=6) * 10
        config, v, a = root_motion(q[:3], dq[:3], ddq[:3])
        qk, vk, ak = np.r_[config, q[3:]], np.r_[v, dq[3:]], np.r_[a, ddq[3:]]
        pin.computeCentroidalMomentumTimeVariation(model, data, qk, vk, ak)
        pin.framesForwardKinematics(model, data, qk)
        mass, com, p = pin.computeTotalMass(model), data.com[0].copy(), data.oMf[ee].translation
        force = data.dhg.linear + mass * np.array([0, 0, robot.gravity]) + w[:3]
        moment = np.cross(com, data.dhg.linear + mass * np.array([0, 0, robot.gravity])) + data.dhg.angular \
            + w[3:] + np.cross(p, w[:3])
        R = pin.rpy.rpyToMatrix(0, 0, q[2])
        got = ground_wrench(robot, q[None], dq[None], ddq[None], w[None])[0]
        assert np.allclose(got, np.r_[R.T @ force, R.T @ (moment - np.cross(np.r_[q[:2], 0.0], force))], atol=1e-8)


@pytest.mark.parametrize("name", ["authors", "tiago"])
def test_the_nlp_ground_wrench_equals_pinocchio(name):
    """The CasADi twin's Newton-Euler (the term's) equals the free-flyer RNEA on backward differences."""
    r = preset_robot(name)
    twin = CasadiTwin(r)
    Q = [ca.SX.sym(f"q{i}", r.nq) for i in range(3)]
    dt1, dt0, f, m = ca.SX.sym("dt1"), ca.SX.sym("dt0"), ca.SX.sym("f", 3), ca.SX.sym("m", 3)
    fn = ca.Function("g", [*Q, dt1, dt0, f, m], [twin.ground_wrench(*Q, dt1, dt0, f, m)])
    rng = np.random.default_rng(0)
    for _ in range(3):
        q0 = np.r_[rng.uniform(-1, 1, 3), np.clip(r.home_arm + rng.uniform(-0.5, 0.5, r.n_arm), r.lower, r.upper)]
        q = [q0, q0 + 0.05 * rng.normal(size=r.nq), None]
        q[2] = q[1] + 0.05 * rng.normal(size=r.nq)
        w = rng.normal(size=6) * 10
        v0, v1 = (q[2] - q[1]) / 0.25, (q[1] - q[0]) / 0.2
        exact = ground_wrench(r, q[2][None], v0[None], ((v0 - v1) / 0.25)[None], w[None])[0]
        assert np.allclose(np.array(fn(*q, 0.2, 0.25, w[:3], w[3:])).ravel(), exact, atol=1e-9)


def test_support_polygon_margin_and_checks():
    square = BaseSupport(rectangle(1.0, 1.0))
    assert square.margin([[0.0, 0.0], [0.5, 0.0], [2.0, 0.0], [2.0, 2.0]]).tolist() == \
        pytest.approx([1.0, 0.5, -1.0, -np.sqrt(2.0)])
    clockwise = BaseSupport(rectangle(1.0, 1.0)[::-1])
    assert clockwise.footprint == square.footprint  # stored counter-clockwise
    assert BaseSupport.from_dict(AUTHORS_BASE.to_dict()) == AUTHORS_BASE
    assert TIAGO_BASE.margin([[0.0, 0.0]])[0] == pytest.approx(0.1535)  # the front casters
    with pytest.raises(InvalidInputError, match="base_footprint: expected a convex polygon"):
        BaseSupport(((0, 0), (1, 1), (1, 0), (0, 1)))
    with pytest.raises(InvalidInputError, match="base_footprint: expected at least 3"):
        BaseSupport(((0, 0), (1, 1)))
    with pytest.raises(InvalidInputError, match="base_mass"):
        BaseSupport(rectangle(1, 1), mass=-1.0)


def test_tiago_footprint_is_its_wheel_and_caster_contacts():
    r = preset_robot("tiago")
    full = pin.buildModelFromUrdf(str(r.urdf_path))
    data = full.createData()
    pin.framesForwardKinematics(full, data, pin.neutral(full))
    names = ["wheel_left_link", "wheel_right_link", *(f"caster_{s}_2_link" for s in
                                                       ("front_left", "front_right", "back_left", "back_right"))]
    contacts = {tuple(np.round(data.oMf[full.getFrameId(n)].translation[:2], 4)) for n in names}
    assert contacts == {tuple(np.round(v, 4)) for v in TIAGO_BASE.footprint}
    assert r.base_support == TIAGO_BASE and preset_robot("ur5").base_support == AUTHORS_BASE


def _task(tmp_path: Path, changes: dict, drop: tuple[str, ...] = ()) -> Path:
    doc = yaml.safe_load(TIPOVER_TASK.read_text())
    for key in drop:
        doc.pop(key, None)
    for key, value in changes.items():
        doc.setdefault("robot", {})[key] = value
    path = tmp_path / "task.yaml"
    path.write_text(yaml.safe_dump(doc))
    return path


@pytest.mark.parametrize(("value", "message"), [
    ([[0, 0], [1, 1]], "robot: base_footprint: expected at least 3"),
    ("round", "robot: base_footprint: expected a list"),
    ([[0, 0], [1, 1], [1, 0], [0, 1]], "robot: base_footprint: expected a convex polygon"),
])
def test_a_bad_footprint_is_one_line_naming_the_field(tmp_path, value, message):
    with pytest.raises(TaskFileError, match=message):
        forte.load_task(_task(tmp_path, {"base_footprint": value}))


def test_task_file_support_fields(tmp_path):
    with pytest.raises(TaskFileError, match="robot.base_footprint: required with base_mass"):
        forte.load_task(_task(tmp_path, {"base_footprint": None}, ("terms",)))
    doc = yaml.safe_load(TIPOVER_TASK.read_text())
    doc["robot"] = {"base_footprint": None}
    doc.pop("terms")
    assert task_from_dict(doc).robot.base_support is None
    box = forte.load_task(_task(tmp_path, {"base_footprint": "box"}, ("terms",))).robot.base_support
    assert box.mass == 40.0 and box.footprint[0] == (0.3, 0.25)  # base_mass on top of the box
    with pytest.raises(TaskFileError, match="terms.bogus: not a registered cost term"):
        doc = yaml.safe_load(TIPOVER_TASK.read_text()) | {"terms": {"bogus": {}}}
        task_from_dict(doc)
    with pytest.raises(TaskFileError, match=r"terms.tipover.weigth: unknown field; expected one of margin, weight"):
        task_from_dict(yaml.safe_load(TIPOVER_TASK.read_text()) | {"terms": {"tipover": {"weigth": 1}}})


def test_bad_footprint_exits_2(tmp_path, capsys):
    path = _task(tmp_path, {"base_footprint": [[0, 0]]})
    assert main(["plan", str(path), "--out", str(tmp_path / "out"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "robot: base_footprint: expected at least 3" in err, err


@pytest.mark.slow
def test_the_tipover_term_keeps_the_zmp_inside_where_the_plan_without_it_tips(tmp_path):
    """examples/tasks/tipover.yaml: braking with a 3 kg payload on a light base. Without the term
    forte's plan tips (verdict: tipover); with it the margin stays >= 0 on every judged sample."""
    task = forte.load_task(TIPOVER_TASK)
    without = forte.plan(replace(task, terms={}))
    assert "tipover" in without.verdict.failed
    assert without.metrics["tipover_margin"].min() < -0.01
    with_term = forte.plan(task)
    assert with_term.feasible, with_term.verdict.reason()
    assert with_term.metrics["tipover_margin"].min() >= 0.015
    assert with_term.solver["term_settings"]["tipover"]["margin"]["value"] == 0.02
    assert with_term.solver["term_weights"]["tipover"] == 10.0


def test_metrics_have_the_tipover_column_when_the_base_has_a_footprint(tmp_path):
    from forte.io.plandir import read_metrics, read_plan_dir, write_plan

    task = forte.load_task(ROOT / "examples" / "tasks" / "hold.yaml", mass=0.35)
    out = write_plan(forte.plan(task, "teaching"), tmp_path / "p", figures=False)
    metrics = read_metrics(out)
    assert list(metrics)[-1] == "tipover_margin" and 0.1 < metrics["tipover_margin"][0] < 0.2225
    assert read_plan_dir(out).robot.base_support == AUTHORS_BASE
    bare = replace(task, robot=forte.default_robot(base_support=None))
    assert "tipover_margin" not in forte.plan(bare, "teaching").metrics
