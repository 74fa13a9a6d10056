"""Occupancy from sensed points: voxels on a world-aligned grid, merged into boxes or covered by a few.

**Voxels.** A point ``p`` (world frame, m) occupies the cell of integer index ``floor(p / v)``
of the grid of voxel size ``v`` (cell ``i`` spans ``[i v, (i + 1) v)`` on each axis; the grid is
anchored at the world's origin, so two clouds of one place fall on the same cells). Every sensed
point lies in its cell, so the occupied cells hold every point and reach at most one voxel (its
diagonal, ``sqrt(3) v``) beyond the surface that was sampled.

**Boxes.** The occupied cells are merged into axis-aligned boxes, greedily: from the first cell
not yet taken (z slowest, x fastest), a run along x as long as the cells are occupied and free,
then the run's row grown along y while every cell of the next row is, then the rectangle grown
along z while every cell of the next layer is. The boxes are disjoint and their union is
exactly the occupied cells, so a distance to the boxes *is* the distance to the occupancy map:
the scene's boxes go to the optimizer's rounded-box rows, coal's exact check and MuJoCo as
ordinary :class:`~forte.model.scene.Box` bodies. A flat surface seen by a camera (a table top,
a box face) becomes a few boxes however many cells it has.

**Cover.** By default (:func:`sensed_boxes`) the cells become a conservative *coarse cover*
instead (:mod:`forte.model.occupancy_cover`): disjoint boxes that hold every occupied cell and
may hold free cells too, but none farther than ``slack`` (default two voxels, at least 4 cm)
from an occupied cell,
in at most ``max_boxes`` boxes; a noisy or slanted surface becomes a few slabs instead of a
staircase of thousands of boxes. The exact merge stays available (``cover=None``).

**Depth images** (:func:`depth_points`): the pixel in column ``u``, row ``v`` with depth ``z``
(m, along the optical axis, as ROS's, OpenCV's and MuJoCo's depth images are) is the point
``((u - cx) z / fx, (v - cy) z / fy, z)`` in the camera's *optical* frame: z forward (out of
the lens), x right, y down in the image. The entry's pose is that frame's pose in the world; a
camera looking along world +x, upright, has ``roll = -pi/2, yaw = -pi/2``. Pixels with depth 0,
NaN or beyond ``max_range`` (no return) are dropped.

**Self-filter** (:func:`self_filter`): a point inside the robot's collision cover
(:mod:`forte.model.body_spheres`: spheres and vertical capsules holding every collision mesh,
the base box and the payload) at the capture configuration, grown by ``padding``, is the robot
seeing itself and is removed.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

from forte.exceptions import InvalidInputError
from forte.model.occupancy_cover import CoverSettings, cover_boxes, slack_for
from forte.model.scene import Box, SceneObject
from forte.validation import FloatArray

#: The most cells the dense grid around a cloud may have (a bool each).
MAX_GRID_CELLS = 50_000_000
#: The coarse cover's settings when a caller does not say (:mod:`forte.model.occupancy_cover`).
DEFAULT_COVER = CoverSettings()
#: How far (m) beyond the robot's collision cover the self-filter removes points.
SELF_FILTER_PADDING = 0.03


class Intrinsics(NamedTuple):
    """A pinhole camera: focal lengths and principal point, in pixels."""

    fx: float
    fy: float
    cx: float
    cy: float


class Occupancy(NamedTuple):
    """Occupied cells of voxel size ``voxel`` (m): ``grid[i, j, k]`` is the cell of world index
    ``origin + (i, j, k)``."""

    voxel: float
    origin: Any
    grid: Any

    @property
    def cells(self) -> int:
        return int(np.count_nonzero(self.grid))

    def centres(self) -> FloatArray:
        """World centres (C x 3) of the occupied cells."""
        return (np.argwhere(self.grid) + self.origin + 0.5) * self.voxel

    def occupied(self, points: Any) -> Any:
        """Whether each point (N x 3, world) lies in an occupied cell."""
        index = np.floor(np.asarray(points, dtype=float) / self.voxel).astype(np.int64) - self.origin
        inside = np.all((index >= 0) & (index < self.grid.shape), axis=1)
        out = np.zeros(len(index), dtype=bool)
        out[inside] = self.grid[tuple(index[inside].T)]
        return out


def occupancy(points: Any, voxel: float, max_cells: int = MAX_GRID_CELLS) -> Occupancy:
    """The cells (voxel size ``voxel``, m) that ``points`` (N x 3, world, N > 0) occupy;
    ``InvalidInputError`` when the grid around them would have more than ``max_cells`` cells."""
    points = np.asarray(points, dtype=float)
    index = np.floor(points / voxel).astype(np.int64)
    lo, hi = index.min(axis=0), index.max(axis=0)
    shape = hi - lo + 1
    if float(np.prod(shape.astype(float))) > max_cells:
        span = np.ptp(points, axis=0)
        raise InvalidInputError(f"{voxel:g} m voxels over the points' {' x '.join(f'{s:.3g}' for s in span)} m make "
                                f"a grid of {np.prod(shape.astype(float)):.3g} cells, more than {max_cells}; "
                                "choose a larger voxel or crop the cloud")
    grid = np.zeros(tuple(shape), dtype=bool)
    grid[tuple((index - lo).T)] = True
    return Occupancy(float(voxel), lo, grid)


def merged_boxes(grid: Any) -> Any:
    """Disjoint boxes (B x 6 integer: low corner, high corner exclusive, in cells) whose union is
    ``grid``'s occupied cells (greedy runs along x, then y, then z: module docstring)."""
    free = np.array(grid, dtype=bool)
    nx, ny, nz = free.shape
    out = []
    for z, y, x in np.argwhere(free.transpose(2, 1, 0)):
        if not free[x, y, z]:
            continue
        x1 = x + 1
        while x1 < nx and free[x1, y, z]:
            x1 += 1
        y1 = y + 1
        while y1 < ny and free[x:x1, y1, z].all():
            y1 += 1
        z1 = z + 1
        while z1 < nz and free[x:x1, y:y1, z1].all():
            z1 += 1
        free[x:x1, y:y1, z:z1] = False
        out.append((x, y, z, x1, y1, z1))
    return np.array(out, dtype=np.int64).reshape(-1, 6)


class SensedBoxes(NamedTuple):
    """Boxes of an occupancy (B x 6 integer cells: low corner, high corner exclusive), how far
    (m) any point of them may lie from an occupied cell, and the free cells they hold."""

    boxes: Any
    excess: float
    free_cells: int


def sensed_boxes(occ: Occupancy, cover: CoverSettings | None = DEFAULT_COVER) -> SensedBoxes:
    """The occupancy's boxes: ``cover`` (default :data:`DEFAULT_COVER`) the conservative coarse
    cover (:mod:`forte.model.occupancy_cover`), ``None`` the exact merge (no excess)."""
    if cover is None:
        return SensedBoxes(merged_boxes(occ.grid), 0.0, 0)
    return SensedBoxes(*cover_boxes(occ.grid, occ.voxel, slack_for(occ.voxel, cover.slack), cover.max_boxes))


def box_objects(name: str, occ: Occupancy, cover: CoverSettings | None = DEFAULT_COVER) -> tuple[SceneObject, ...]:
    """The occupancy's boxes (:func:`sensed_boxes`) as scene bodies ``name/0``, ``name/1``, ... (world axes)."""
    return boxes_as_objects(name, occ, sensed_boxes(occ, cover).boxes)


def boxes_as_objects(name: str, occ: Occupancy, boxes: Any) -> tuple[SceneObject, ...]:
    """Integer boxes of ``occ`` (B x 6 cells) as scene bodies ``name/0``, ``name/1``, ... (world axes)."""
    lo = (boxes[:, :3] + occ.origin) * occ.voxel
    hi = (boxes[:, 3:] + occ.origin) * occ.voxel
    out = []
    for i, (a, b) in enumerate(zip(lo, hi, strict=True)):
        pose = np.eye(4)
        pose[:3, 3] = (a + b) / 2
        out.append(SceneObject(f"{name}/{i}", Box(tuple(float(s) for s in b - a)), pose))
    return tuple(out)


def seen_through(occ: Occupancy, origin: Any, points: Any, chunk: int = 2048) -> Any:
    """The cells of ``occ``'s grid (a bool grid of its shape) that the rays from the sensor at
    ``origin`` (3, world) to ``points`` (N x 3, world) pass through, up to one voxel short of each
    point: each ray, clipped to the grid's bounds, is sampled every half voxel, and a cell holding
    a sample is seen through. Sampling can miss a cell a ray only clips (it then stays as it was:
    the conservative side); the last voxel before a point is never cleared by its own ray, so a
    ray grazing the surface it ends on does not clear that surface's cells."""
    origin, points = np.asarray(origin, dtype=float), np.asarray(points, dtype=float)
    v, shape = occ.voxel, np.array(occ.grid.shape)
    lo, hi = occ.origin * v, (occ.origin + shape) * v
    seen = np.zeros(occ.grid.shape, dtype=bool)
    d = points - origin
    length = np.linalg.norm(d, axis=1)
    keep = length > v
    d, length = d[keep] / length[keep, None], length[keep] - v
    with np.errstate(divide="ignore", invalid="ignore"):
        t0, t1 = (lo - origin) / d, (hi - origin) / d
    enter = np.nan_to_num(np.max(np.minimum(t0, t1), axis=1), nan=-np.inf).clip(0.0)
    leave = np.minimum(np.nan_to_num(np.min(np.maximum(t0, t1), axis=1), nan=np.inf), length)
    hit = enter < leave
    d, enter, leave = d[hit], enter[hit], leave[hit]
    for start in range(0, len(d), chunk):
        e, f, u = enter[start:start + chunk], leave[start:start + chunk], d[start:start + chunk]
        t = e[:, None] + np.arange(int(np.ceil((f - e).max() / (v / 2))) + 1) * (v / 2)
        t = np.where(t <= f[:, None], t, np.nan)
        samples = (origin + u[:, None, :] * t[..., None])[~np.isnan(t)]
        index = np.floor(samples / v).astype(np.int64) - occ.origin
        index = index[np.all((index >= 0) & (index < shape), axis=1)]
        seen[tuple(index.T)] = True
    return seen


def fused(previous: Occupancy | None, origin: Any, points: Any, voxel: float,
          occupying: Any = None) -> Occupancy | None:
    """The occupancy after a new scan: ``previous``'s cells minus those the scan's rays (from the
    sensor at ``origin`` to every one of ``points``) see through (:func:`seen_through`), plus the
    cells of the points that occupy (``occupying``: a mask; default all; the floor's and the
    robot's own points are rays, not bodies). A cell a new point lies in is occupied whatever the
    rays say. ``None`` when no cell is left."""
    points = np.asarray(points, dtype=float)
    mine = points if occupying is None else points[np.asarray(occupying, dtype=bool)]
    cells = [np.argwhere(o.grid) + o.origin for o in ([occupancy(mine, voxel)] if len(mine) else [])]
    if previous is not None:
        if previous.voxel != voxel:
            raise InvalidInputError(f"fused: a {previous.voxel:g} m occupancy and {voxel:g} m voxels")
        seen = seen_through(previous, origin, points) if len(points) else np.zeros_like(previous.grid)
        cells.append(np.argwhere(previous.grid & ~seen) + previous.origin)
    cells = [c for c in cells if len(c)]
    return occupancy((np.vstack(cells) + 0.5) * voxel, voxel) if cells else None


def transformed(points: Any, pose: Any) -> FloatArray:
    """``points`` (N x 3) in the frame of ``pose`` (4x4) expressed in the world."""
    pose = np.asarray(pose, dtype=float)
    return np.asarray(points, dtype=float) @ pose[:3, :3].T + pose[:3, 3]


def depth_points(depth: Any, intrinsics: Intrinsics, max_range: float, pose: Any) -> FloatArray:
    """The world points (N x 3) of a depth image (H x W, m along the optical axis) seen by a
    camera whose optical frame has ``pose`` (4x4; module docstring)."""
    depth = np.asarray(depth, dtype=float)
    with np.errstate(invalid="ignore"):
        valid = np.isfinite(depth) & (depth > 0) & (depth <= max_range)
    v, u = np.nonzero(valid)
    z = depth[v, u]
    camera = np.column_stack([(u - intrinsics.cx) * z / intrinsics.fx, (v - intrinsics.cy) * z / intrinsics.fy, z])
    return transformed(camera, pose)


def robot_cover_distance(points: Any, robot: Any, q: Any, chunk: int = 20000) -> FloatArray:
    """The distance (m; negative inside) from each point (N x 3, world) to the robot's collision
    cover (:mod:`forte.model.body_spheres`) at whole-body configuration ``q``: per primitive, the
    distance to its vertical segment (``centre +- half_height`` along world z) minus its radius."""
    from forte.model.body_spheres import primitive_centres, robot_primitives

    primitives = robot_primitives(robot)
    centres = primitive_centres(robot, q, primitives)
    half = np.array([p.half_height for p in primitives])
    radius = np.array([p.radius for p in primitives])
    points = np.asarray(points, dtype=float)
    out = np.empty(len(points))
    for start in range(0, len(points), chunk):
        d = points[start:start + chunk, None, :] - centres[None]
        dz = np.maximum(np.abs(d[..., 2]) - half, 0.0)
        out[start:start + chunk] = np.min(np.sqrt(d[..., 0] ** 2 + d[..., 1] ** 2 + dz**2) - radius, axis=1)
    return out


def self_filter(points: Any, robot: Any, q: Any, padding: float = SELF_FILTER_PADDING) -> Any:
    """Which points (N x 3, world) to keep: those farther than ``padding`` (m) from the robot's
    collision cover at whole-body configuration ``q`` (the rest are the robot seeing itself)."""
    return robot_cover_distance(points, robot, q) > padding


def octree(occ: Occupancy) -> Any:
    """coal's OcTree of the occupied cells (their centres at the voxel size): the same cells,
    for a distance computed by coal over the tree instead of the merged boxes."""
    import coal

    return coal.makeOctree(np.ascontiguousarray(occ.centres()), occ.voxel)
