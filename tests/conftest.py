"""Shared fixtures: robots are built once per session (URDF parsing costs ~50 ms)."""

from __future__ import annotations

import numpy as np
import pytest

from forte.model.robot import MobileManipulator, default_robot


@pytest.fixture(scope="session")
def robot() -> MobileManipulator:
    return default_robot()


@pytest.fixture(scope="session")
def ur5() -> MobileManipulator:
    return MobileManipulator("erd:ur_description/urdf/ur5_robot.urdf", "tool0", name="ur5")


# Hand example shared by the polytope and metric tests: a planar 2-link arm (l1 = l2 = 1) in
# the xy-plane at q = (0, pi/2): j1 = (-1, 1, 0), j2 = (-1, 0, 0); limits (10, 5) Nm; nominal
# torque (2, -1) Nm.
TWO_LINK_J = np.array([[-1.0, -1.0], [1.0, 0.0], [0.0, 0.0]])
TWO_LINK_TAU_MAX = np.array([10.0, 5.0])
TWO_LINK_TAU_NOM = np.array([2.0, -1.0])


def random_configuration(robot: MobileManipulator, rng: np.random.Generator) -> np.ndarray:
    base = np.array([rng.uniform(-2, 2), rng.uniform(-2, 2), rng.uniform(-np.pi, np.pi)])
    lo = np.maximum(robot.lower, -np.pi)
    hi = np.minimum(robot.upper, np.pi)
    return np.concatenate([base, rng.uniform(lo, hi)])
