"""A route's time law at the path's corners (forte.planning.search.corners): toppra's spline cuts a
corner of the searched path; knots on the corner's segments bring it back to the path's clearance."""

from __future__ import annotations

import numpy as np
import pytest

from forte.model.clearance import clearances
from forte.model.robot import MobileManipulator
from forte.model.scene import Scene, SceneObject, Sphere
from forte.planning.search.corners import corners, hugging_law, with_corner_knots
from forte.planning.search.sampling import SLIP, kept
from forte.planning.search.timing import retime

pytest.importorskip("toppra")

ARM = (0.6, 0.0, -1.8, 0.0, 2.4, 0.785)
START = np.r_[0.0, 0.0, 0.0, -0.7, ARM]
GOAL = np.r_[0.0, 0.0, 0.0, 0.7, ARM]
OVER = np.r_[0.0, 0.0, 0.0, 0.0, -0.3, 0.0, -1.2, 0.0, 1.6, 0.785]  # the corner of START -> OVER -> GOAL
PATH = np.array([START, OVER, GOAL])
SAMPLES = 400


@pytest.fixture(scope="module")
def panda() -> MobileManipulator:
    return MobileManipulator(urdf="erd:panda_description/urdf/panda.urdf", ee_frame="panda_hand", base="fixed")


def polyline(path: np.ndarray, per_segment: int = 2000) -> np.ndarray:
    return np.concatenate([np.linspace(a, b, per_segment) for a, b in zip(path[:-1], path[1:], strict=True)])


@pytest.fixture(scope="module")
def pin_inside_the_cut(panda) -> tuple[Scene, Scene]:
    """A 1 cm ball where the plain law leaves the path most (the hand's largest offset from the
    polyline), 3.5 mm from the polyline; and the same ball 1 cm farther out."""
    law = retime(panda, PATH, samples=SAMPLES)
    dense = polyline(PATH)
    on_path = np.array([panda.ee_pose(q)[:3, 3] for q in dense])
    on_law = np.array([panda.ee_pose(q)[:3, 3] for q in law.q])
    offset = np.linalg.norm(on_law[:, None] - on_path[None], axis=2)
    k = int(np.argmax(offset.min(axis=1)))
    j = int(np.argmin(offset[k]))
    out = (on_law[k] - on_path[j]) / np.linalg.norm(on_law[k] - on_path[j])

    def ball(at: float) -> Scene:
        pose = np.eye(4)
        pose[:3, 3] = on_path[j] + out * at
        return Scene((SceneObject("pin", Sphere(0.01), pose),), None)

    at = 0.1
    for _ in range(4):  # the ball along ``out`` until the polyline keeps 3.5 mm (the closest part moves with it)
        at += 0.0035 - clearances(panda, ball(at), dense).distance.min()
    return ball(at), ball(at + 0.01)


def test_corners_are_the_vertices_where_the_path_turns():
    straight = np.array([START, (START + OVER) / 2, OVER, GOAL])
    assert corners(straight).tolist() == [2]
    assert corners(np.array([START, GOAL])).tolist() == []


def test_corner_knots_lie_on_the_corners_segments():
    out = with_corner_knots(PATH, [1], 0.05)
    assert len(out) == 5 and np.array_equal(out[[0, 2, 4]], PATH)
    for knot, end in ((out[1], START), (out[3], GOAL)):
        along = knot - OVER
        assert np.linalg.norm(along) == pytest.approx(0.05)
        assert np.allclose(along / np.linalg.norm(along), (end - OVER) / np.linalg.norm(end - OVER))
    assert np.array_equal(with_corner_knots(PATH, [0, 2], 0.05), PATH)  # the ends are no corners


def test_a_law_that_cuts_the_corner_below_the_paths_clearance_gets_corner_knots(panda, pin_inside_the_cut):
    near, _ = pin_inside_the_cut
    assert clearances(panda, near, polyline(PATH)).distance.min() == pytest.approx(0.0035, abs=1e-5)
    floor = kept(panda, near, 0.0, START, GOAL) - SLIP  # 3 mm kept, 1 mm slip: the verdict's 2 mm
    plain = retime(panda, PATH, samples=SAMPLES)
    assert clearances(panda, near, plain.q).distance.min() < floor  # the spline cuts inside the corner
    law, facts = hugging_law(panda, near, PATH, 0.0, samples=SAMPLES)
    assert facts["corner_knots"] == 1
    assert facts["law_clearance_m"] == pytest.approx(clearances(panda, near, law.q).distance.min())
    assert facts["law_clearance_m"] >= floor
    assert np.array_equal(law.q[0], START) and np.allclose(law.q[-1], GOAL)
    assert plain.duration <= law.duration < 1.5 * plain.duration  # a sharper turn, slower there only


def test_a_law_that_keeps_the_clearance_is_left_as_it_is(panda, pin_inside_the_cut):
    _, far = pin_inside_the_cut
    law, facts = hugging_law(panda, far, PATH, 0.0, samples=SAMPLES)
    assert facts == {}
    assert np.array_equal(law.q, retime(panda, PATH, samples=SAMPLES).q)
