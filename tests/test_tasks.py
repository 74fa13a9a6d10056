"""Task files: the shipped examples load, and bad files give errors naming file and field."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import yaml

from forte.exceptions import ForteError, TaskFileError
from forte.planning.tasks.tasks import load_task, task_from_dict

EXAMPLES = Path(__file__).resolve().parents[1] / "examples" / "tasks"


def test_lift_example_is_the_authors_taught_lift():
    task = load_task(EXAMPLES / "lift.yaml")
    assert task.mode == "trajectory" and task.n == 41 and task.t[-1] == 10.0
    assert task.payload.mass == 2.7 and task.weights.preset == "forte-trajectory"
    times, knots = task.knots
    np.testing.assert_allclose(times, [0, 5, 10])
    np.testing.assert_allclose(task.q_init, knots[0])
    # targets pass through the forward kinematics of every taught configuration
    for tk, qk in zip(times, knots, strict=True):
        k = int(np.flatnonzero(np.isclose(task.t, tk))[0])
        np.testing.assert_allclose(task.targets[k], task.robot.ee_pose(qk), atol=1e-12)
    # the orientation between knots is the slerp with the quintic blend: a geodesic
    import pinocchio as pin
    Ra, Rb = task.robot.ee_pose(knots[0])[:3, :3], task.robot.ee_pose(knots[1])[:3, :3]
    s = 10 * 0.5**3 - 15 * 0.5**4 + 6 * 0.5**5
    np.testing.assert_allclose(task.targets[10, :3, :3], Ra @ pin.exp3(s * pin.log3(Ra.T @ Rb)), atol=1e-12)
    # the required force adds the robot's 1.146 kg end-effector load to the payload
    force = task.force()
    np.testing.assert_allclose(force.f[0], [0, 0, (2.7 + 1.146) * 9.81])
    assert load_task(EXAMPLES / "lift.yaml", mass=0.35).force().f[0, 2] == pytest.approx((0.35 + 1.146) * 9.81)
    # nominal = joint-space quintics through the knots, at rest at each knot
    nominal = task.nominal()
    np.testing.assert_allclose(nominal[[0, 20, 40]], knots, atol=1e-12)
    np.testing.assert_allclose(nominal[19], nominal[21], atol=1e-2)  # symmetric blend about P1


def test_lift_path_example_loads():
    task = load_task(EXAMPLES / "lift-path.yaml", waypoints=20)
    assert task.mode == "trajectory" and task.n == 20 and task.robot.tool_force_mass == 0.0
    np.testing.assert_allclose(task.targets[0], task.robot.ee_pose(task.q_init), atol=1e-9)
    z = task.targets[:, 2, 3]
    assert z.min() < z[0] - 0.3 and z[-1] > z.min() + 0.3
    np.testing.assert_allclose(task.targets[:, :3, :3], np.repeat(task.targets[:1, :3, :3], 20, 0))
    np.testing.assert_allclose(task.force().f[0], [0, 0, 2.7 * 9.81])


def test_continuous_example_follows_the_papers_formula():
    task = load_task(EXAMPLES / "continuous.yaml")
    T = 12.0
    t = task.t
    s = 10 * (t / T) ** 3 - 15 * (t / T) ** 4 + 6 * (t / T) ** 5
    w = 4 * s * (1 - s)
    fz = w * (-65 + 80 * np.sin(2 * np.pi * t / 12 + np.pi / 4))
    np.testing.assert_allclose(task.force().f[:, 2], fz, atol=1e-5)
    dy = w * 0.10 * np.sin(2 * np.pi * 0.2 * t)
    # the paper's formula everywhere but the two samples before the last, which hold the final pose so the
    # plan can end at rest (forte.planning.tasks.paths.ending_at_rest; departure < 0.2 mm here)
    np.testing.assert_allclose(task.targets[:-3, 1, 3] - task.targets[0, 1, 3], dy[:-3], atol=1e-9)
    np.testing.assert_array_equal(task.targets[-3:-1], task.targets[[-1, -1]])
    assert np.abs(task.targets[-3:-1, 1, 3] - task.targets[0, 1, 3] - dy[-3:-1]).max() < 2e-4


def test_hold_example_uses_the_teaching_pose():
    task = load_task(EXAMPLES / "hold.yaml")
    assert task.mode == "hold" and task.n == 1 and task.weights.preset == "forte-hold"
    assert task.settings.alpha == 0.7
    np.testing.assert_allclose(task.targets[0], task.robot.ee_pose(task.teaching), atol=1e-12)


def write(tmp_path, data, name="task.yaml"):
    path = tmp_path / name
    path.write_text(yaml.safe_dump(data) if not isinstance(data, str) else data)
    return path


def lift_dict():
    return yaml.safe_load((EXAMPLES / "lift-path.yaml").read_text())


def load_error(tmp_path, mutate):
    """Write lift.yaml changed by ``mutate`` and return (path, the error message of loading it)."""
    data = lift_dict()
    mutate(data)
    path = write(tmp_path, data)
    with pytest.raises(ForteError) as err:
        load_task(path)
    return path, str(err.value)


@pytest.mark.parametrize(
    ("mutate", "message"),
    [
        (lambda d: d.update(colour="red"), "colour: unknown field"),
        (lambda d: d.update(mode="fly"), "mode: expected one of trajectory, hold"),
        (lambda d: d["payload"].update(mass=-2), "payload.mass: expected a number >= 0"),
        (lambda d: d["payload"].update(mass="heavy"), "payload.mass: expected a finite number"),
        (lambda d: d.update(initial_configuration=[0, 0, 0]), "initial_configuration: expected a list of 10"),
        (lambda d: d["path"]["waypoints"][2].update(t=1.0), "path.waypoints[2].t: times must increase"),
        (lambda d: d["path"]["waypoints"][1].update(position=[0, 0]), "path.waypoints[1].position: expected a list"),
        (lambda d: d["path"].update(relative=False), "m from the end-effector position of initial_configuration"),
        (lambda d: d.update(uncertainty_radius=-1), "uncertainty_radius: expected a number >= 0"),
        (lambda d: d.update(uncertainty_rule="guess"), "uncertainty_rule: expected one of fixed, mass-range"),
        (lambda d: d.update(weights={"capability": -1}), "weights.capability: expected a number >= 0"),
        (lambda d: d.update(weights={"capabilty": 1}), "weights.capabilty: unknown field"),
        (lambda d: d.update(robot={"urdf": "missing.urdf", "ee_frame": "x"}), "does not exist"),
        (lambda d: d.update(robot={"ee_frame": "nope"}), "robot: ee_frame: no frame 'nope'"),
        (lambda d: d.update(torque_limits=[1, 2]), "torque_limits: expected a list of 7"),
    ],
)
def test_bad_task_files_name_file_and_field(tmp_path, mutate, message):
    path, error = load_error(tmp_path, mutate)
    assert message in error
    assert str(path) in error or "robot" in message or "does not exist" in message


def test_missing_and_malformed_files(tmp_path):
    with pytest.raises(TaskFileError, match="task file does not exist"):
        load_task(tmp_path / "nope.yaml")
    with pytest.raises(TaskFileError, match="not valid YAML"):
        load_task(write(tmp_path, "a: [1, 2"))
    with pytest.raises(TaskFileError, match=r"\(top level\): expected a mapping"):
        load_task(write(tmp_path, "- 1\n- 2\n"))


def test_mass_override_is_validated():
    with pytest.raises(TaskFileError, match="--mass: expected a finite number > 0"):
        load_task(EXAMPLES / "lift.yaml", mass=float("nan"))


def test_robot_section_loads_another_arm(tmp_path):
    data = lift_dict()
    data["robot"] = {"urdf": "erd:ur_description/urdf/ur5_robot.urdf", "ee_frame": "tool0",
                     "mount": {"xyz": [0, 0, 0.5]}, "tool": None}
    data["initial_configuration"] = [0, 0, 0, 0, -1.2, 1.5, -1.8, -1.57, 0]
    task = load_task(write(tmp_path, data))
    assert task.robot.n_arm == 6 and task.robot.tool is None
    assert task.robot.mount[2, 3] == 0.5


@pytest.mark.parametrize(
    ("mutate", "message"),
    [
        (lambda d: d.update(solver={"tol": 0}), "solver: tol: expected a finite number > 0"),
        (lambda d: d.update(solver={"max_iter": 0}), "solver: max_iter: expected an integer >= 1"),
        (lambda d: d.update(weights={"joint_margin": 0}), "weights.joint_margin: expected a finite number > 0, got 0"),
        (lambda d: d.update(weights={"capability_params": {"alpha": 2}}),
         "weights.capability_params.alpha: expected 0 < alpha <= 1, got 2"),
        (lambda d: d.update(limits={"base_velocity": [-1, 1, 1]}), "limits: base_velocity: expected limits > 0"),
        (lambda d: d.update(limits={"arm_velocity": [1, 2]}), "limits: expected 7 arm velocity"),
        (lambda d: d["path"].update(relative="no"), "path.relative: expected true or false"),
        (lambda d: d["path"].update(samples=None, rate=0.01), "path.rate: gives 1 waypoint"),
        (lambda d: d["path"].update(orientation={"matrix": [["a"]]}), "path.orientation.matrix: expected a 3x3"),
        (lambda d: d.update(initial_configuration=[0, 0, 0, 0, -0.78, 0, 0.5, 0, 1.57, 0.78]),
         "initial_configuration[6]: joint panda_joint4 = 0.5 is outside its limits"),
        (lambda d: d.update(mode="hold", teaching_configuration=d["initial_configuration"]),
         "path: not used in mode 'hold'"),
    ],
)
def test_bad_options_name_file_and_field(tmp_path, mutate, message):
    path, error = load_error(tmp_path, mutate)
    assert message in error
    assert str(path) in error


def test_string_options_are_accepted(tmp_path):
    data = lift_dict()
    data["solver"] = {"cache_dir": str(tmp_path / "cache"), "codegen": False}
    task = load_task(write(tmp_path, data))
    assert task.solver.cache_dir == str(tmp_path / "cache") and task.solver.codegen is False


def test_waypoints_do_not_apply_to_hold():
    with pytest.raises(TaskFileError, match="--waypoints: applies to mode 'trajectory'"):
        load_task(EXAMPLES / "hold.yaml", waypoints=10)


def _absolute_lift(tmp_path, shift, rpy=None):
    """lift-path.yaml with absolute positions starting ``shift`` (m) from the initial pose."""
    data = yaml.safe_load((EXAMPLES / "lift-path.yaml").read_text())
    task = load_task(EXAMPLES / "lift-path.yaml")
    p0 = task.targets[0][:3, 3]
    data["path"]["relative"] = False
    for item in data["path"]["waypoints"]:
        item["position"] = (p0 + np.asarray(item["position"], dtype=float)).tolist()
    data["path"]["waypoints"][0]["position"] = (p0 + np.asarray(shift)).tolist()
    if rpy is not None:
        data["path"]["orientation"] = {"rpy": rpy}
    return write(tmp_path, data, "absolute.yaml")


def test_absolute_start_within_a_millimetre_is_snapped_with_a_note(tmp_path):
    path = _absolute_lift(tmp_path, [0.0005, 0.0, 0.0])
    with pytest.warns(UserWarning, match=r"path: starts 0\.5 mm and .* mrad from .* snapped"):
        task = load_task(path)
    np.testing.assert_allclose(task.targets[0], task.robot.ee_pose(task.q_init), atol=1e-12)
    np.testing.assert_allclose(task.resampled(20).targets[0], task.targets[0], atol=1e-12)


def test_start_errors_say_what_differs_at_full_precision(tmp_path):
    with pytest.raises(TaskFileError, match=r"path: starts 0\.01229999\d* m from the end-effector position"):
        load_task(_absolute_lift(tmp_path, [0.0123, 0.0, 0.0]))
    # an orientation in degrees: the error talks about orientation and units, not 'relative: true'
    with pytest.raises(TaskFileError, match=r"path\.orientation: differs by .* rad .* look like degrees") as exc:
        load_task(_absolute_lift(tmp_path, [0.0, 0.0, 0.0], rpy=[180.0, 0.0, 90.0]))
    assert "relative" not in str(exc.value)


def test_mass_range_rule_covers_the_estimate_s_range(tmp_path):
    from dataclasses import replace

    data = yaml.safe_load((EXAMPLES / "hold.yaml").read_text())
    data["uncertainty_rule"] = "mass-range"
    path = tmp_path / "hold.yaml"
    path.write_text(yaml.safe_dump(data))
    task = load_task(path)
    assert task.radius_rule == "mass-range"
    # a given mass has no range: the fixed radius
    np.testing.assert_allclose(task.force().r, 10.0)
    ranged = task.with_payload(replace(task.payload, mass=2.7, mass_range=(1.0, 4.5)))
    np.testing.assert_allclose(ranged.force().r, 1.8 * task.robot.gravity)
    # an explicit mass (e.g. the identified one while re-planning) is exact: the fixed radius again
    np.testing.assert_allclose(ranged.force(mass=3.0).r, 10.0)
    # the authors' default keeps r = 10 N whatever the range
    default = load_task(EXAMPLES / "hold.yaml")
    np.testing.assert_allclose(default.with_payload(ranged.payload).force().r, 10.0)


def test_capability_params_override_keeps_the_preset_s_other_fields(tmp_path):
    """``weights: {capability_params: {knee: 0}}`` changes the knee only: alpha stays the preset's
    (0.9 on the trajectory sets, 0.7 in holding), not the class default."""
    for name, alpha in (("lift.yaml", 0.9), ("hold.yaml", 0.7)):
        data = yaml.safe_load((EXAMPLES / name).read_text())
        data.setdefault("weights", {})["capability_params"] = {"knee": 0}
        path = tmp_path / name
        path.write_text(yaml.safe_dump(data))
        params = load_task(path).settings.capability_params
        preset = load_task(EXAMPLES / name).settings.capability_params
        assert params.knee == 0 and preset.knee == 3
        assert params.alpha == preset.alpha == alpha
        assert (params.kappa, params.max_exponent) == (preset.kappa, preset.max_exponent)


def test_term_settings_in_the_terms_section_equal_their_older_weights_names(tmp_path):
    """``terms: {manipulability: {lambda: ...}}`` and ``weights: {manipulability_lambda: ...}`` give the
    same settings (the term's own declaration says both); ``terms:`` wins over ``weights:``."""
    from forte.planning.terms.costs import make_terms

    def load(**sections):
        data = yaml.safe_load((EXAMPLES / "lift.yaml").read_text()) | sections
        return task_from_dict(data, tmp_path / "t.yaml")

    old = load(weights={"manipulability_lambda": 1e-4, "dct_cutoff": 0.2, "joint_margin_fraction": None})
    new = load(terms={"manipulability": {"lambda": 1e-4}, "base_spectral": {"cutoff": 0.2},
                      "joint_limits": {"margin_fraction": None}})
    assert old.settings == new.settings and old.weights == new.weights
    terms = make_terms(("manipulability", "base_spectral", "joint_limits"), new.settings)
    assert (terms[0].lam, terms[1].cutoff, terms[2].margin_fraction) == (1e-4, 0.2, None)
    both = load(weights={"dct_cutoff": 0.2}, terms={"base_spectral": {"cutoff": 0.3}})
    assert both.settings["base_spectral"]["cutoff"] == 0.3


@pytest.mark.parametrize(("section", "message"), [
    ({"terms": {"manipulability": {"lamda": 1e-4}}},
     "terms.manipulability.lamda: unknown field; expected one of eps, lambda, weight, with_yaw"),
    ({"terms": {"base_spectral": {"form": "sparse"}}},
     "terms.base_spectral.form: expected one of auto, exact, dense, banded, got 'sparse'"),
    ({"terms": {"joint_limits": {"margin": -1}}}, "terms.joint_limits.margin: expected a finite number > 0, got -1.0"),
    ({"weights": {"dct_cutof": 0.2}}, "weights.dct_cutof: unknown field; expected one of "),
])
def test_a_bad_term_setting_is_one_line_naming_the_field(tmp_path, section, message):
    path = tmp_path / "task.yaml"
    path.write_text(yaml.safe_dump(yaml.safe_load((EXAMPLES / "lift.yaml").read_text()) | section))
    with pytest.raises(TaskFileError) as err:
        load_task(path)
    text = str(err.value)
    assert message in text and str(path) in text and "\n" not in text


@pytest.mark.parametrize(("edit", "line"), [
    (lambda d: d.update(initial_configuraton=d.pop("initial_configuration")),
     r"initial_configuraton: unknown field; expected one of .*; did you mean 'initial_configuration'\?$"),
    (lambda d: d.update(weights={"capabilty": 1}),
     r"weights\.capabilty: unknown field; .*did you mean 'capability'\?$"),
    (lambda d: d.update(terms={"manipulabilty": {}}), r"terms\.manipulabilty: not a registered cost term; .*"
     r"did you mean 'manipulability'\?$"),
    (lambda d: d.update(colour="red"), r"colour: unknown field; expected one of [a-z_, ]+$"),  # nothing close
])
def test_an_unknown_field_suggests_the_nearest_valid_name(tmp_path, capsys, edit, line):
    from forte.cli.main import main

    data = yaml.safe_load((EXAMPLES / "hold.yaml").read_text())
    edit(data)
    path = tmp_path / "typo.yaml"
    path.write_text(yaml.safe_dump(data))
    assert main(["plan", str(path), "--out", str(tmp_path / "o"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert err.startswith(f"forte: error: {path}: ")
    assert re.search(line, err.strip()), err
