"""A coarse, conservative cover of occupied cells: few boxes that hold every occupied cell.

The exact merge (:func:`forte.model.occupancy.merged_boxes`) makes the boxes' union *equal* the
occupied cells, so a noisy or slanted surface becomes a staircase of thousands of boxes, and the
planner pays per box. The cover trades a bounded amount of free space for far fewer boxes:

**Over-approximation.** Let ``d(c)`` be the Euclidean distance (in cells, centre to centre) from
cell ``c`` to the nearest occupied cell (scipy's exact distance transform; 0 on occupied cells).
A box's *excess* is ``e = v max d(c)`` over its cells (``v``: the voxel, m). Every point ``p`` of
the box lies within ``e`` of an occupied cell's cube: with ``p`` in cell ``c`` (offset ``t`` in
``[-1/2, 1/2]^3`` cells from its centre) and the nearest occupied centre at integer offset
``n`` from ``c``, the distance from ``p`` to that cube is
``v sqrt(sum_i max(|n_i - t_i| - 1/2, 0)^2) <= v |n| = v d(c)``. So the cover keeps free space
only within ``e`` of what was sensed: a plan that keeps ``c`` from the cover keeps ``c`` from the
occupied cells, and loses at most ``e`` of clearance against them.

**Splitting.** The cover starts as the occupied cells' bounding box and splits, largest excess
first, the box whose excess exceeds ``slack`` (m) until none does or there are ``max_boxes``
boxes. A box is split by one plane between cell slices, along the axis and at the cut that
minimise the children's Gini impurity ``sum_i n_i p_i (1 - p_i)``, ``n_i`` the cells of child
``i``'s bounding box of its occupied cells and ``p_i`` their occupied fraction (for every cut at
once, from prefix unions of the slices' projections), as a decision tree separates classes. It
prefers a cut that leaves a child nearly full (peeling a face off a hollow box, a dense noisy
surface off its sparse fringe) to one that halves the waste, and a cut through an empty gap
(both children shrink) to either; the excess, a maximum, would not tell these apart (a hollow
box's centre stays in one child). Each child is the tight box of its occupied cells, so the
boxes are disjoint and every occupied cell is in exactly one.

**Why not grow boxes through free cells** (the exact merge, allowed into free cells within the
slack): seeded at the first cell in scan order, a noisy surface's first cells are its sparse
outliers, whose runs stay short; a top-down split sees the whole surface first.
"""

from __future__ import annotations

import heapq
from typing import Any, NamedTuple

import numpy as np

#: The cover's settings when an entry does not say: free space within ``DEFAULT_SLACK_VOXELS``
#: voxels, and at least ``DEFAULT_SLACK`` (m), of the occupied cells may be covered, in at most
#: ``DEFAULT_MAX_BOXES`` boxes.
DEFAULT_SLACK = 0.04
DEFAULT_SLACK_VOXELS = 2
DEFAULT_MAX_BOXES = 128


class CoverSettings(NamedTuple):
    """How coarse a cover may be: its boxes within ``slack`` (m; ``None``: the default,
    :func:`slack_for`) of the occupied cells, at most ``max_boxes`` of them (the budget wins: then
    the excess is larger than ``slack``)."""

    slack: float | None = None
    max_boxes: int = DEFAULT_MAX_BOXES


def slack_for(voxel: float, slack: float | None = None) -> float:
    """``slack``, or the default for ``voxel``: ``max(DEFAULT_SLACK, DEFAULT_SLACK_VOXELS voxel)``
    (a slack under a voxel would leave no free cell in any box: the exact merge's staircase)."""
    return float(slack) if slack is not None else max(DEFAULT_SLACK, DEFAULT_SLACK_VOXELS * voxel)


class Cover(NamedTuple):
    """Disjoint boxes (B x 6 integer: low corner, high corner exclusive, in cells) holding every
    occupied cell; ``excess`` (m): every point of them lies within it of an occupied cell;
    ``free_cells``: the free cells they hold."""

    boxes: Any
    excess: float
    free_cells: int


def cover_boxes(grid: Any, voxel: float, slack: float, max_boxes: int) -> Cover:
    """The conservative cover of ``grid``'s occupied cells (module docstring): boxes split until
    each is within ``slack`` (m) of the occupied cells or there are ``max_boxes`` of them."""
    from scipy.ndimage import distance_transform_edt

    grid = np.asarray(grid, dtype=bool)
    if not grid.any():
        return Cover(np.zeros((0, 6), dtype=np.int64), 0.0, 0)
    far = distance_transform_edt(~grid).astype(np.float32)
    first = _tight(grid, np.zeros(3, dtype=np.int64), np.array(grid.shape))
    heap = [(-_excess(far, first), 0, first)]
    done: list[Any] = []
    serial = 1
    while heap and len(heap) + len(done) < max_boxes:
        negative, _, box = heapq.heappop(heap)
        if -negative * voxel <= slack:
            done.append(box)
            break
        for child in _split(grid, box):
            heapq.heappush(heap, (-_excess(far, child), serial, child))
            serial += 1
    boxes = np.array(done + [b for _, _, b in heap], dtype=np.int64).reshape(-1, 6)
    excess = max(_excess(far, b) for b in boxes) * voxel
    volume = np.prod(boxes[:, 3:] - boxes[:, :3], axis=1).sum()  # disjoint, each cell in one: less the cells
    return Cover(boxes, float(excess), int(volume - np.count_nonzero(grid)))


def _excess(far: Any, box: Any) -> float:
    """The largest distance (cells) from a cell of ``box`` to an occupied cell."""
    return float(far[box[0]:box[3], box[1]:box[4], box[2]:box[5]].max())


def _tight(grid: Any, lo: Any, hi: Any) -> Any:
    """The bounding box (6 integers) of the occupied cells of ``grid[lo:hi]``."""
    sub = grid[lo[0]:hi[0], lo[1]:hi[1], lo[2]:hi[2]]
    out = []
    for a in range(3):
        seen = np.flatnonzero(sub.any(axis=tuple(b for b in range(3) if b != a)))
        out.append((lo[a] + seen[0], lo[a] + seen[-1] + 1))
    return tuple(int(v) for v in (out[0][0], out[1][0], out[2][0], out[0][1], out[1][1], out[2][1]))


def _split(grid: Any, box: Any) -> tuple[Any, Any]:
    """``box`` cut in two by the plane of least Gini impurity of the children (module docstring)."""
    lo, hi = np.array(box[:3]), np.array(box[3:])
    sub = grid[lo[0]:hi[0], lo[1]:hi[1], lo[2]:hi[2]]
    best = (np.inf, 0, 0)
    for a in range(3):
        n = sub.shape[a]
        if n < 2:
            continue
        slab = np.moveaxis(sub, a, 0)
        cells = np.cumsum(slab.sum(axis=(1, 2)))
        low_volume = _prefix_volumes(slab)
        high_volume = _prefix_volumes(slab[::-1])[::-1]
        score = _impurity(cells[:-1], low_volume[:-1]) + _impurity(cells[-1] - cells[:-1], high_volume[1:])
        k = int(np.argmin(score))
        if score[k] < best[0]:
            best = (float(score[k]), a, k + 1)
    _, a, cut = best
    mid = lo.copy()
    mid[a] += cut
    top = hi.copy()
    top[a] = mid[a]
    return _tight(grid, lo, top), _tight(grid, mid, hi)


def _impurity(occupied: Any, volume: Any) -> Any:
    """``n p (1 - p)`` of boxes of ``volume`` cells, ``occupied`` of them occupied (``p = occupied / volume``)."""
    return occupied * (volume - occupied) / volume


def _prefix_volumes(slab: Any) -> Any:
    """For each k, the volume (cells) of the bounding box of the occupied cells of ``slab[:k + 1]``
    (slices along the first axis; 0 while they are empty)."""
    n = slab.shape[0]
    any_b = np.logical_or.accumulate(slab.any(axis=2), axis=0)
    any_c = np.logical_or.accumulate(slab.any(axis=1), axis=0)
    occupied = np.logical_or.accumulate(any_b.any(axis=1))
    first = np.argmax(occupied)
    length_a = np.where(occupied, np.arange(n) - first + 1, 0)
    return length_a * _extent(any_b) * _extent(any_c)


def _extent(seen: Any) -> Any:
    """Per row of ``seen`` (k x m bool), last True index - first True index + 1 (0 if none)."""
    m = seen.shape[1]
    has = seen.any(axis=1)
    start = np.argmax(seen, axis=1)
    end = m - np.argmax(seen[:, ::-1], axis=1)
    return np.where(has, end - start, 0)
