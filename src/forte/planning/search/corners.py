"""A route's time law that keeps its path's clearance at the path's corners.

toppra's law (:func:`~forte.planning.search.timing.retime`) follows a cubic spline through knots
at most :data:`~forte.planning.search.timing.KNOT_STEP` apart on the path's segments. Where the
shortcut path turns (a *corner*: a vertex whose two segments are not collinear) the spline cuts
inside the turn, off the path the search checked: on MotionBenchMaker's cage 0029 the path keeps
3.1 mm at its states and the law comes within 0.28 mm (a waypoint of the route at 1.4 mm < the
verdict's 2 mm), so neither the route nor the NLP plan started from it was feasible.

The path keeps its kept clearance ``c`` (:func:`~forte.planning.search.sampling.kept`) at every state
:data:`~forte.planning.search.sampling.DENSE_STEP` apart; the law must keep ``c - SLIP`` (what the
path itself may lose between two checked states). Where a sample of the law keeps less, the
corner nearest to it gets two knots, on its two segments at distance ``delta`` from the vertex, and
the law is timed again: a spline through three points ``delta`` apart on the two segments turns
within ``~delta`` of the vertex. ``delta`` is ``KNOT_STEP / 2, / 4, / 8`` over at most
:data:`CORNER_ROUNDS` rounds, each round adding the corners near its own dips to the former ones.
The knots lie on the checked segments, so they keep the path's clearance; a sharper turn makes
toppra slow down there (only at the corners that needed it).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from forte.model.clearance import ClearanceChecker
from forte.model.robot import MobileManipulator
from forte.model.scene import Scene
from forte.planning.search.sampling import SLIP, kept
from forte.planning.search.timing import KNOT_STEP, Timed, retime
from forte.validation import FloatArray

#: Rounds of corner knots, ``delta`` halving each round.
CORNER_ROUNDS = 3
#: A vertex is a corner when its segments' directions differ by more than this (cosine below 1 minus it).
STRAIGHT = 1e-9


def corners(path: FloatArray) -> FloatArray:
    """Indices of the interior vertices of ``path`` (M x n) where it turns."""
    u, w = path[1:-1] - path[:-2], path[2:] - path[1:-1]
    norms = np.linalg.norm(u, axis=1) * np.linalg.norm(w, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        cos = np.einsum("ij,ij->i", u, w) / norms
    return np.flatnonzero((norms > 0) & (cos < 1.0 - STRAIGHT)) + 1


def with_corner_knots(path: FloatArray, at: Any, delta: float) -> FloatArray:
    """``path`` with a state on each segment of every vertex in ``at``, ``delta`` from the vertex
    (at most 0.4 of the segment, so that two corners' knots keep their order)."""
    marked, out = {int(i) for i in at}, []
    for i, q in enumerate(path):
        if i in marked and 0 < i < len(path) - 1:
            before, after = path[i - 1] - q, path[i + 1] - q
            out += [q + before * min(delta / np.linalg.norm(before), 0.4), q,
                    q + after * min(delta / np.linalg.norm(after), 0.4)]
        else:
            out.append(q)
    return np.array(out)


def hugging_law(robot: MobileManipulator, scene: Scene, path: FloatArray, clearance: float, *,
                samples: int, limits: Any = None) -> tuple[Timed, dict[str, Any]]:
    """toppra's law along ``path`` (:func:`retime`) with corner knots where it cuts below the path's
    kept clearance less :data:`SLIP` (module docstring); the law and what was done (``corner_knots``:
    the corners given knots, ``law_clearance_m``: the law's least clearance at its samples)."""
    law = retime(robot, path, samples=samples, limits=limits)
    turns = corners(path)
    if not scene.objects and scene.floor is None or not len(turns):
        return law, {}
    checker = ClearanceChecker(robot, scene)
    floor = kept(robot, scene, clearance, path[0], path[-1]) - SLIP
    distance = checker.evaluate(law.q).distance
    marked: set[int] = set()
    for round_ in range(CORNER_ROUNDS):
        low = law.q[distance < floor]
        if not len(low):
            break
        nearest = np.argmin(np.linalg.norm(low[:, None, :] - path[None, turns, :], axis=2), axis=1)
        marked |= {int(turns[k]) for k in nearest}
        law = retime(robot, with_corner_knots(path, sorted(marked), KNOT_STEP / 2 ** (round_ + 1)),
                     samples=samples, limits=limits)
        distance = checker.evaluate(law.q).distance
    facts = {"corner_knots": len(marked), "law_clearance_m": float(distance.min())} if marked else {}
    return law, facts
