"""A live point cloud as the scene of ``forte ros`` (``--cloud-topic``): ``sensor_msgs/PointCloud2``.

:func:`cloud_points` reads a message's ``x``, ``y``, ``z`` fields with NumPy (any of
PointField's numeric types, either byte order, rows padded to ``row_step``), dropping the
points that are not finite (a live sensor writes NaN where it has no return).
:class:`LiveCloud` turns the latest cloud into the task's scene as a task file's
``point_cloud:`` entry does (:mod:`forte.planning.tasks.sensed_section`): placed in the world by
``pose`` (the cloud's frame; default: the points are in the world frame, the robot's start base
frame), the floor's points and the robot's own (at the configuration it is given) dropped,
occupied voxels covered by boxes named ``cloud/<i>`` next to the task's own bodies. It is
*throttled*: a cloud is taken at most once per ``period`` seconds (the latest one that arrived;
those in between are dropped) and *latched*: a new scene comes out only when the occupied
cells differ from the last ones, so a static world re-plans once. The cells become the default
coarse cover (:mod:`forte.model.occupancy_cover`). Each cloud replaces the last, unless
``carve``: then the cells *accumulate*, and a new cloud clears the earlier cells its rays (from
the cloud frame's origin, the sensor, to each of its points, the floor's and the robot's
included) pass through (:func:`forte.model.occupancy.fused`): an object taken away disappears
once the sensor sees past it, one out of view stays.
"""

from __future__ import annotations

import hashlib
from typing import Any, NamedTuple

import numpy as np

from forte.exceptions import InvalidInputError
from forte.model.occupancy import box_objects, fused, occupancy, self_filter, transformed
from forte.model.scene import Scene
from forte.validation import FloatArray

#: ``sensor_msgs/PointField`` datatypes (INT8 ... FLOAT64) as NumPy types.
POINTFIELD_TYPES = {1: "i1", 2: "u1", 3: "i2", 4: "u2", 5: "i4", 6: "u4", 7: "f4", 8: "f8"}
#: The prefix of the cloud's boxes among the scene's bodies.
CLOUD_NAME = "cloud"


def cloud_points(msg: Any) -> FloatArray:
    """The finite ``x``, ``y``, ``z`` points (N x 3) of a ``sensor_msgs/PointCloud2``."""
    fields = {f.name: f for f in msg.fields}
    if not {"x", "y", "z"} <= set(fields):
        raise InvalidInputError(f"PointCloud2: expected x, y and z fields, got {sorted(fields)}")
    order = ">" if msg.is_bigendian else "<"
    try:
        formats = [order + POINTFIELD_TYPES[fields[a].datatype] for a in "xyz"]
    except KeyError as exc:
        raise InvalidInputError(f"PointCloud2: unknown PointField datatype {exc.args[0]}") from None
    dtype = np.dtype({"names": list("xyz"), "formats": formats, "offsets": [fields[a].offset for a in "xyz"],
                      "itemsize": msg.point_step})
    n = msg.width * msg.height
    data = np.frombuffer(bytes(msg.data), dtype=np.uint8)
    if n == 0:
        return np.zeros((0, 3))
    if data.size < msg.height * msg.row_step or msg.row_step < msg.width * msg.point_step:
        raise InvalidInputError(f"PointCloud2: {data.size} bytes for {msg.height} rows of {msg.row_step}")
    rows = data[:msg.height * msg.row_step].reshape(msg.height, msg.row_step)[:, :msg.width * msg.point_step]
    table = np.frombuffer(np.ascontiguousarray(rows).tobytes(), dtype=dtype, count=n)
    points = np.column_stack([table[a].astype(float) for a in "xyz"])
    return points[np.all(np.isfinite(points), axis=1)]


def cloud_message(points: Any, frame_id: str = "world") -> Any:
    """``points`` (N x 3) as an unorganized ``sensor_msgs/PointCloud2`` of float32 x, y, z."""
    from sensor_msgs.msg import PointCloud2, PointField

    points = np.asarray(points, dtype=np.float32).reshape(-1, 3)
    msg = PointCloud2()
    msg.header.frame_id = frame_id
    msg.height, msg.width = 1, len(points)
    msg.fields = [PointField(name=a, offset=4 * i, datatype=7, count=1) for i, a in enumerate("xyz")]
    msg.is_bigendian, msg.point_step, msg.row_step, msg.is_dense = False, 12, 12 * len(points), True
    msg.data = points.tobytes()
    return msg


class CloudOptions(NamedTuple):
    """``forte ros``'s cloud: the ``topic``, the ``voxel`` (m), the throttle ``period`` (s), the
    cloud frame's ``pose`` in the world (4x4; ``None``: the world frame) and whether clouds
    accumulate, carved along their rays (``carve``: :class:`LiveCloud`)."""

    topic: str
    voxel: float = 0.02
    period: float = 1.0
    pose: Any = None
    carve: bool = False


class CloudScene(NamedTuple):
    """A scene made from a cloud: ``scene`` (the task's bodies and the cloud's boxes), the cloud's
    ``points`` kept, its occupied ``cells`` and ``boxes``."""

    scene: Scene
    points: int
    cells: int
    boxes: int


class LiveCloud:
    """The latest cloud as the task's scene, throttled and latched (module docstring)."""

    def __init__(self, base: Scene, robot: Any, voxel: float = 0.02, period: float = 1.0,
                 pose: Any = None, carve: bool = False) -> None:
        self.base, self.robot, self.voxel, self.period = base, robot, float(voxel), float(period)
        self.pose = np.eye(4) if pose is None else np.asarray(pose, dtype=float)
        self.carve, self.cells = bool(carve), None
        self.pending: Any = None
        self.last_taken = -np.inf
        self.key: str | None = None

    def offer(self, msg: Any) -> None:
        """A cloud arrived: keep it (the latest one wins)."""
        self.pending = msg

    def poll(self, now: float, q: Any) -> CloudScene | None:
        """The scene of the pending cloud, with the robot at whole-body ``q`` filtered out, when
        ``period`` has passed since the last cloud taken and its cells changed; else ``None``."""
        if self.pending is None or now - self.last_taken < self.period:
            return None
        msg, self.pending, self.last_taken = self.pending, None, now
        points = transformed(cloud_points(msg), self.pose)
        keep = np.ones(len(points), dtype=bool)
        if self.base.floor is not None:
            keep &= points[:, 2] >= self.base.floor + self.voxel
        if keep.any():
            keep[keep] = self_filter(points[keep], self.robot, q)
        if self.carve:  # the earlier cells, less those this cloud's rays see through
            occ = self.cells = fused(self.cells, self.pose[:3, 3], points, self.voxel, keep)
        else:
            occ = occupancy(points[keep], self.voxel) if keep.any() else None
        digest = hashlib.sha1()
        if occ is not None:
            digest.update(np.asarray(occ.origin, dtype=np.int64).tobytes() + str(occ.grid.shape).encode()
                          + np.packbits(occ.grid).tobytes())
        if digest.hexdigest() == self.key:
            return None
        self.key = digest.hexdigest()
        boxes = box_objects(CLOUD_NAME, occ) if occ is not None else ()
        return CloudScene(Scene((*self.base.objects, *boxes), self.base.floor), int(keep.sum()),
                          occ.cells if occ is not None else 0, len(boxes))
