"""A start for the whole-body solve that keeps clear of the scene: where to put the base.

The path fixes the end effector, so the base is what can go around a body. When the usual
start (inverse kinematics along the path, :func:`forte.planning.tasks.ik.initial_guess`) brings the
robot's cover (:mod:`forte.model.body_spheres`) within the clearance of a body, this module
searches for base poses instead:

1. **Candidates.** At every waypoint near one where the usual start comes close to a body
   (:data:`WINDOW`), base poses on rings around the end effector's target
   (:data:`RINGS` radii x :data:`ANGLES` directions, the base facing the target), plus the usual
   start's own configuration. For each, the arm's inverse kinematics with the base held (the
   same damped least squares, seeded with the usual start's arm) gives the arm; a candidate is
   kept when it reaches the pose and its cover keeps the clearance from every body. Elsewhere
   the usual start is the only candidate.
2. **A path through them.** Dynamic programming over the waypoints picks one candidate each,
   from the fixed first configuration, minimizing ``sum |Δ base xy|^2 + 0.1 Δyaw^2 + 0.1 |Δ arm|^2``
   plus ``0.05`` times the squared distance of the base from the usual start's (yaw at 0.1),
   with base steps no longer than :data:`MAX_BASE_STEP` between waypoints.

Returns ``None`` when some waypoint has no clear candidate or no chain connects them; the
solve then starts from the usual start and the optimizer has to push out of the bodies.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin

from forte.model.robot import N_BASE
from forte.planning.nlp.collision_slots import trajectory_distances
from forte.validation import FloatArray

#: Distances (m) of the base from the end effector's target, and directions, of the candidates.
RINGS = (0.45, 0.6, 0.75, 0.9)
ANGLES = 24
#: Longest base step (m) between consecutive waypoints of a chain: the candidates are ~0.2-0.4 m
#: apart on a ring, and the whole-body solve smooths the steps into the velocity limits.
MAX_BASE_STEP = 0.5

#: Candidates are searched at the waypoints within WINDOW of one where the usual start comes
#: within the clearance plus WINDOW_DISTANCE (m) of a body.
WINDOW = 8
WINDOW_DISTANCE = 0.05



def clear_start(task: Any, guess: FloatArray) -> FloatArray | None:
    """A start clear of ``task.scene`` (see the module docstring), ``guess`` when it is clear
    already, or ``None``."""
    D, _ = trajectory_distances(task.robot, guess, task.scene, task.clearance + WINDOW_DISTANCE + 0.05)
    if D.min() >= task.clearance:
        return guess
    fixed_first = task.mode != "hold"
    close = np.flatnonzero(D.min(axis=(1, 2)) < task.clearance + WINDOW_DISTANCE)
    near = np.zeros(len(guess), dtype=bool)
    for k in close:  # search around the waypoints that come close; elsewhere keep the usual start
        near[max(k - WINDOW, 0):k + WINDOW + 1] = True
    seeds: dict[int, FloatArray] = {}  # each ring position's last arm: the next waypoint's IK starts there
    candidates = [_candidates(task, k, guess, (fixed_first and k == 0) or not near[k], seeds)
                  for k in range(len(guess))]
    if any(not c for c in candidates):
        return None
    return _chain(task, candidates, guess)


def _candidates(task: Any, k: int, guess: FloatArray, only_guess: bool,
                seeds: dict[int, FloatArray]) -> list[FloatArray]:
    robot, target = task.robot, task.targets[k]
    tries = [guess[k]]
    if not only_guess:
        angles = np.tile(np.linspace(-np.pi, np.pi, ANGLES, endpoint=False), len(RINGS))
        radii = np.repeat(RINGS, ANGLES)
        starts = np.column_stack([target[0, 3] - radii * np.cos(angles), target[1, 3] - radii * np.sin(angles),
                                  angles])
        for i in np.flatnonzero(_base_clear(task, starts)):  # the arm's IK only where the base fits
            in_base = np.linalg.inv(robot.base_transform(starts[i])) @ target
            arm = _arm_ik(robot, in_base, seeds.get(int(i), guess[k, N_BASE:]))
            if arm is not None:
                seeds[int(i)] = arm
                tries.append(np.concatenate([starts[i], arm]))
    tries = np.array(tries)
    D, _ = trajectory_distances(robot, tries, task.scene, task.clearance + 0.05)
    clear = D.min(axis=(1, 2)) >= task.clearance + 0.01
    if only_guess:  # the fixed first configuration, or a waypoint far from every body
        return [tries[0]] if clear[0] or k == 0 else []
    return list(tries[clear])


def _arm_ik(robot: Any, target: FloatArray, seed: FloatArray, iterations: int = 30) -> FloatArray | None:
    """The arm reaching ``target`` (base frame) from ``seed`` by damped least squares (the same
    step as :func:`forte.planning.tasks.ik.solve_pose`, the base held, without its per-call checks), or
    ``None`` when it stays more than 1 mm / 0.01 rad away (the whole-body solve refines it)."""
    model, data, frame = robot.model, robot.data, robot.ee_frame_id
    q = seed.copy()
    goal = pin.SE3(target[:3, :3].copy(), target[:3, 3].copy())
    damping = 1e-6 * np.eye(6)
    err = np.empty(6)
    for _ in range(iterations):
        pin.framesForwardKinematics(model, data, q)
        current = data.oMf[frame]
        err[:3] = goal.translation - current.translation
        err[3:] = pin.log3(goal.rotation @ current.rotation.T)
        if err @ err < 1e-12:
            break
        J = pin.computeFrameJacobian(model, data, q, frame, pin.LOCAL_WORLD_ALIGNED)
        q = np.clip(q + J.T @ np.linalg.solve(J @ J.T + damping, err), robot.lower, robot.upper)
    pin.framesForwardKinematics(model, data, q)
    current = data.oMf[frame]
    if np.linalg.norm(goal.translation - current.translation) > 1e-3 or \
            np.linalg.norm(pin.log3(goal.rotation @ current.rotation.T)) > 1e-2:
        return None
    return q


def _base_clear(task: Any, starts: FloatArray) -> FloatArray:
    """Which base poses keep the base's own cover clear of every body (no kinematics needed)."""
    from forte.model.body_spheres import BASE_FRAME, robot_primitives
    from forte.planning.nlp.collision_slots import pair_distances, upright

    base = tuple(p for p in robot_primitives(task.robot) if p.frame == BASE_FRAME and p.piece == "base")
    local = np.array([p.centre for p in base])
    c, s = np.cos(starts[:, 2]), np.sin(starts[:, 2])
    world = np.stack([starts[:, None, 0] + c[:, None] * local[:, 0] - s[:, None] * local[:, 1],
                      starts[:, None, 1] + s[:, None] * local[:, 0] + c[:, None] * local[:, 1],
                      np.broadcast_to(local[:, 2], (len(starts), len(base)))], axis=-1)
    D = pair_distances(world, base, [upright(p) for p in task.scene.proxies()], task.clearance + 0.05)
    return D.min(axis=(1, 2)) >= task.clearance + 0.01


def _chain(task: Any, candidates: list[list[FloatArray]], guess: FloatArray) -> FloatArray | None:
    cost = [np.zeros(len(candidates[0]))]
    back: list[FloatArray] = []
    for k in range(1, len(candidates)):
        prev, now = np.array(candidates[k - 1]), np.array(candidates[k])
        step = np.linalg.norm(now[None, :, :2] - prev[:, None, :2], axis=2)
        yaw = np.angle(np.exp(1j * (now[None, :, 2] - prev[:, None, 2])))
        arm = np.linalg.norm(now[None, :, N_BASE:] - prev[:, None, N_BASE:], axis=2)
        away = now[:, :2] - guess[k, :2]  # stay near the usual start where the scene allows
        turn = np.angle(np.exp(1j * (now[:, 2] - guess[k, 2])))
        total = cost[-1][:, None] + step**2 + 0.1 * yaw**2 + 0.1 * arm**2 \
            + 0.05 * ((away**2).sum(axis=1) + 0.1 * turn**2)[None, :]
        total[step > MAX_BASE_STEP] = np.inf
        back.append(np.argmin(total, axis=0))
        cost.append(total.min(axis=0))
    if not np.isfinite(cost[-1]).any():
        return None
    out = np.empty((len(candidates), task.robot.nq))
    j = int(np.argmin(cost[-1]))
    for k in range(len(candidates) - 1, -1, -1):
        out[k] = candidates[k][j]
        if k:
            j = int(back[k - 1][j])
    out[:, 2] = np.unwrap(out[:, 2])
    return out
