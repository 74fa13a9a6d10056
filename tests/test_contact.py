"""Contact-rich tasks (issue 25, item 4): the force models by hand, against MuJoCo's measured
contact and constraint forces, bad task input, and a planned drawer executed in MuJoCo."""

from __future__ import annotations

import tempfile
from pathlib import Path
from types import SimpleNamespace

import mujoco
import numpy as np
import pytest
import yaml

from forte.cli.main import main
from forte.exceptions import ForteError
from forte.execution.contact_objects import ContactRig
from forte.force.contact import Carry, Drawer, PushBox, carry_wrench, drawer_force, push_force
from forte.planning.tasks.tasks import load_task

EXAMPLES = Path(__file__).resolve().parents[1] / "examples" / "tasks"
G = 9.81


def _line(t, s, d=(1.0, 0.0, 0.0), start=(0.5, 0.0, 0.6)):
    return np.asarray(start) + np.outer(s, d)


def test_push_force_is_friction_plus_inertia_by_hand():
    # constant acceleration 0.2 m/s^2 from rest: s = 0.1 t^2; backward differences give v_k, a_k
    t = np.linspace(0.0, 2.0, 11)
    s = 0.1 * t**2
    box = PushBox(mass=8.0, friction=0.3)
    f = push_force(t, _line(t, s, (0.0, 1.0, 0.0)), box, 10.0, G).f
    dt = t[1] - t[0]
    for k in range(2, t.size):  # v_k = (s_k - s_{k-1}) / dt > 0, a_k by hand
        a = ((s[k] - s[k - 1]) - (s[k - 1] - s[k - 2])) / dt**2
        assert f[k, 1] == pytest.approx(8.0 * a + 0.3 * 8.0 * G, rel=1e-12)
    assert np.allclose(f[:, [0, 2]], 0.0)
    assert f[0, 1] == 0.0  # at rest: static friction holds the box, no push


def test_drawer_force_is_the_resistance_by_hand():
    t = np.array([0.0, 0.5, 1.0])
    p = _line(t, [0.0, 0.05, 0.15], (-1.0, 0.0, 0.0))
    dr = Drawer(mass=3.0, stiffness=120.0, damping=20.0, friction=15.0, rest=-0.02)
    f = drawer_force(t, p, dr, 10.0).f
    # k = 2: s = 0.15, s' = 0.2, s'' = (0.2 - 0.1) / 0.5 = 0.2; the hand pulls along -x (the opening)
    expected = 3.0 * 0.2 + 120.0 * (0.15 + 0.02) + 20.0 * 0.2 + 15.0
    assert f[2] == pytest.approx([-expected, 0.0, 0.0], rel=1e-12)


def test_carry_wrench_static_share_by_hand():
    t = np.array([0.0, 1.0, 2.0, 3.0])
    T = np.tile(np.eye(4), (4, 1, 1))
    carry = Carry(mass=2.0, com=(0.2, 0.0, 0.0), partner=(0.4, 0.0, 0.0), release_time=1.5, release_duration=0.5)
    w = carry_wrench(t, T, carry, 10.0, tool_mass=1.0, gravity=G)
    # both hold (lever rule: the partner takes (c . e) / |e|^2 = 1/2): the robot holds half the
    # board and the tool, no moment
    assert carry.initial_share == pytest.approx(0.5)
    assert w.f[0] == pytest.approx([0.0, 0.0, 0.5 * 2.0 * G + 1.0 * G])
    assert w.m[0] == pytest.approx([0.0, 0.0, 0.0], abs=1e-12)
    # let go: the whole board, and its moment (0.2, 0, 0) x (0, 0, 2 g) = (0, -0.4 g, 0)
    assert w.f[3] == pytest.approx([0.0, 0.0, 3.0 * G])
    assert w.m[3] == pytest.approx([0.0, -0.4 * G, 0.0])
    assert w.lever == pytest.approx(0.4)


def _mocap_spec():
    spec = mujoco.MjSpec()
    spec.option.timestep = 1e-3
    spec.option.gravity = [0.0, 0.0, -G]
    spec.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[5, 5, 0.1], contype=0,
                            conaffinity=0)
    hand = spec.worldbody.add_body(name="hand", mocap=True, pos=[0.0, 0.0, 0.3])
    hand.add_site(name="ee")
    return spec


def _run_mocap(contact, d, speed, duration):
    """Move a kinematic hand along ``d`` at ``speed``; return times, the object's travel and the
    measured hand force along ``d``."""
    T0 = np.eye(4)
    T0[:3, 3] = [0.0, 0.0, 0.3]
    rig = ContactRig(contact, T0, np.asarray(d, dtype=float), speed * duration, G)
    spec = _mocap_spec()
    rig.decorate(spec)
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    rig.bind(SimpleNamespace(model=model, data=data))
    out = []
    for k in range(int(duration / model.opt.timestep)):
        t = k * model.opt.timestep
        data.mocap_pos[0] = T0[:3, 3] + np.asarray(d) * speed * min(t, duration)
        mujoco.mj_step(model, data)
        out.append((t, rig.opening(), float(rig.hand_force() @ rig.d), float(data.qvel[0])))
    return np.array(out)


def test_push_force_matches_mujocos_contact_force_while_sliding():
    box = PushBox(mass=8.0, friction=0.3, size=(0.5, 0.5, 0.7))
    log = _run_mocap(box, (1.0, 0.0, 0.0), 0.05, 3.0)
    sliding = log[log[:, 0] > 1.0]  # past the start transient: constant speed
    assert sliding[-1, 1] > 0.09  # the box moved with the hand
    predicted = push_force([0.0, 1.0, 2.0], _line([0, 1, 2], [0.0, 0.05, 0.1]), box, 0.0, G).f[2, 0]
    assert predicted == pytest.approx(0.3 * 8.0 * G)
    assert np.mean(sliding[:, 2]) == pytest.approx(predicted, rel=0.03)


def test_drawer_force_matches_mujocos_constraint_force_in_a_quasi_static_pull():
    dr = Drawer(mass=3.0, stiffness=120.0, damping=20.0, friction=15.0)
    speed = 0.05
    log = _run_mocap(dr, (-1.0, 0.0, 0.0), speed, 4.0)
    steady = log[(log[:, 0] > 0.5) & (log[:, 0] < 3.9)]
    s = steady[:, 1]
    predicted = 120.0 * s + 20.0 * speed + 15.0  # quasi-static: s'' = 0, s' = the hand's speed
    assert s[-1] > 0.15
    assert np.max(np.abs(steady[:, 2] - predicted)) < 0.02 * np.max(predicted)


def _task_error(tmp_path, name, mutate):
    data = yaml.safe_load((EXAMPLES / f"{name}.yaml").read_text())
    mutate(data)
    path = tmp_path / "task.yaml"
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(ForteError) as err:
        load_task(path)
    return path, str(err.value)


@pytest.mark.parametrize(
    ("name", "mutate", "message"),
    [
        ("push-box", lambda d: d["contact"].update(kind="shove"),
         "contact.kind: expected one of push-box, drawer, carry"),
        ("push-box", lambda d: d["contact"].update(friction=-0.3), "contact.friction: expected a number > 0"),
        ("push-box", lambda d: d["contact"].update(size=[0.5, 0.5]), "contact.size: expected a list of 3 numbers"),
        ("push-box", lambda d: d["path"]["waypoints"][1].update(position=[0.6, 0.0, 0.1]),
         "path: the end effector rises or sinks 0.1000 m"),
        ("push-box", lambda d: d.update(payload={"mass": 2.0}), "payload: not used by a contact task"),
        ("drawer", lambda d: d["contact"].update(stiffness="stiff"), "contact.stiffness: expected a finite number"),
        ("drawer", lambda d: d["contact"].pop("mass"), "contact.mass: required field is missing"),
        ("drawer", lambda d: d["path"]["waypoints"].insert(1, {"t": 3.0, "position": [-0.1, 0.1, 0.0]}),
         "off the straight line"),
        ("carry-with-partner", lambda d: d["contact"].update(share=1.5), "contact.share: expected a number <= 1"),
        ("carry-with-partner", lambda d: d["contact"].update(partner=[0, 0, 0]), "contact.partner: expected the"),
    ],
)
def test_bad_contact_fields_name_file_and_field(tmp_path, name, mutate, message):
    path, error = _task_error(tmp_path, name, mutate)
    assert message in error
    assert str(path) in error
    assert "\n" not in error


def test_bad_contact_task_exits_2(tmp_path, capsys):
    data = yaml.safe_load((EXAMPLES / "drawer.yaml").read_text())
    data["contact"]["damping"] = -1
    path = tmp_path / "task.yaml"
    path.write_text(yaml.safe_dump(data))
    assert main(["plan", str(path), "--out", str(tmp_path / "o"), "--quiet"]) == 2
    assert "contact.damping: expected a number >= 0" in capsys.readouterr().err


def test_example_contact_tasks_load_with_their_models():
    push = load_task(EXAMPLES / "push-box.yaml")
    f = push.force().f
    assert np.max(f[:, 0]) > 0.3 * 8.0 * G and np.allclose(f[:, 1:], 0.0)
    drawer = load_task(EXAMPLES / "drawer.yaml")
    assert np.all(drawer.force().f[:, 0] <= 0.0)  # the hand pulls the drawer open (-x)
    carry = load_task(EXAMPLES / "carry-with-partner.yaml")
    w = carry.force()
    assert w.has_moment and carry.payload.mass == 1.5 and carry.payload.com == (0.2, 0.0, 0.0)
    assert np.abs(w.m[0]).max() < 1e-9 < np.abs(w.m[-1]).max()  # no moment until the partner lets go


@pytest.mark.slow
@pytest.mark.parametrize("name", ["drawer", "push-box", "carry-with-partner"])
def test_planned_contact_task_runs_in_mujoco_with_the_contact(name):
    from forte.execution.run import simulate_plan
    from forte.io.plandir import read_plan_dir, write_plan
    from forte.planning.planner import plan

    task = load_task(EXAMPLES / f"{name}.yaml", waypoints=21)
    res = plan(task, "forte")
    with tempfile.TemporaryDirectory() as tmp:
        directory = write_plan(res, Path(tmp) / "forte", figures=False)
        assert read_plan_dir(directory).contact == task.contact  # plan.json round trip
        run = simulate_plan(directory, write=False)
    facts = run.summary["contact_task"]
    assert facts["kind"] == task.contact.kind
    if name != "carry-with-partner":
        assert facts["travel_m"] == pytest.approx(facts["planned_travel_m"], abs=0.05)
        assert facts["peak_hand_force_N"] > 0.5 * np.max(np.linalg.norm(res.force.f, axis=1))
    assert run.success, run.detail
