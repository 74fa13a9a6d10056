"""The broad phase: which robot-versus-scene pairs get clearance rows, and their slot parameters.

The optimizer's clearance rows (:mod:`forte.planning.collision_kernels`) are only written for
pairs that can come close: at each waypoint, a primitive of the robot's cover
(:mod:`forte.model.body_spheres`) and a scene body whose proxies are closer than the clearance
plus :data:`ACTIVATION` (m) on the trajectory the solve starts from, at that waypoint or the one
before. The planner re-runs the broad phase on the solution and solves again from it when the
solution brought a pair close that had no row (:func:`missing_pairs`).

Proxies of tilted bodies: the kernels take a proxy turned about z only (a yaw); a body whose z
axis is not vertical is replaced by the world-axis box around its proxy, which contains it.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from forte.model.body_spheres import Primitive, primitive_centres, robot_primitives
from forte.model.scene import Proxy, Scene
from forte.planning.collision_kernels import SLOT_BUCKETS, SLOT_FIELDS, SLOT_SIZE, bucket
from forte.validation import FloatArray

#: A pair gets rows when its cover distance is below the clearance plus this (m).
ACTIVATION = 0.10


class FrameSlots(NamedTuple):
    """The clearance rows of one frame in one solve: ``slots`` per waypoint; ``values``
    (N x slots * SLOT_SIZE) their NLP parameters; ``keep`` (N x 2 slots) the rows written into
    the NLP; ``pairs``: ``(k, slot) -> (primitive, body)``."""

    frame: int
    slots: int
    values: FloatArray
    keep: FloatArray
    pairs: dict[tuple[int, int], tuple[int, int]]


class Slots(NamedTuple):
    """The clearance rows of one solve, per frame that has any."""

    frames: tuple[FrameSlots, ...]

    @property
    def rows(self) -> int:
        return int(sum(f.keep.sum() for f in self.frames))

    def triples(self) -> set[tuple[int, int, int]]:
        """``(k, primitive, body)`` of every pair with rows (at ``k`` and, through the interval's
        second row, ``k - 1``)."""
        out = set()
        for f in self.frames:
            for (k, _), (p, m) in f.pairs.items():
                out |= {(k, p, m), (k - 1, p, m)}
        return out


def upright(proxy: Proxy) -> Proxy:
    """``proxy`` turned about z only: itself when its z axis is vertical, else its world box."""
    R = proxy.pose[:3, :3]
    if abs(R[2, 2]) > 1 - 1e-9:
        if R[2, 2] > 0:
            return proxy
        flip = np.diag([1.0, -1.0, -1.0])  # upside down: same body, z axis turned up
        pose = proxy.pose.copy()
        pose[:3, :3] = R @ flip
        return Proxy(pose, proxy.half, proxy.rho, proxy.sigma)
    corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * proxy.half
    world = corners @ R.T
    pose = np.eye(4)
    pose[:3, 3] = proxy.pose[:3, 3]
    half = np.abs(world).max(axis=0) + proxy.rho + proxy.sigma
    return Proxy(pose, half, 0.0, 0.0)


def pair_distances(centres: FloatArray, primitives: tuple[Primitive, ...], proxies: list[Proxy]) -> FloatArray:
    """Cover distances (... x P x M) of primitives at ``centres`` (... x P x 3) to upright proxies:
    the numpy twin of :func:`forte.planning.collision_kernels.slot_distance`."""
    half_a = np.array([p.half_height for p in primitives])
    radius = np.array([p.radius for p in primitives])
    out = np.empty((*centres.shape[:-1], len(proxies)))
    for m, proxy in enumerate(proxies):
        d = centres - proxy.pose[:3, 3]
        c, s = proxy.pose[0, 0], proxy.pose[1, 0]
        local = np.stack([c * d[..., 0] + s * d[..., 1], -s * d[..., 0] + c * d[..., 1],
                          d[..., 2] - np.clip(d[..., 2], -half_a, half_a)], axis=-1)
        q = np.abs(local[..., :2]) - proxy.half[:2]
        a = np.linalg.norm(np.maximum(q, 0), axis=-1) + np.minimum(q.max(axis=-1), 0) - proxy.rho
        b = np.abs(local[..., 2]) - proxy.half[2]
        ab = np.stack([a, b], axis=-1)
        out[..., m] = np.linalg.norm(np.maximum(ab, 0), axis=-1) + np.minimum(ab.max(axis=-1), 0) - proxy.sigma
    return out - radius[:, None]


def trajectory_distances(robot: object, q: FloatArray, scene: Scene) -> tuple[FloatArray, tuple[Primitive, ...]]:
    """Cover distances (N x P x M) along a trajectory (N x nq) and the primitives."""
    primitives = robot_primitives(robot)
    centres = np.stack([primitive_centres(robot, qk, primitives) for qk in np.atleast_2d(q)])
    return pair_distances(centres, primitives, [upright(p) for p in scene.proxies()]), primitives


def assign_slots(robot: object, q: FloatArray, scene: Scene, clearance: float, fix_initial: bool,
                 extra: set[tuple[int, int, int]] | None = None) -> Slots:
    """Slots for the solve that starts from ``q`` (N x nq); ``extra``: ``(k, primitive, body)``
    triples that must get rows (found on an earlier solution)."""
    D, primitives = trajectory_distances(robot, q, scene)
    n = D.shape[0]
    near = [set(zip(*np.nonzero(D[k] < clearance + ACTIVATION), strict=True)) for k in range(n)]
    for k, p, m in extra or ():
        near[k].add((p, m))
    first = 1 if fix_initial and n > 1 else 0
    chosen: list[dict[int, list[tuple[float, int, int]]]] = []
    for k in range(n):
        pairs = near[k] | (near[k - 1] if k else set()) if k >= first else set()
        by_frame: dict[int, list[tuple[float, int, int]]] = {}
        for p, m in pairs:
            score = min(D[k, p, m], D[k - 1, p, m] if k else np.inf)
            by_frame.setdefault(primitives[p].frame + 1, []).append((score, int(p), int(m)))
        chosen.append(by_frame)
    proxies = [upright(p) for p in scene.proxies()]
    frames = []
    for frame in range(robot.n_arm + 1):
        most = max((len(by.get(frame, ())) for by in chosen), default=0)
        if most == 0:
            continue
        size = min(bucket(most), SLOT_BUCKETS[-1])
        values = np.zeros((n, size * SLOT_SIZE))
        keep = np.zeros((n, 2 * size), dtype=bool)
        pairs = {}
        for k, by_frame in enumerate(chosen):
            for j, (_, p, m) in enumerate(sorted(by_frame.get(frame, ()))[:size]):
                values[k, j * SLOT_SIZE:(j + 1) * SLOT_SIZE] = _slot(primitives[p], proxies[m], clearance)
                keep[k, 2 * j] = True
                keep[k, 2 * j + 1] = n > 1  # one waypoint (holding): no interval, one row
                pairs[(k, j)] = (p, m)
        frames.append(FrameSlots(frame, size, values, keep, pairs))
    return Slots(tuple(frames))


def _slot(primitive: Primitive, proxy: Proxy, clearance: float) -> FloatArray:
    v = np.zeros(SLOT_SIZE)
    fields = {"centre_a": primitive.centre, "half_a": [primitive.half_height], "radius_a": [primitive.radius],
              "origin": proxy.pose[:3, 3], "yaw": [proxy.pose[0, 0], proxy.pose[1, 0]], "half": proxy.half,
              "rho": [proxy.rho], "sigma": [proxy.sigma], "margin": [clearance], "active": [1.0]}
    for name, value in fields.items():
        offset, size = SLOT_FIELDS[name]
        v[offset:offset + size] = value
    return v


def missing_pairs(robot: object, q: FloatArray, scene: Scene, clearance: float, slots: Slots,
                  tol: float = 1e-4) -> set[tuple[int, int, int]]:
    """``(k, primitive, body)`` triples closer than the clearance at ``q`` without a row."""
    D, _ = trajectory_distances(robot, q, scene)
    have = slots.triples()
    out = set()
    for k, p, m in zip(*np.nonzero(D < clearance - tol), strict=True):
        if (int(k), int(p), int(m)) not in have:
            out.add((int(k), int(p), int(m)))
    return out

