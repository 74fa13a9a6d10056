"""Batched forward kinematics (forte.model.joint_placements) against Pinocchio's, joint by joint."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from forte.model.joint_placements import joint_placements
from forte.model.presets import preset_robot
from forte.model.self_collision import arm_geometry


def _pinocchio_placements(model: pin.Model, Q: np.ndarray) -> np.ndarray:
    data = model.createData()
    out = []
    for q in Q:
        pin.forwardKinematics(model, data, q)
        out.append([m.homogeneous for m in data.oMi])
    return np.array(out)


@pytest.mark.parametrize("preset", ["authors", "ur5", "kinova", "tiago"])
def test_the_presets_arm_joints_are_placed_as_pinocchio_places_them(preset):
    model = arm_geometry(preset_robot(preset)).model  # revolute x/y/z, TIAGo's prismatic torso
    rng = np.random.default_rng(3)
    Q = rng.uniform(np.maximum(model.lowerPositionLimit, -4), np.minimum(model.upperPositionLimit, 4), (40, model.nq))
    assert np.abs(joint_placements(model, Q) - _pinocchio_placements(model, Q)).max() < 1e-12


def test_unaligned_unbounded_and_prismatic_joints_are_placed_as_pinocchio_places_them():
    model = pin.Model()
    rng = np.random.default_rng(4)
    def placement() -> pin.SE3:
        return pin.SE3(pin.exp3(rng.normal(size=3)), rng.normal(size=3))
    joints = [pin.JointModelRUBZ(), pin.JointModelRevoluteUnaligned(np.array([1.0, 2.0, 3.0])),  # not unit: as given
              pin.JointModelPrismaticUnaligned(np.array([0.3, -1.0, 2.0])), pin.JointModelRY(), pin.JointModelPX(),
              pin.JointModelRUBX()]
    parent = 0
    for i, joint in enumerate(joints):
        parent = model.addJoint(parent, joint, placement(), f"j{i}")
    Q = np.array([pin.randomConfiguration(model, -np.ones(model.nq), np.ones(model.nq)) for _ in range(30)])
    assert np.abs(joint_placements(model, Q) - _pinocchio_placements(model, Q)).max() < 1e-12


def test_a_joint_of_another_type_gives_none():
    model = pin.Model()
    model.addJoint(0, pin.JointModelSpherical(), pin.SE3.Identity(), "ball")
    assert joint_placements(model, np.array([[0.0, 0.0, 0.0, 1.0]])) is None
