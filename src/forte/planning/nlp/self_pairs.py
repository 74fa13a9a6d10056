"""The robot's own pairs of primitives that the optimizer keeps apart (self-collision).

The same cover as for the scene (:mod:`forte.model.body_spheres`), so an arm other than the
Panda gets it from its URDF's meshes alone. Which pairs count:

- two arm pieces when the robot's SRDF (or, without one, the rule "not the same or adjacent
  links") lets their meshes collide (:class:`forte.model.self_collision.ArmGeometry`);
- an arm piece and the base, unless the piece hangs on the base too (the arm's root link);
- never two pieces on the same frame or on a joint and its parent joint (adjacent links move
  about one joint axis, their distance barely changes, and URDF meshes of adjacent links
  usually overlap);
- minus every pair whose covers overlap at the robot's home configuration: there the cover is
  coarser than the gap between the meshes (a cover is up to ~12 % thicker than a capsule around
  the mesh), and a row would forbid a posture the robot takes. The verdict checks those pairs on
  the real meshes all the same (its ``self_collision`` requirement).

A pair keeps :data:`SELF_MARGIN` between its covers: the covers contain the meshes, so covers
apart means meshes apart.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from forte.model.body_spheres import BASE_FRAME, Primitive, link_of, primitive_centres, robot_primitives
from forte.validation import FloatArray

#: A self pair gets rows when its covers come closer than this (m) on the start trajectory.
SELF_ACTIVATION = 0.05
#: The distance (m) kept between two covers of the robot's own pieces.
SELF_MARGIN = 0.0
#: Pairs whose covers are closer than this (m) at home are left to the verdict.
HOME_GAP = 0.01

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
    home = primitive_centres(robot, robot.home(), primitives)
    gaps = self_distances(home, primitives, tuple(candidates))
    return tuple(pair for pair, gap in zip(candidates, gaps, strict=True) if gap >= HOME_GAP)
