"""The static capacity check before a solve (forte.planning.verdict.sanity): batched as one by one."""

from __future__ import annotations

import numpy as np
import pytest

from forte.capability.polytope import halfspaces, residual_margins
from forte.model.presets import preset_robot
from forte.planning.verdict.sanity import best_static_capacity, sample_configurations


def _one_by_one(robot, directions: np.ndarray, configurations: np.ndarray) -> np.ndarray:
    """Each configuration's polytope on its own (checked rnea and Jacobian), then, per direction,
    the largest over configurations of the smallest ratio b_i / (A_i u) over rows with A_i u > 0."""
    zeros = np.zeros(robot.n_arm)
    polytopes = [halfspaces(robot.arm_jacobian(q), *residual_margins(robot.rnea(q[3:], zeros, zeros),
                                                                     robot.torque_limits)) for q in configurations]
    A, b = np.array([p.A for p in polytopes]), np.array([p.b for p in polytopes])
    proj = np.einsum("smj,kj->skm", A, directions)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(proj > 1e-12, b[:, None, :] / np.where(proj > 1e-12, proj, 1.0), np.inf)
    return ratio.min(axis=-1).max(axis=0)


@pytest.mark.parametrize("preset", ["authors", "ur5", "tiago"])
def test_the_batched_capacity_is_the_one_by_one_capacity_to_the_bit(preset):
    robot = preset_robot(preset)
    configurations = sample_configurations(robot, [robot.home()], samples=64)
    rng = np.random.default_rng(9)
    directions = rng.normal(size=(300, 3))
    directions /= np.linalg.norm(directions, axis=1)[:, None]
    got = best_static_capacity(robot, directions, configurations)
    assert got.tobytes() == _one_by_one(robot, directions, configurations).tobytes()
    assert np.all(got > 0)
