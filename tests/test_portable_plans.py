"""Outputs that travel: a plan directory carries its robot description (robot.urdf, sha256), so a
moved copy reads, exports and simulates the same; the exported URDF names its meshes by package and
carries the simulator's base inertia."""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from forte.cli.main import main
from forte.exceptions import TaskFileError
from forte.execution.model import build_sim_model
from forte.io.export import BASE_JOINTS, BASE_LINKS
from forte.io.plandir import read_plan_dir, write_plan_dir
from forte.io.robot_file import ROBOT_FILE
from forte.model.description import (
    BASE_INERTIA,
    BASE_MASS,
    _link_inertial,
    example_robot_data_dir,
    mesh_package_dirs,
)
from forte.model.robot import MobileManipulator, default_robot
from forte.model.self_collision import arm_geometry
from forte.model.trajectory import quintic_path

PANDA = "panda_description/urdf/panda.urdf"


def _short_plan(robot: MobileManipulator, directory: Path) -> Path:
    """A 1 s reach of the arm with the base moving, 6 waypoints, 1 kg payload."""
    q0 = robot.home()
    q1 = q0 + np.array([0.1, -0.05, 0.2, 0.15, 0.0, -0.1, 0.1, 0.0, 0.1, 0.0])
    t = np.linspace(0.0, 1.0, 6)
    return write_plan_dir(directory, robot, t, quintic_path([0.0, 1.0], [q0, q1], t), mass=1.0)


def _outputs(plan_dir: Path, work: Path) -> dict[str, bytes]:
    """Every export of ``plan_dir`` and a short simulation of it, as bytes (run through the CLI)."""
    work.mkdir()
    for name in ("plan.npz", "plan.csv", "plan.mcap", "robot.urdf", "robot.xml"):
        command = ["robot", "export", str(work / name), "--plan", str(plan_dir)] if name.startswith("robot") \
            else ["export", str(plan_dir), str(work / name)]
        assert main([*command, "--quiet"]) == 0, command
    assert main(["simulate", str(plan_dir), "--out", str(work / "sim"), "--hold", "0.2", "--quiet"]) == 0
    out = {p.name: p.read_bytes() for p in work.iterdir() if p.is_file()}
    out["sim.csv"] = (work / "sim" / "sim.csv").read_bytes()
    sim = json.loads((work / "sim" / "sim.json").read_text())
    sim.pop("wall_time_s")  # differs between any two runs
    assert sim.pop("plan_dir") == str(plan_dir)  # where it was read from: the one path recorded
    out["sim.json"] = json.dumps(sim, sort_keys=True).encode()
    return out


def test_plan_dir_stores_its_robot(tmp_path: Path) -> None:
    plan_dir = _short_plan(default_robot(), tmp_path / "plan")
    doc = json.loads((plan_dir / "plan.json").read_text())
    robot = doc["robot"]
    assert doc["format_version"] == 4
    assert robot["urdf"] == f"erd:{PANDA}" and robot["urdf_file"] == ROBOT_FILE
    stored = (plan_dir / ROBOT_FILE).read_bytes()
    assert stored == (example_robot_data_dir() / PANDA).read_bytes()
    assert robot["urdf_sha256"] == hashlib.sha256(stored).hexdigest()
    assert str(example_robot_data_dir()) not in (plan_dir / "plan.json").read_text()  # no path into the venv
    assert b"package://example-robot-data/" in stored and b"file://" not in stored


@pytest.mark.parametrize("own_urdf", [False, True], ids=["example-robot-data", "own-urdf-deleted"])
def test_moved_plan_exports_and_simulates_identically(tmp_path: Path, own_urdf: bool) -> None:
    """The built-in robot, and a robot whose own URDF file is gone after planning (the stored copy
    is all there is): a moved copy gives the same exports and simulation, byte for byte."""
    robot = default_robot()
    if own_urdf:
        mine = tmp_path / "mine" / "arm.urdf"
        mine.parent.mkdir()
        shutil.copy(example_robot_data_dir() / PANDA, mine)
        robot = default_robot(urdf=str(mine), arm_joints=robot.arm_joints, hand_mass=robot.hand_mass)
    plan_dir = _short_plan(robot, tmp_path / "plan")
    before = _outputs(plan_dir, tmp_path / "before")
    pairs = arm_geometry(read_plan_dir(plan_dir).robot).pairs  # the collision meshes resolve
    moved = tmp_path / "elsewhere" / "deeper" / "plan"
    moved.parent.mkdir(parents=True)
    shutil.move(plan_dir, moved)
    if own_urdf:
        shutil.rmtree(tmp_path / "mine")
        assert read_plan_dir(moved).robot.urdf_path == moved / ROBOT_FILE
    after = _outputs(moved, tmp_path / "after")
    geometry = arm_geometry(read_plan_dir(moved).robot)
    assert geometry is not None and geometry.pairs == pairs
    assert before.keys() == after.keys()
    for name in before:
        assert before[name] == after[name], name


def test_older_plan_dir_still_reads(tmp_path: Path) -> None:
    """Format 3: no robot.urdf, ``robot.urdf`` an absolute path (this machine's, or another
    installation's of example-robot-data)."""
    plan_dir = _short_plan(default_robot(), tmp_path / "plan")
    new = read_plan_dir(plan_dir)
    path = plan_dir / "plan.json"
    doc = json.loads(path.read_text())
    doc["format_version"] = 3
    del doc["robot"]["urdf_file"]
    (plan_dir / ROBOT_FILE).unlink()
    for urdf in (str(example_robot_data_dir() / PANDA),
                 f"/elsewhere/venv/lib/python3.11/site-packages/cmeel.prefix/share/example-robot-data/robots/{PANDA}"):
        doc["robot"]["urdf"] = urdf
        path.write_text(json.dumps(doc))
        old = read_plan_dir(plan_dir)
        assert old.robot.fingerprint == new.robot.fingerprint
        np.testing.assert_array_equal(old.q, new.q)


def test_tampered_robot_urdf_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    plan_dir = _short_plan(default_robot(), tmp_path / "plan")
    stored = plan_dir / ROBOT_FILE
    stored.write_text(stored.read_text().replace('<mass value="0.73"/>', '<mass value="0.93"/>', 1))
    assert stored.read_bytes() != (example_robot_data_dir() / PANDA).read_bytes()
    with pytest.raises(TaskFileError, match="robot.urdf: sha256 .* differs from plan.json's robot.urdf_sha256"):
        read_plan_dir(plan_dir)
    for command in (["simulate", str(plan_dir)], ["export", str(plan_dir), str(tmp_path / "x.npz")],
                    ["robot", "export", str(tmp_path / "r.urdf"), "--plan", str(plan_dir)]):
        capsys.readouterr()
        assert main(command) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "robot.urdf: sha256" in err[0], err
    stored.unlink()
    assert main(["simulate", str(plan_dir)]) == 2
    assert "robot.urdf: file missing" in capsys.readouterr().err


def test_exported_urdf_loads_elsewhere_with_the_planner_model(tmp_path: Path) -> None:
    """Pinocchio in a fresh process, in another working directory, with only example-robot-data's
    share folder for ``package://``: the planner's forward kinematics, masses and gravity torques."""
    robot = default_robot()
    plan_dir = _short_plan(robot, tmp_path / "plan")
    out = tmp_path / "export" / "robot.urdf"
    out.parent.mkdir()
    assert main(["robot", "export", str(out), "--plan", str(plan_dir), "--quiet"]) == 0
    text = out.read_text()
    assert "file://" not in text and str(example_robot_data_dir()) not in text
    assert "package://example-robot-data/robots/panda_description/meshes/" in text
    rng = np.random.default_rng(7)
    qs = np.column_stack([rng.uniform(-2, 2, (5, 2)), rng.uniform(-np.pi, np.pi, 5),
                          rng.uniform(robot.lower, robot.upper, (5, robot.n_arm))])
    script = f"""
import json, sys
import numpy as np, pinocchio as pin
model = pin.buildModelFromUrdf("robot.urdf")
geom = pin.buildGeomFromUrdf(model, "robot.urdf", pin.GeometryType.VISUAL, package_dirs={mesh_package_dirs()!r})
data = model.createData()
model.gravity = pin.Motion(np.array([0, 0, -{robot.gravity!r}, 0, 0, 0]))
out = {{"names": [model.names[j] for j in range(1, model.njoints)], "ngeoms": geom.ngeoms, "poses": [], "tau": [],
       "masses": {{model.names[j]: model.inertias[j].mass for j in range(1, model.njoints)}}}}
for q in {qs.tolist()!r}:
    q = np.array(q)
    pin.framesForwardKinematics(model, data, q)
    out["poses"].append(data.oMf[model.getFrameId("forte_ee")].homogeneous.tolist())
    out["tau"].append(pin.rnea(model, data, q, np.zeros(model.nv), np.zeros(model.nv)).tolist())
json.dump(out, sys.stdout)
"""
    elsewhere = tmp_path / "export"
    env = {k: v for k, v in os.environ.items() if k not in ("ROS_PACKAGE_PATH", "AMENT_PREFIX_PATH")}
    result = subprocess.run([sys.executable, "-c", script], cwd=elsewhere, capture_output=True, text=True,
                            env=env, check=False, timeout=120)
    assert result.returncode == 0, result.stderr
    got = json.loads(result.stdout)
    assert got["names"] == [*BASE_JOINTS, *robot.arm_joints] and got["ngeoms"] > 0
    for q, pose, tau in zip(qs, got["poses"], got["tau"], strict=True):
        np.testing.assert_allclose(pose, robot.ee_pose(q), atol=1e-12)
        n = robot.n_arm
        np.testing.assert_allclose(tau[3:], robot.rnea(q[3:], np.zeros(n), np.zeros(n)), atol=1e-9)
    # masses: the base is the simulator's; every arm body the planner's (hand 0.54 kg, fingers merged)
    base = ET.fromstring(text).find(f"link[@name='{BASE_LINKS[-1]}']/inertial")
    assert float(base.find("mass").get("value")) == BASE_MASS
    assert [float(base.find("inertia").get(k)) for k in ("ixx", "iyy", "izz")] == list(BASE_INERTIA)
    # Pinocchio merges the arm's root link (fixed on the base) into the base body
    link0 = _link_inertial(example_robot_data_dir() / PANDA, "panda_link0")[0]
    assert got["masses"]["base_yaw"] == pytest.approx(BASE_MASS + link0, abs=1e-12)
    assert got["masses"]["base_x"] == got["masses"]["base_y"] == 0.0
    for j, name in enumerate(robot.arm_joints, start=1):
        assert got["masses"][name] == pytest.approx(robot.model.inertias[j].mass, abs=1e-12), name
    # ... and MuJoCo's base body carries the same mass and inertia
    sim = build_sim_model(robot)
    body = sim.model.body("base")
    assert body.mass[0] == BASE_MASS and np.allclose(body.inertia, BASE_INERTIA)
