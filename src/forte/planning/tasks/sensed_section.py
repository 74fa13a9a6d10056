"""Scene entries from sensor data: ``point_cloud:`` and ``depth_image:`` (read by :func:`sensed_objects`).

::

    scene:
      - name: shelf_cloud
        point_cloud: {file: shelf.ply, voxel: 0.02}     # .ply, .pcd or .npy (N x 3)
        pose: [0, 0, 0, 0, 0, 0]                          # the cloud's frame in the world
      - name: camera
        depth_image: {file: depth.png, scale: 0.001, intrinsics: {fx: 525, fy: 525, cx: 319.5, cy: 239.5},
                      max_range: 3.0, voxel: 0.02}
        pose: [0.2, 0, 1.4, -1.5708, 0, -1.5708]          # the camera's optical frame (z forward, x right, y down)
        capture_configuration: [0, 0, 0, 0, -0.785, 0, -2.356, 0, 1.571, 0.785]   # optional: the robot's q

The points (a cloud's, or a depth image's back-projected: :func:`forte.model.occupancy.depth_points`)
are placed in the world by ``pose``; those lower than one voxel above the floor are dropped (the
floor is in every world already, :attr:`forte.model.scene.Scene.floor`), and so are the robot's
own at ``capture_configuration`` (a whole-body configuration;
:func:`forte.model.occupancy.self_filter`); the rest occupy cells of ``voxel`` (m), covered by
boxes named ``<name>/<i>`` (:mod:`forte.model.occupancy`): every consumer of the scene takes
them as box bodies. ``merge`` says how: by default (or ``merge: {slack: 0.04, max_boxes: 128}``;
the default slack is two voxels, at least 0.04 m) a conservative coarse cover, boxes holding
every occupied cell and free space only within ``slack`` (m) of one
(:mod:`forte.model.occupancy_cover`); ``merge: exact``, boxes whose union is exactly the
occupied cells. A file is relative to the task file. ``scale`` turns the image's values into
metres (default 0.001 for a PNG, millimetres as depth cameras write them; 1 for a ``.npy``).
Every error is one line naming the entry's field and, for a file's content, the file.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from forte.exceptions import ForteError
from forte.model.occupancy import (
    Intrinsics,
    box_objects,
    depth_points,
    occupancy,
    self_filter,
    transformed,
)
from forte.model.occupancy_cover import DEFAULT_MAX_BOXES, CoverSettings
from forte.model.scene import SceneObject
from forte.planning.tasks.schema import Reader
from forte.validation import FloatArray

#: The sensed entries' kinds, as the task file spells them.
SENSED_KINDS = ("point_cloud", "depth_image")
#: The voxel size (m) when an entry does not say.
DEFAULT_VOXEL = 0.02
#: The largest voxel (m) forte accepts.
MAX_VOXEL = 1.0
#: The depth image's range (m) when an entry does not say.
DEFAULT_MAX_RANGE = 10.0
#: The most points a sensed entry's file may hold.
MAX_POINTS = 20_000_000
#: The largest cover slack (m) and box budget forte accepts.
MAX_SLACK = 1.0
MAX_BOXES = 100_000


def sensed_objects(r: Reader, kind: str, name: str, pose: FloatArray, base: Path,
                   filters: tuple[Any, FloatArray | None, float | None]) -> tuple[SceneObject, ...]:
    """The boxes of entry ``r`` (its ``kind`` mapping read by ``r.sub(kind)``) at ``pose`` (4x4);
    ``filters``: the robot, the capture configuration (``None``: no self-filter) and the floor's
    height (``None``: no floor), below which and up to one voxel above which points are the floor."""
    robot, capture, floor = filters
    sub = r.sub(kind)
    sub.unknown({"file", "voxel", "merge"} | ({"scale", "intrinsics", "max_range"} if kind == "depth_image" else set()))
    voxel = sub.number("voxel", DEFAULT_VOXEL, positive=True, maximum=MAX_VOXEL, unit=" m")
    cover = merge_settings(sub)
    points = transformed(_read(sub, base, cloud=True), pose) if kind == "point_cloud" else _depth_image(sub, base, pose)
    source = Path(str(sub.get("file"))).name
    if floor is not None:  # the floor is every world's half-space already: its points are no body
        points = points[points[:, 2] >= floor + voxel]
    if capture is not None:
        points = points[self_filter(points, robot, capture)]
    if len(points) == 0:
        field = "capture_configuration" if capture is not None else f"{kind}.file"
        raise r.error(field, f"no point of {source} is left " + ("off the robot at the capture configuration"
                                                                  if capture is not None else "in range"))
    try:
        return box_objects(name, occupancy(points, voxel), cover)
    except ForteError as exc:
        raise sub.error("voxel", f"{source}: {exc}") from exc


def merge_settings(sub: Reader) -> CoverSettings | None:
    """The entry's ``merge``: ``exact`` (``None``: the cells merged into boxes exactly) or the
    coarse cover's ``{slack, max_boxes}`` (defaults :class:`~forte.model.occupancy_cover.CoverSettings`)."""
    merge = sub.get("merge")
    if merge is None:
        return CoverSettings()
    if merge == "exact":
        return None
    if not isinstance(merge, dict):
        raise sub.error("merge", f"expected exact or {{slack, max_boxes}}, got {merge!r}")
    m = sub.sub("merge")
    m.unknown({"slack", "max_boxes"})
    slack = m.number("slack", nonnegative=True, maximum=MAX_SLACK, unit=" m") if m.has("slack") else None
    return CoverSettings(slack, m.integer("max_boxes", DEFAULT_MAX_BOXES, maximum=MAX_BOXES))


def capture_configuration(r: Reader, robot: Any) -> FloatArray | None:
    """The entry's ``capture_configuration`` (whole-body, ``robot.nq`` values) or ``None``."""
    if not r.has("capture_configuration"):
        return None
    return r.vector("capture_configuration", robot.nq)


def _read(sub: Reader, base: Path, cloud: bool) -> FloatArray:
    from forte.model.point_files import read_depth, read_points

    file = sub.get("file")
    if not isinstance(file, str) or not file:
        raise sub.error("file", f"expected a {'point cloud' if cloud else 'depth image'} file path, got {file!r}")
    path = (Path(file) if Path(file).is_absolute() else base / file).resolve()
    try:
        values = read_points(path) if cloud else read_depth(path)
    except ForteError as exc:
        raise sub.error("file", str(exc)) from exc
    if values.size > (3 if cloud else 1) * MAX_POINTS:
        raise sub.error("file", f"{path.name}: more than {MAX_POINTS} points; crop or thin it")
    return values


def _depth_image(sub: Reader, base: Path, pose: FloatArray) -> FloatArray:
    file = str(sub.get("file", ""))
    default_scale = 0.001 if file.lower().endswith(".png") else 1.0
    scale = sub.number("scale", default_scale, positive=True)
    max_range = sub.number("max_range", DEFAULT_MAX_RANGE, positive=True, maximum=1000.0, unit=" m")
    if not sub.has("intrinsics") or not isinstance(sub.get("intrinsics"), dict):
        raise sub.error("intrinsics", "expected {fx, fy, cx, cy} (pixels)")
    k = sub.sub("intrinsics")
    k.unknown({"fx", "fy", "cx", "cy"})
    intrinsics = Intrinsics(k.number("fx", positive=True), k.number("fy", positive=True), k.number("cx"),
                            k.number("cy"))
    depth = _read(sub, base, cloud=False) * scale
    with np.errstate(invalid="ignore"):
        if np.any(depth < 0):
            raise sub.error("file", f"{Path(file).name}: negative depths (expected m >= 0 after scale {scale:g})")
    return depth_points(depth, intrinsics, max_range, pose)
