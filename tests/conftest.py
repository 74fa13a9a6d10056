"""Shared fixtures: robots are built once per session (URDF parsing costs ~50 ms)."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import pytest

from forte.model.robot import MobileManipulator, default_robot, example_robot_data_dir


@pytest.fixture(autouse=True)
def _no_progress_leak(request: pytest.FixtureRequest) -> Iterator[None]:
    """Every test starts and ends with progress off (the library's default): a test that leaves a
    reporter active fails itself, and the next test starts clean whatever happened."""
    from forte import progress

    with progress.activate(None):  # restores the state before the test on the way out
        yield
        leaked = progress.active()
    assert leaked is None, f"{request.node.nodeid} left a progress reporter active"


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


def authors_ee_in_base(q_arm: np.ndarray) -> np.ndarray:
    """The authors' end effector in the base frame, independent of forte's model: Pinocchio on the
    plain example-robot-data URDF, then their mount (0.2575, 0, 0.52) m, the flange, the hand's
    -45 deg about z and 0.10 m along z."""
    import pinocchio as pin

    full = pin.buildModelFromUrdf(str(example_robot_data_dir() / "panda_description/urdf/panda.urdf"))
    data = full.createData()
    pin.framesForwardKinematics(full, data, np.r_[q_arm, 0.0, 0.0])
    flange = data.oMf[full.getFrameId("panda_link8")].homogeneous
    hand = np.eye(4)
    hand[:3, :3] = pin.rpy.rpyToMatrix(0, 0, -np.pi / 4)
    hand[2, 3] = 0.10
    mount = np.eye(4)
    mount[:3, 3] = (0.2575, 0.0, 0.52)
    return mount @ flange @ hand
