"""The broad phase: which robot-versus-scene pairs get clearance rows, and their slot parameters.

The optimizer's clearance rows (:mod:`forte.planning.nlp.collision_kernels`) are only written for
pairs that can come close: at each waypoint, a primitive of the robot's cover
(:mod:`forte.model.body_spheres`) and a scene body whose proxies are closer than the clearance
plus :data:`ACTIVATION` (m) on the trajectory the solve starts from, at that waypoint or the one
before. The planner re-runs the broad phase on the solution and solves again from it when the
solution brought a pair close that had no row (:func:`missing_pairs`).

Proxies of tilted bodies: the kernels take a proxy turned about z only (a yaw); a body whose z
axis is not vertical is replaced by the world-axis box around its proxy, which contains it.

The floor (:attr:`forte.model.scene.Scene.floor`) is the last body, its proxy
:func:`forte.model.scene.floor_proxy`; the primitives on the base frame (the base's capsules, the
arm's root link) rest on it and never pair with it (their distance is ``inf``).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from forte.model.body_spheres import BASE_FRAME, Primitive, primitive_centres, robot_primitives
from forte.model.scene import Proxy, Scene, floor_proxy, rounded_box_distance
from forte.planning.nlp.collision_kernels import SELF_FIELDS, SELF_SIZE, SLOT_BUCKETS, SLOT_FIELDS, SLOT_SIZE, bucket
from forte.planning.nlp.self_pairs import SELF_ACTIVATION, SELF_MARGIN, SELF_START_SLACK, self_distances, self_pairs
from forte.validation import FloatArray

#: A pair gets rows when its cover distance is below the clearance plus this (m).
ACTIVATION = 0.10


class FrameSlots(NamedTuple):
    """The clearance rows of one frame in one solve: ``slots`` per waypoint; ``values``
    (N x slots * slot size) their NLP parameters; ``keep`` (N x slots) the rows written into
    the NLP (one per slot: the chord from waypoint k - 1 to k); ``pairs``: ``(k, slot) ->
    (primitive, body)`` (a self pair's body: ``-1 - primitive``); ``other``: the second frame of
    self-collision slots, ``None`` for the scene."""

    frame: int
    slots: int
    values: FloatArray
    keep: FloatArray
    pairs: dict[tuple[int, int], tuple[int, int]]
    other: int | None = None


class Slots(NamedTuple):
    """The clearance rows of one solve, per frame that has any."""

    frames: tuple[FrameSlots, ...]

    @property
    def rows(self) -> int:
        return int(sum(f.keep.sum() for f in self.frames))

    def triples(self) -> set[tuple[int, int, int]]:
        """``(k, primitive, body)`` of every pair with rows (at ``k`` and ``k - 1``: the row keeps
        the chord between them)."""
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


def pair_distances(centres: FloatArray, primitives: tuple[Primitive, ...], proxies: list[Proxy],
                   cutoff: float = np.inf) -> FloatArray:
    """Cover distances (... x P x M) of primitives at ``centres`` (... x P x 3) to upright proxies:
    the numpy twin of :func:`forte.planning.nlp.collision_kernels.slot_distance` (all pairs at once).

    A body whose bounding sphere stays farther than ``cutoff`` (m) from the box around every
    primitive gets that lower bound instead (never above the true distance): the callers only
    compare distances with thresholds below their cutoff (the broad phase)."""
    if not proxies:
        return np.empty((*centres.shape[:-1], 0))
    if np.isfinite(cutoff):
        gap = _box_gap(centres, primitives, proxies)
        near = np.flatnonzero(gap < cutoff)
        size = np.array([[*proxies[m].half, proxies[m].rho, proxies[m].sigma] for m in near]).reshape(-1, 5)
        small = near[np.linalg.norm(size[:, :3], axis=1) + size[:, 3] + size[:, 4] < 1.0]
        if small.size > SPHERE_CULL_BODIES:  # many small bodies (a sensed scene's boxes): a k-d tree
            out = np.full((*centres.shape[:-1], len(proxies)), float(cutoff))  # a lower bound of the far ones too
            _culled(centres, primitives, proxies, small, cutoff, out.reshape(-1, len(proxies)))
            near = np.setdiff1d(near, small)
        else:
            out = np.broadcast_to(gap, (*centres.shape[:-1], len(proxies))).copy()
        if near.size:
            out[..., near] = pair_distances(centres, primitives, [proxies[m] for m in near])
        return out
    half_a = np.array([p.half_height for p in primitives])[:, None]
    radius = np.array([p.radius for p in primitives])[:, None]
    origin = np.array([p.pose[:3, 3] for p in proxies])  # M x 3
    c, s = np.array([p.pose[0, 0] for p in proxies]), np.array([p.pose[1, 0] for p in proxies])
    half = np.array([p.half for p in proxies])
    rho, sigma = np.array([p.rho for p in proxies]), np.array([p.sigma for p in proxies])
    d = centres[..., :, None, :] - origin  # ... x P x M x 3
    local = np.stack([c * d[..., 0] + s * d[..., 1], -s * d[..., 0] + c * d[..., 1],
                      d[..., 2] - np.clip(d[..., 2], -half_a, half_a)], axis=-1)  # a's nearest segment point
    return rounded_box_distance(local, half, rho, sigma) - radius


#: Above this many bodies near the motion (each within a 1 m bounding sphere), :func:`pair_distances`
#: finds each primitive's near bodies in a k-d tree of the bodies' centres instead of measuring every pair.
SPHERE_CULL_BODIES = 64


def _culled(centres: FloatArray, primitives: tuple[Primitive, ...], proxies: list[Proxy], bodies: FloatArray,
            cutoff: float, out: FloatArray) -> None:
    """Into ``out`` (primitive centres x proxies; the rest holds ``cutoff``): the exact distance to
    each of ``bodies`` (proxy indices) where the bounding spheres' gap ``|c - o| - (r + h) - (|half|
    + rho + sigma)`` may be below ``cutoff``: a primitive's candidates are the bodies whose centre
    ``o`` lies within ``cutoff + r + h + max(|half| + rho + sigma)`` of its centre ``c`` (scipy's
    k-d tree); every other pair's gap is at least ``cutoff``, which it keeps (a lower bound, as
    :func:`pair_distances` promises)."""
    from scipy.spatial import cKDTree

    flat = centres.reshape(-1, 3)
    n_prim = len(primitives)
    half_a = np.tile([p.half_height for p in primitives], len(flat) // n_prim)
    radius = np.tile([p.radius for p in primitives], len(flat) // n_prim)
    chosen = [proxies[b] for b in bodies]
    origin = np.array([p.pose[:3, 3] for p in chosen])
    cos, sin = np.array([p.pose[0, 0] for p in chosen]), np.array([p.pose[1, 0] for p in chosen])
    half = np.array([p.half for p in chosen])
    rho, sigma = np.array([p.rho for p in chosen]), np.array([p.sigma for p in chosen])
    size = np.linalg.norm(half, axis=1) + rho + sigma
    found = cKDTree(origin).query_ball_point(flat, cutoff + radius + half_a + size.max())
    i = np.repeat(np.arange(len(flat)), [len(f) for f in found])
    m = np.concatenate([np.asarray(f, dtype=np.int64) for f in found]) if len(i) else np.zeros(0, dtype=np.int64)
    d = flat[i] - origin[m]
    local = np.stack([cos[m] * d[:, 0] + sin[m] * d[:, 1], -sin[m] * d[:, 0] + cos[m] * d[:, 1],
                      d[:, 2] - np.clip(d[:, 2], -half_a[i], half_a[i])], axis=-1)
    out[i, bodies[m]] = rounded_box_distance(local, half[m], rho[m], sigma[m]) - radius[i]


def _box_gap(centres: FloatArray, primitives: tuple[Primitive, ...], proxies: list[Proxy]) -> FloatArray:
    """A lower bound (M) on every primitive's distance to each body: from the body's bounding
    sphere to the box around all the centres grown by the largest primitive."""
    reach = max(p.radius + p.half_height for p in primitives)
    points = centres.reshape(-1, 3)
    lo, hi = points.min(axis=0) - reach, points.max(axis=0) + reach
    origin = np.array([p.pose[:3, 3] for p in proxies])
    size = np.array([np.linalg.norm(p.half) + p.rho + p.sigma for p in proxies])
    return np.linalg.norm(np.maximum(np.maximum(lo - origin, origin - hi), 0), axis=1) - size


def body_proxies(scene: Scene) -> list[Proxy]:
    """The optimizer's bodies: the scene's upright proxies, then the floor's (when it has one)."""
    return [upright(p) for p in scene.proxies()] + ([] if scene.floor is None else [floor_proxy(scene.floor)])


def scene_distances(centres: FloatArray, primitives: tuple[Primitive, ...], scene: Scene,
                    cutoff: float = np.inf) -> FloatArray:
    """:func:`pair_distances` to :func:`body_proxies`, ``inf`` for the base frame's primitives
    against the floor (they rest on it)."""
    D = pair_distances(centres, primitives, body_proxies(scene), cutoff)
    if scene.floor is not None:
        D[..., [p.frame == BASE_FRAME for p in primitives], -1] = np.inf
    return D


def trajectory_distances(robot: object, q: FloatArray, scene: Scene, cutoff: float = np.inf
                         ) -> tuple[FloatArray, tuple[Primitive, ...]]:
    """Cover distances (N x P x M) along a trajectory (N x nq) to the scene's bodies and floor, and
    the primitives (``cutoff``: see :func:`pair_distances`)."""
    primitives = robot_primitives(robot)
    return scene_distances(_centres(robot, q, primitives), primitives, scene, cutoff), primitives


def _centres(robot: object, q: FloatArray, primitives: tuple[Primitive, ...]) -> FloatArray:
    return np.stack([primitive_centres(robot, qk, primitives) for qk in np.atleast_2d(q)])


def assign_slots(robot: object, q: FloatArray, scene: Scene, clearance: float, fix_initial: bool,
                 extra: set[tuple[int, int, int]] | None = None, clear: FloatArray | None = None) -> Slots:
    """Slots for the solve that starts from ``q`` (N x nq): the scene pairs within the clearance
    plus :data:`ACTIVATION`, the robot's own pairs (:func:`forte.planning.nlp.self_pairs.self_pairs`)
    within :data:`~forte.planning.nlp.self_pairs.SELF_ACTIVATION`; ``extra``: ``(k, primitive, body)``
    triples that must get rows (found on an earlier solution; a self pair's ``body`` is
    ``-1 - primitive``); ``clear``: a motion (N x nq) known clear of the scene on the exact
    geometry (a goal task's route), whose covers may overlap a body (the covers are thicker than
    the meshes: a grasp's fingers around an object): a scene pair keeps at waypoint k at most its
    cover distance there less :data:`START_OVERLAP_SLACK` (:func:`scene_margins`)."""
    primitives = robot_primitives(robot)
    centres = _centres(robot, q, primitives)
    D = scene_distances(centres, primitives, scene, clearance + 2 * ACTIVATION)
    kept = scene_margins(robot, scene, clearance, D.shape, clear, primitives)
    pairs_self = self_pairs(robot)
    S = self_distances(centres, primitives, pairs_self)
    margins = self_margins(S, fix_initial)
    n = D.shape[0]
    index_self = {pair: i for i, pair in enumerate(pairs_self)}
    near = [set(zip(*np.nonzero(D[k] < clearance + ACTIVATION), strict=True))
            | {(a, -1 - b) for a, b in np.asarray(pairs_self, dtype=int).reshape(-1, 2)[S[k] < SELF_ACTIVATION]}
            for k in range(n)]
    for k, p, m in extra or ():
        near[k].add((p, m))

    def score(k: int, p: int, m: int) -> float:
        values = D[:, p, m] if m >= 0 else S[:, index_self[(p, -1 - m)]]
        return float(min(values[k], values[k - 1] if k else np.inf))

    first = 1 if fix_initial and n > 1 else 0
    chosen: list[dict[tuple[int, int], list[tuple[float, int, int]]]] = []
    for k in range(n):
        groups: dict[tuple[int, int], list[tuple[float, int, int]]] = {}
        for p, m in (near[k] | (near[k - 1] if k else set())) if k >= first else set():
            key = (primitives[p].frame + 1, -1 if m >= 0 else primitives[-1 - m].frame + 1)
            groups.setdefault(key, []).append((score(k, int(p), int(m)), int(p), int(m)))
        chosen.append(groups)
    proxies = body_proxies(scene)
    frames = []
    for key in sorted({key for groups in chosen for key in groups}):
        size = min(bucket(max(len(groups.get(key, ())) for groups in chosen)), SLOT_BUCKETS[-1])
        width = SLOT_SIZE if key[1] < 0 else SELF_SIZE
        values = np.zeros((n, size * width))
        keep = np.zeros((n, size), dtype=bool)
        pairs = {}
        for k, groups in enumerate(chosen):
            for j, (_, p, m) in enumerate(sorted(groups.get(key, ()))[:size]):
                values[k, j * width:(j + 1) * width] = _slot(primitives[p], proxies[m], kept[k, p, m]) if m >= 0 \
                    else _self_slot(primitives[p], primitives[-1 - m], margins[index_self[(p, -1 - m)]])
                keep[k, j] = True
                pairs[(k, j)] = (p, m)
        frames.append(FrameSlots(key[0], size, values, keep, pairs, None if key[1] < 0 else key[1]))
    return Slots(tuple(frames))


def scene_margins(robot: object, scene: Scene, clearance: float, shape: tuple[int, ...], clear: FloatArray | None,
                  primitives: tuple[Primitive, ...]) -> FloatArray:
    """The cover distance each scene pair keeps at each waypoint (N x primitives x bodies): the
    clearance, or where a motion ``clear`` of the scene (exact geometry) would break its rows, what
    it keeps there less :data:`START_OVERLAP_SLACK` (see :func:`assign_slots`).

    A slot at waypoint ``k`` asks ``D(x_mid) >= m + |Δ_k| / 2`` at the midpoint ``x_mid`` of the
    primitive's chord from waypoint ``k - 1`` to ``k`` (:mod:`~forte.planning.nlp.collision_kernels`),
    so the motion meets it with ``m_k = D(x_mid) - |Δ_k| / 2``, ``D`` its cover distance and
    ``|Δ_k|`` how far the primitive moves between the two waypoints (at the first waypoint: its
    own distance): ``m`` is the clearance or that, less the slack, whichever is smaller. Covers
    are up to ~12 % thicker than the meshes and a route through a cage moves a link 7-23 cm per
    waypoint on 30 waypoints: with the clearance alone the route
    broke ~200 of its rows by up to 14 cm (MotionBenchMaker's cage, table_under_pick), and IPOPT,
    started there, ran out of iterations or called the problem infeasible. The verdict checks
    the exact clearance of what the NLP returns."""
    kept = np.full(shape, float(clearance))
    if clear is not None and len(clear) == shape[0]:
        centres = _centres(robot, clear, primitives)
        before = np.concatenate([centres[:1], centres[:-1]])  # the first waypoint's chord: itself
        middle = scene_distances(0.5 * (centres + before), primitives, scene, clearance + ACTIVATION)
        step = np.linalg.norm(centres - before, axis=-1)  # N x P
        kept = np.minimum(kept, middle - 0.5 * step[..., None] - START_OVERLAP_SLACK)
    return kept


def _slot(primitive: Primitive, proxy: Proxy, clearance: float) -> FloatArray:
    v = np.zeros(SLOT_SIZE)
    fields = {"centre_a": primitive.centre, "half_a": [primitive.half_height], "radius_a": [primitive.radius],
              "origin": proxy.pose[:3, 3], "yaw": [proxy.pose[0, 0], proxy.pose[1, 0]], "half": proxy.half,
              "rho": [proxy.rho], "sigma": [proxy.sigma], "margin": [clearance], "active": [1.0]}
    for name, value in fields.items():
        offset, size = SLOT_FIELDS[name]
        v[offset:offset + size] = value
    return v


#: A pair of the robot's own covers that overlaps at a fixed start keeps, as its margin, its start
#: distance less this (m): it may not come much closer than it starts.
START_OVERLAP_SLACK = 0.002


def self_margins(S: FloatArray, fix_initial: bool) -> FloatArray:
    """Per self pair: the cover distance it keeps, :data:`~forte.planning.nlp.self_pairs.SELF_MARGIN`,
    or, for a pair whose covers already overlap at the fixed start (``S[0]``: its distance there;
    a cover is up to ~12 % thicker than the mesh, so the meshes may well be apart), its start
    distance less :data:`~forte.planning.nlp.self_pairs.SELF_START_SLACK`, so the plan does not push the
    two further into each other. ``S``: N x pairs."""
    margins = np.full(S.shape[1], SELF_MARGIN)
    if fix_initial and len(S):
        margins = np.minimum(margins, S[0] - SELF_START_SLACK)
    return margins


def missing_pairs(robot: object, q: FloatArray, scene: Scene, clearance: float, slots: Slots,
                  tol: float = 1e-4, fix_initial: bool = True) -> set[tuple[int, int, int]]:
    """``(k, primitive, body)`` triples closer than their margin at ``q`` without a row (the
    scene's: the clearance; the robot's own pairs: :func:`self_margins`, as :func:`assign_slots`
    gives them for the same ``fix_initial``)."""
    primitives = robot_primitives(robot)
    centres = _centres(robot, q, primitives)
    D = scene_distances(centres, primitives, scene, clearance + ACTIVATION)
    pairs_self = np.asarray(self_pairs(robot), dtype=int).reshape(-1, 2)
    S = self_distances(centres, primitives, self_pairs(robot))
    have = slots.triples()
    found = {(int(k), int(p), int(m)) for k, p, m in zip(*np.nonzero(D < clearance - tol), strict=True)}
    found |= {(int(k), int(pairs_self[i, 0]), -1 - int(pairs_self[i, 1]))
              for k, i in zip(*np.nonzero(S < self_margins(S, fix_initial) - tol), strict=True)}
    return found - have


def _self_slot(a: Primitive, b: Primitive, margin: float = SELF_MARGIN) -> FloatArray:
    v = np.zeros(SELF_SIZE)
    fields = {"centre_a": a.centre, "radius_a": [a.radius], "centre_b": b.centre, "half_b": [b.half_height],
              "radius_b": [b.radius], "margin": [margin], "active": [1.0]}
    for name, value in fields.items():
        offset, size = SELF_FIELDS[name]
        v[offset:offset + size] = value
    return v
