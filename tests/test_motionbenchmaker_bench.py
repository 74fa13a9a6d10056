"""The MotionBenchMaker benchmark's variants (``benchmarks/motionbenchmaker.py``): the arm on the
authors' holonomic base with the scene placed at its mount and the goal as the hand's pose."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DATA = Path(__file__).resolve().parent / "data" / "motionbenchmaker" / "box_panda"
_spec = importlib.util.spec_from_file_location("motionbenchmaker_bench", ROOT / "benchmarks" / "motionbenchmaker.py")
mbm = importlib.util.module_from_spec(_spec)
sys.modules["motionbenchmaker_bench"] = mbm
_spec.loader.exec_module(mbm)


def test_the_holonomic_variant_places_the_scene_at_the_mount_and_asks_the_hands_pose(tmp_path):
    request, scene = DATA / "request0001.yaml", DATA / "scene0001.yaml"
    (tmp_path / "fixed").mkdir()
    (tmp_path / "mobile").mkdir()
    fixed = mbm.load(request, scene, tmp_path / "fixed", None)
    mobile = mbm.load(request, scene, tmp_path / "mobile", None, True, "holonomic")
    assert mobile.robot.base == "holonomic" and fixed.robot.base == "fixed" and mobile.solver.route_first
    mount = np.eye(4)
    mount[:3, 3] = mbm.AUTHORS_MOUNT
    by_name = {o.name: o for o in fixed.scene.objects}
    assert len(mobile.scene.objects) == len(by_name)
    for body in mobile.scene.objects:  # every body where the mount puts the fixed arm's world
        assert np.allclose(body.pose, mount @ by_name[body.name].pose, atol=1e-9)
    # the goal: the pose the fixed arm's goal configuration gives, seen from the mount
    hand = mount @ fixed.robot.ee_pose(fixed.goal.q_end)
    assert mobile.goal.pose is not None and np.allclose(mobile.goal.pose, hand, atol=1e-9)
    assert np.allclose(mobile.robot.ee_pose(np.r_[0.0, 0.0, 0.0, fixed.goal.q_end[3:]]), hand, atol=1e-6)


def test_the_summary_states_how_closely_mujoco_tracked_the_hand():
    rows = [{"sim_ee_error_m": "0.0008"}, {"sim_ee_error_m": "0.0242"}, {"sim_ee_error_m": "0.0115"}, {}]
    said = mbm._tracking(rows)
    assert "11.5 mm (median" in said and "24.2 mm at most" in said
    assert mbm._tracking([{}]) == ""  # nothing simulated: nothing said
