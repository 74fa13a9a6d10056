"""The rows of a scene round after a solution that brought pairs close without rows
(:func:`forte.planning.scene.scene_solve.next_pairs`): the missing pairs, the old rows' pairs, and
every scene pair near the solution, measured here on the cover distances directly."""

from __future__ import annotations

import numpy as np

from forte.planning.nlp.collision_slots import ACTIVATION, assign_slots, trajectory_distances
from forte.planning.scene.scene_solve import next_pairs
from forte.planning.tasks.tasks import task_from_dict

PANDA = {"urdf": "erd:panda_description/urdf/panda.urdf", "ee_frame": "panda_hand", "base": "fixed"}
START = [0, 0, 0, -1.0, 0.3, 0.0, -1.8, 0.0, 2.1, 0.785]
GOAL = [0, 0, 0, 1.0, 0.3, 0.0, -1.8, 0.0, 2.1, 0.785]


def crate_task(y: float) -> object:
    return task_from_dict({
        "robot": PANDA, "initial_configuration": START, "clearance": 0.01, "floor": "none",
        "path": {"kind": "goal", "configuration": GOAL, "samples": 8},
        "scene": [{"name": "crate", "box": {"size": [0.3, 0.3, 0.3]}, "pose": [0.45, y, 0.35, 0, 0, 0]}]})


def test_the_next_round_covers_every_scene_pair_near_the_solution():
    task = crate_task(0.0)
    q = task.goal.motion(task.q_init, task.t)  # the straight line sweeps the hand past the crate
    D, _ = trajectory_distances(task.robot, q, task.scene)
    near = {(int(k), int(p), int(m)) for k, p, m in zip(*np.nonzero(D < task.clearance + ACTIVATION), strict=True)
            if k > 0}  # the fixed first waypoint has no rows
    assert near  # the motion passes the crate
    away = np.tile(START, (task.n, 1))
    away[:, 3] = -2.5  # the arm turned away from the crate: another motion's rows
    old = assign_slots(task.robot, away, task.scene, task.clearance, True)
    missing = {(3, 0, 0)}
    assert not near <= missing | old.triples()  # the pairs near q come from q itself
    found = next_pairs(task, q, old, missing, True)
    assert near <= found and missing <= found and old.triples() <= found


def test_far_from_every_body_the_next_round_adds_no_scene_pair():
    task = crate_task(3.0)  # the crate 3 m to the side: no pair within reach
    q = task.goal.motion(task.q_init, task.t)
    D, _ = trajectory_distances(task.robot, q, task.scene)
    assert D.min() > task.clearance + ACTIVATION
    empty = assign_slots(task.robot, q, task.scene, task.clearance, True)
    found = next_pairs(task, q, empty, {(2, 1, 0)}, True)
    assert {t for t in found if t[2] >= 0} == {(2, 1, 0)}  # scene pairs: the missing one only
