"""The configuration-space search (forte.planning.search): free states and segments on forte's
collision model, a path around a wall, failures that say why, and the time law's limits."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from forte.exceptions import InvalidInputError
from forte.model.clearance import clearances
from forte.model.robot import MobileManipulator
from forte.model.scene import Box, Scene, SceneObject
from forte.model.self_collision import arm_geometry
from forte.planning.search import StateChecker, find_path, retime, segment_free
from forte.planning.search.sampling import DENSE_STEP, SLIP, kept, moving_joints
from forte.planning.verdict.requirements import EXECUTION_MARGIN
from forte.settings import KinematicLimits

pytest.importorskip("ompl")
pytest.importorskip("toppra")

ARM = (0.6, 0.0, -1.8, 0.0, 2.4, 0.785)  # joints 2..7: the hand low, ~0.5 m out
START = np.r_[0.0, 0.0, 0.0, -0.7, ARM]
GOAL = np.r_[0.0, 0.0, 0.0, 0.7, ARM]
OVER = np.r_[0.0, 0.0, 0.0, 0.0, -0.3, 0.0, -1.2, 0.0, 1.6, 0.785]  # the hand raised above the wall


@pytest.fixture(scope="module")
def panda() -> MobileManipulator:
    return MobileManipulator(urdf="erd:panda_description/urdf/panda.urdf", ee_frame="panda_hand", base="fixed")


@pytest.fixture(scope="module")
def wall() -> Scene:
    """A thin wall in front of the arm, between START (hand at y < 0) and GOAL (y > 0); no floor."""
    pose = np.eye(4)
    pose[:3, 3] = [0.6, 0.0, 0.3]
    return Scene((SceneObject("wall", Box((0.5, 0.02, 0.6)), pose),), None)


def dense(q: np.ndarray, per_segment: int = 25) -> np.ndarray:
    return np.concatenate([np.linspace(a, b, per_segment, endpoint=False) for a, b in zip(q[:-1], q[1:], strict=True)]
                          + [q[-1:]])


def test_straight_segment_through_the_wall_is_not_free_and_a_detour_is(panda, wall):
    checker = StateChecker(panda, wall, 0.0)
    assert checker.valid(START) and checker.valid(GOAL) and checker.valid(OVER)
    assert not segment_free(checker, START, GOAL)
    assert segment_free(checker, START, OVER) and segment_free(checker, OVER, GOAL)
    # the straight segment's states, checked on their own, include one inside the wall
    assert clearances(panda, wall, dense(np.array([START, GOAL]))).distance.min() < 0


@pytest.mark.parametrize("clearance", [0.0, 0.04])
def test_state_validity_is_the_exact_clearance_and_self_collision(panda, wall, clearance):
    """valid(q) == (ClearanceChecker's distance >= clearance and no self-collision) on random states."""
    checker = StateChecker(panda, wall, clearance)
    rng = np.random.default_rng(1)
    Q = np.column_stack([np.zeros((300, 3)), rng.uniform(panda.lower, panda.upper, (300, panda.n_arm))])
    distance = clearances(panda, wall, Q).distance
    self_hit = np.array([arm_geometry(panda).contact(q[3:]) is not None for q in Q])
    expected = (distance >= clearance) & ~self_hit
    assert 0 < expected.sum() < len(Q)  # both kinds occur
    assert [checker.valid(q) for q in Q] == expected.tolist()
    assert [checker.valid_pairwise(q) for q in Q] == expected.tolist()  # the broad phase drops no pair


def test_path_around_a_wall_clears_it_everywhere(panda, wall):
    result = find_path(panda, wall, START, GOAL, 0.02, time_limit=5.0, seed=0)
    assert result.found and result.reason == "" and result.states > 0 and result.checks > result.states
    assert np.array_equal(result.q[0], START) and np.allclose(result.q[-1], GOAL)
    assert np.all(result.q[:, :3] == 0.0)  # a fixed base stays put
    assert result.clearance == pytest.approx(0.02 + SLIP)  # the asked clearance is above the verdict's margin
    dense_checker = StateChecker(panda, wall, result.clearance)
    assert all(segment_free(dense_checker, a, b, DENSE_STEP) for a, b in zip(result.q[:-1], result.q[1:], strict=True))
    Q = dense(result.q)
    assert clearances(panda, wall, Q).distance.min() >= 0.02
    assert np.all((Q[:, 3:] >= panda.lower) & (Q[:, 3:] <= panda.upper))
    assert all(arm_geometry(panda).contact(q[3:]) is None for q in Q)


def test_kept_clearance_is_the_verdicts_margin_plus_the_slip_unless_an_end_is_closer(panda, wall):
    """Asked 0: the verdict's 2 mm plus the slip; a goal 2.5 mm from the wall lowers it to that."""
    assert kept(panda, wall, 0.0, START, GOAL) == pytest.approx(EXECUTION_MARGIN + SLIP)
    ends = clearances(panda, wall, np.array([START, GOAL])).distance
    assert ends.min() > 0.05 + SLIP and kept(panda, wall, 0.05, START, GOAL) == pytest.approx(0.05 + SLIP)
    assert kept(panda, wall, ends.min(), START, GOAL) == ends.min()  # never below the asked one
    near = clearances(panda, wall, GOAL)
    away = (near.witness_robot[0] - near.witness_body[0]) / np.linalg.norm(near.witness_robot[0] - near.witness_body[0])
    pose = wall.objects[0].pose.copy()
    pose[:3, 3] += away * (near.distance[0] - 0.0025)  # the wall moved toward the goal's hand
    closer = Scene((wall.objects[0]._replace(pose=pose),), None)
    goal_distance = clearances(panda, closer, GOAL).distance[0]
    assert goal_distance == pytest.approx(0.0025, abs=2e-4)
    assert kept(panda, closer, 0.0, START, GOAL) == pytest.approx(goal_distance - 1e-4)
    result = find_path(panda, closer, START, GOAL, 0.0, seed=0)  # the goal in near contact stays plannable
    assert result.found and result.clearance == pytest.approx(goal_distance - 1e-4)
    dense_checker = StateChecker(panda, closer, result.clearance)
    assert all(segment_free(dense_checker, a, b, DENSE_STEP) for a, b in zip(result.q[:-1], result.q[1:], strict=True))


def test_a_path_the_coarse_check_lets_through_the_wall_is_repaired(panda, wall, monkeypatch):
    """With a search step far too coarse for the wall, the shortcut path cuts through it; the dense
    check sends those segments back, and the returned path keeps the kept clearance densely."""
    import forte.planning.search.sampling as sampling

    monkeypatch.setattr(sampling, "CHECK_STEP", 0.8)
    result = find_path(panda, wall, START, GOAL, 0.0, seed=0, checks=50_000, time_limit=60.0)
    assert result.found and result.repairs > 0
    assert result.clearance == pytest.approx(EXECUTION_MARGIN + SLIP)
    dense_checker = StateChecker(panda, wall, result.clearance)
    assert all(segment_free(dense_checker, a, b, DENSE_STEP) for a, b in zip(result.q[:-1], result.q[1:], strict=True))
    assert clearances(panda, wall, dense(result.q, 100)).distance.min() >= EXECUTION_MARGIN
    again = find_path(panda, wall, START, GOAL, 0.0, seed=0, checks=50_000, time_limit=60.0)
    assert np.array_equal(again.q, result.q) and again.checks == result.checks  # a seed repeats its path


def test_a_path_the_repairs_cannot_mend_leaves_the_rest_of_the_budget_to_a_dense_search(panda, wall, monkeypatch):
    """No repair allowed: the coarse path through the wall is dropped, and the search goes on at the
    dense step with what is left of its budget instead of giving up."""
    import forte.planning.search.sampling as sampling

    monkeypatch.setattr(sampling, "CHECK_STEP", 0.8)
    monkeypatch.setattr(sampling, "REPAIRS", 0)
    result = find_path(panda, wall, START, GOAL, 0.0, seed=0, checks=50_000, time_limit=60.0)
    assert result.found and result.repairs == 0
    dense_checker = StateChecker(panda, wall, result.clearance)
    assert all(segment_free(dense_checker, a, b, DENSE_STEP) for a, b in zip(result.q[:-1], result.q[1:], strict=True))
    assert clearances(panda, wall, dense(result.q, 100)).distance.min() >= EXECUTION_MARGIN


def test_same_seed_same_path(panda, wall):
    first = find_path(panda, wall, START, GOAL, 0.0, seed=3)
    second = find_path(panda, wall, START, GOAL, 0.0, seed=3)
    assert first.found and np.array_equal(first.q, second.q)


def test_goal_in_collision_is_named(panda, wall):
    inside = np.r_[0.0, 0.0, 0.0, 0.0, ARM]  # the hand in the wall
    result = find_path(panda, wall, START, inside, 0.0)
    assert not result.found and result.q is None
    assert result.reason.startswith("goal configuration in collision: panda_hand vs wall, -0.")
    distance = clearances(panda, wall, inside).distance[0]
    assert f"{distance:.3f} m" in result.reason


def test_walled_in_goal_is_not_found_and_says_so():
    """A mobile base's goal inside a closed ring of 2 m walls: free, yet unreachable."""
    mobile = MobileManipulator(urdf="erd:panda_description/urdf/panda.urdf", ee_frame="panda_hand")
    walls = []
    for k, (size, centre) in enumerate([((1.8, 0.1, 2.0), (3.0, -0.9, 1.0)), ((1.8, 0.1, 2.0), (3.0, 0.9, 1.0)),
                                        ((0.1, 1.8, 2.0), (2.1, 0.0, 1.0)), ((0.1, 1.8, 2.0), (3.9, 0.0, 1.0))]):
        pose = np.eye(4)
        pose[:3, 3] = centre
        walls.append(SceneObject(f"wall{k}", Box(size), pose))
    scene = Scene(tuple(walls), 0.0)
    start, goal = np.r_[0.0, 0.0, 0.0, START[3:]], np.r_[3.0, 0.0, 0.0, START[3:]]
    assert StateChecker(mobile, scene).valid(goal)
    result = find_path(mobile, scene, start, goal, 0.0, time_limit=0.3)
    assert not result.found and result.q is None
    assert result.reason.startswith(f"no collision-free path in 0.3 s ({result.states} states sampled, ")
    assert result.states > 10
    # a budget of state checks: the same outcome however busy the machine, and said so
    budget = find_path(mobile, scene, start, goal, 0.0, time_limit=60.0, checks=3000)
    assert not budget.found and 3000 <= budget.checks < 3600  # the last motion checked whole
    assert budget.reason.startswith(f"no collision-free path in {budget.checks} state checks ({budget.states} states")
    again = find_path(mobile, scene, start, goal, 0.0, time_limit=60.0, checks=3000)
    assert (again.checks, again.states) == (budget.checks, budget.states)


def test_holonomic_base_is_searched_and_fixed_is_not(panda):
    mobile = MobileManipulator(urdf="erd:panda_description/urdf/panda.urdf", ee_frame="panda_hand")
    assert moving_joints(mobile).tolist() == list(range(10)) and moving_joints(panda).tolist() == list(range(3, 10))
    start, goal = np.r_[0.0, 0.0, 0.0, ARM[:1], ARM], np.r_[1.0, 0.5, 0.3, ARM[:1], ARM]
    result = find_path(mobile, Scene((), 0.0), start, goal, 0.0)
    assert result.found and np.allclose(result.q[-1], goal)


def test_missing_ompl_says_how_to_install_it(panda, wall, monkeypatch):
    monkeypatch.setitem(sys.modules, "ompl", None)
    with pytest.raises(InvalidInputError, match="pip install ompl"):
        find_path(panda, wall, START, GOAL)


def test_one_joint_move_matches_the_trapezoid(panda):
    """Joint 4 alone over 2 rad: the fastest law is a trapezoid, d / v + v / a."""
    q0 = np.r_[0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -2.5, 0.0, 1.6, 0.785]
    q1 = q0.copy()
    q1[6] += 2.0
    timed = retime(panda, np.array([q0, q1]))
    v, a = panda.model.velocityLimit[3], panda.acceleration_limits[3]
    assert timed.duration == pytest.approx(2.0 / v + v / a, rel=0.02)
    assert timed.limiting in ("velocity of panda_joint4", "acceleration of panda_joint4")
    assert "panda_joint4" in timed.limiting


def test_retimed_path_keeps_the_limits_and_a_slower_robot_takes_longer(panda, wall):
    path = find_path(panda, wall, START, GOAL, 0.0, seed=0).q
    limits = KinematicLimits()
    vel, acc = limits.resolve(panda)
    timed = retime(panda, path, samples=4001)
    assert np.array_equal(timed.q[0], START) and np.allclose(timed.q[-1], GOAL)
    assert timed.t[0] == 0.0 and timed.t[-1] == pytest.approx(timed.duration)
    dt = timed.t[1] - timed.t[0]
    qd = np.diff(timed.q[:, 3:], axis=0) / dt
    qdd = np.diff(timed.q[:, 3:], 2, axis=0) / dt**2
    assert np.all(np.abs(qd) <= vel[3:] * 1.02)
    # toppra bounds the acceleration at its gridpoints only (timing.GRIDPOINTS): between them it
    # overshoots, by 2.5-15 % on the wall's paths of seeds 0-6 (1-2.5 % with 801 gridpoints)
    assert np.all(np.abs(qdd) <= acc[3:] * 1.15)
    assert np.max(np.abs(qd) / vel[3:]) > 0.9  # a limit is reached: time-optimal, not just slow
    slow = retime(panda, path, limits=KinematicLimits(arm_velocity=tuple(vel[3:] / 2)))
    assert slow.duration > timed.duration * 1.2
    stretched = retime(panda, path, margin=1.5)
    assert stretched.duration == pytest.approx(1.5 * timed.duration)
    assert timed.limiting.split(" of ")[0] in ("velocity", "acceleration")
    assert timed.limiting.split(" of ")[1] in panda.arm_joints


def test_a_segment_into_a_joint_limit_is_free_despite_round_off(panda, wall):
    """``a + (b - a) * 1.0`` rounds past ``b`` for some values (-0.7 to -2.8973: by 4e-16): a goal
    exactly at a joint's limit failed every dense segment check into it at its last state, and
    the repairs searched the same segment again (MotionBenchMaker's table_under_pick 0041)."""
    a, b = np.r_[START[:3], -0.7, START[4:]], np.r_[START[:3], panda.lower[0], START[4:]]
    assert -0.7 + (panda.lower[0] + 0.7) * 1.0 < panda.lower[0]  # the round-off this is about
    checker = StateChecker(panda, Scene((), None), 0.0)
    assert checker.valid(a) and checker.valid(b)
    assert segment_free(checker, a, b, DENSE_STEP) and segment_free(checker, b, a, DENSE_STEP)
    from forte.planning.search.validity import on_segment

    states = on_segment(a, b, np.linspace(0.0, 1.0, 7))
    assert np.array_equal(states[0], a) and np.array_equal(states[-1], b)
    assert np.allclose(states, a + np.linspace(0.0, 1.0, 7)[:, None] * (b - a), atol=1e-15)


def test_the_last_share_of_the_budget_goes_to_the_lazy_planner(panda, wall, monkeypatch):
    """RRT-Connect finds the way around the wall; with no share left to it, the lazy planner
    (LBKPIECE1) does, and its path passes the same dense check."""
    import forte.planning.search.sampling as sampling

    assert find_path(panda, wall, START, GOAL, 0.0, seed=0, checks=50_000, time_limit=60.0).planner == "RRTConnect"
    monkeypatch.setattr(sampling, "MARGIN_SHARE", 0.0)
    monkeypatch.setattr(sampling, "LAZY_SHARE", 0.0)
    result = find_path(panda, wall, START, GOAL, 0.0, seed=0, checks=50_000, time_limit=60.0)
    assert result.found and result.planner == sampling.LAZY == "LBKPIECE1"
    assert np.array_equal(result.q[0], START) and np.allclose(result.q[-1], GOAL)
    dense_checker = StateChecker(panda, wall, result.clearance)
    assert all(segment_free(dense_checker, a, b, DENSE_STEP) for a, b in zip(result.q[:-1], result.q[1:], strict=True))
    assert clearances(panda, wall, dense(result.q, 100)).distance.min() >= EXECUTION_MARGIN


def test_a_repair_that_returns_the_segment_it_was_sent_fails_at_once(panda, wall, monkeypatch):
    """A segment OMPL's motion check passes and the dense check fails comes back unchanged from
    its repair: the path fails then, instead of searching the same segment every round."""
    import forte.planning.search.sampling as sampling

    calls = []

    def same_segment(robot, checker, a, b, budget, share, seed, step, planner="RRTConnect"):
        calls.append(step)
        return np.array([a, b]), 1, 0.0

    monkeypatch.setattr(sampling, "_search", same_segment)
    budget = sampling._Budget(60.0, None)
    dense_checker = budget.checker(panda, wall, EXECUTION_MARGIN + SLIP, None)
    path, _, repairs = sampling._repaired(panda, dense_checker, np.array([START, GOAL]), budget, 0)
    assert path is None and repairs == 1 and calls == [DENSE_STEP]
