"""Shared fixtures: robots are built once per session (URDF parsing costs ~50 ms)."""

from __future__ import annotations

import numpy as np
import pytest

from forte.robot import MobileManipulator, default_robot


@pytest.fixture(scope="session")
def robot() -> MobileManipulator:
    return default_robot()


@pytest.fixture(scope="session")
def ur5() -> MobileManipulator:
    return MobileManipulator("erd:ur_description/urdf/ur5_robot.urdf", "tool0", name="ur5")


def random_configuration(robot: MobileManipulator, rng: np.random.Generator) -> np.ndarray:
    base = np.array([rng.uniform(-2, 2), rng.uniform(-2, 2), rng.uniform(-np.pi, np.pi)])
    lo = np.maximum(robot.lower, -np.pi)
    hi = np.minimum(robot.upper, np.pi)
    return np.concatenate([base, rng.uniform(lo, hi)])
