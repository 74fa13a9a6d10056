"""The robot's own pairs of primitives that the optimizer keeps apart (self-collision).

The same cover as for the scene (:mod:`forte.model.body_spheres`), so an arm other than the
Panda gets it from its URDF's meshes alone. Which pairs count:

- two arm pieces when neither the rule "not the same or adjacent links" nor the robot's SRDF
  leaves their meshes out (:class:`forte.model.self_collision.ArmGeometry`);
- an arm piece and the base, unless the piece hangs on the base too (the arm's root link);
- never two pieces on the same frame or on a joint and its parent joint (adjacent links move
  about one joint axis, their distance barely changes, and URDF meshes of adjacent links
  usually overlap);
- minus every pair whose covers are always in contact: closer than :data:`HOME_GAP` at the
  home configuration and at each of :data:`CONTACT_SAMPLES` postures drawn within the joint
  limits (a fixed seed). Such a pair's cover is coarser than the gap between its meshes wherever
  the arm goes (a cover is up to ~12 % thicker than a capsule around the mesh), and a row would
  forbid every posture. The verdict checks those pairs on the real meshes all the same (its
  ``self_collision`` requirement).

A pair whose covers overlap only at some postures keeps its rows: at a fixed start where they
overlap it keeps its start distance
(:func:`~forte.planning.nlp.collision_slots.self_margins`), elsewhere :data:`SELF_MARGIN`.
Filtering at ``robot.home()`` instead dropped pairs that are apart at the user's start: a raw
URDF's home is the all-zeros posture, where 5 of the raw TIAGo's 12 ``arm_1_link`` /
``torso_fixed_column_link`` pairs overlap, and the arm then ran through the column.

A pair keeps :data:`SELF_MARGIN` between its covers: the covers contain the meshes, so covers
apart means meshes apart.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from forte.model.body_spheres import BASE_FRAME, Primitive, primitive_centres, robot_primitives
from forte.model.self_collision import link_of
from forte.validation import FloatArray

#: A self pair gets rows when its covers come closer than this (m) on the start trajectory.
SELF_ACTIVATION = 0.05
#: The distance (m) kept between two covers of the robot's own pieces.
SELF_MARGIN = 0.0
#: Pairs whose covers are closer than this (m) at home and at every sampled posture are left to
#: the verdict (always in contact).
HOME_GAP = 0.01
#: How many postures within the joint limits (beside home) a pair must overlap at to count as
#: always in contact.
CONTACT_SAMPLES = 32
#: A pair whose covers overlap at a fixed start keeps its start distance less this (m)
#: (:func:`~forte.planning.nlp.collision_slots.self_margins`). Its rows ask
#: ``D(q_k), D(q_{k-1}) >= margin + |Δ_k| / 2`` (``|Δ_k|``: how far the two primitives move
#: relative to each other over the interval), and in the first interval ``D(q_0)`` is the start
#: distance: the pair may move ``2 x`` this relative to each other there, and in every later interval
#: no more than that beyond twice what it has moved apart. With 2 mm (the scene's
#: :data:`~forte.planning.nlp.collision_slots.START_OVERLAP_SLACK`) a raw TIAGo tucked at the start
#: (259 of its pairs overlapping, by up to 28 cm) could move its hand 4 mm per interval along its
#: torso: the self-row solve of a 0.1 m down reach (41 samples) ran out of its 120 s budget at
#: 346 iterations, its constraint violation stuck at 0.07-0.09 through restoration phases; with
#: 1 cm it converged (291 iterations). The verdict checks the meshes all the same.
SELF_START_SLACK = 0.01

_CACHE: dict[str, tuple[tuple[int, int], ...]] = {}


def self_distances(centres: FloatArray, primitives: tuple[Primitive, ...],
                   pairs: tuple[tuple[int, int], ...]) -> FloatArray:
    """Cover distances (... x len(pairs)) of primitive pairs ``(a, b)`` at ``centres`` (... x P x 3):
    sphere ``a`` against ``b``'s vertical segment, both swollen by their radii (the numpy twin of
    :func:`forte.planning.nlp.collision_kernels.self_distance`)."""
    if not pairs:
        return np.zeros((*centres.shape[:-2], 0))
    a, b = np.asarray(pairs, dtype=int).T
    half = np.array([primitives[i].half_height for i in b])
    radius = np.array([primitives[i].radius for i in a]) + np.array([primitives[i].radius for i in b])
    d = centres[..., a, :] - centres[..., b, :]
    dz = d[..., 2] - np.clip(d[..., 2], -half, half)
    return np.sqrt(d[..., 0] ** 2 + d[..., 1] ** 2 + dz**2) - radius


def self_pairs(robot: Any) -> tuple[tuple[int, int], ...]:
    """Primitive pairs ``(a, b)`` kept apart (module docstring), ``a`` on the later frame; cached."""
    key = robot.fingerprint + str(robot.urdf_path)
    if key not in _CACHE:
        _CACHE[key] = _pairs(robot)
    return _CACHE[key]


def _pairs(robot: Any) -> tuple[tuple[int, int], ...]:
    from forte.model.self_collision import arm_geometry

    primitives = robot_primitives(robot)
    geometry = arm_geometry(robot)
    allowed: set[frozenset[str]] = set()
    if geometry is not None:
        objs = geometry.geom.geometryObjects
        allowed = {frozenset((link_of(objs[p.first].name), link_of(objs[p.second].name)))
                   for p in geometry.geom.collisionPairs}
    parent = {j: int(robot.model.parents[j + 1]) - 1 for j in range(robot.n_arm)}  # BASE_FRAME: on the base
    candidates = []
    for i, a in enumerate(primitives):
        for j, b in enumerate(primitives):
            if a.frame <= b.frame or a.frame == BASE_FRAME or parent[a.frame] == b.frame:
                continue
            if (b.piece == "base") or frozenset((a.piece, b.piece)) in allowed:
                candidates.append((i, j))
    if not candidates:
        return ()
    gaps = np.stack([self_distances(primitive_centres(robot, q, primitives), primitives, tuple(candidates))
                     for q in contact_postures(robot)])
    return tuple(pair for pair, apart in zip(candidates, np.any(gaps >= HOME_GAP, axis=0), strict=True) if apart)


def contact_postures(robot: Any) -> FloatArray:
    """Home and :data:`CONTACT_SAMPLES` postures (base at the origin, arm joints uniform within
    their limits, ``[-pi, pi]`` where a limit is infinite; seed 0) at which a pair must overlap
    to count as always in contact."""
    lower, upper = (np.where(np.isfinite(x), x, s * np.pi) for x, s in ((robot.lower, -1), (robot.upper, 1)))
    arm = np.random.default_rng(0).uniform(lower, upper, (CONTACT_SAMPLES, robot.n_arm))
    home = robot.home()
    return np.vstack([home, np.hstack([np.zeros((CONTACT_SAMPLES, home.size - robot.n_arm)), arm])])
