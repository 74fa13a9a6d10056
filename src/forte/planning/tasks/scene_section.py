"""The task file's ``scene:``, ``scene_file:``, ``floor:`` and ``clearance:`` fields.

``scene:`` is a list of bodies, each ``{name, <shape>: {...}, pose: [x, y, z, roll, pitch, yaw]}``
with one shape of :data:`forte.model.scene.SHAPE_KINDS` (a mesh's ``file`` is relative to the
task file); ``scene_file:`` adds the static bodies of a URDF or MJCF file
(:mod:`forte.model.scene_files`); ``floor:`` is ``{height: h}`` (m, world z; default: the floor
at z = 0 that MuJoCo's robot rides on) or ``none``; ``clearance:`` is the distance (m) the plan
keeps from every body and from the floor. Every error names the entry and the field. An entry
may also be sensor data, ``point_cloud:`` or ``depth_image:`` (with an optional
``capture_configuration:``), read into boxes by :mod:`forte.planning.tasks.sensed_section`.

The floor's rules at the start (:func:`check_floor`): a part rigid with the base (the arm's root
link) more than 1 mm below the floor is an arm mounted at or below it, and in a task whose start
is fixed (not ``hold``) an arm link or the payload closer to the floor than the clearance at the
start configuration leaves no plan that keeps it; either is one line naming the link.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from forte.exceptions import ForteError
from forte.model.scene import (
    DEFAULT_FLOOR,
    SHAPE_KINDS,
    Box,
    Capsule,
    Cylinder,
    Mesh,
    Scene,
    SceneObject,
    Sphere,
    pose_matrix,
)
from forte.planning.tasks.schema import Reader
from forte.validation import FloatArray, _short

#: The clearance (m) a plan keeps from every scene body when the task does not say.
DEFAULT_CLEARANCE = 0.02

#: The largest clearance and body size forte accepts (m): beyond them a unit slip is likelier.
MAX_LENGTH_M = 100.0


def scene_section(reader: Reader, base: Path, robot: Any = None) -> Scene:
    """The task's scene (empty without ``scene:`` and ``scene_file:``); ``robot`` filters itself
    out of sensed entries (:mod:`forte.planning.tasks.sensed_section`)."""
    objects: list[SceneObject] = []
    floor = floor_value(reader)
    if reader.has("scene"):
        entries = reader.get("scene")
        if not isinstance(entries, list):
            raise reader.error("scene", f"expected a list of bodies, got {type(entries).__name__}")
        for i, entry in enumerate(entries):
            objects += _entry(Reader(entry, reader.path, f"{reader.key('scene')}[{i}]."), i, base, robot, floor)
    if reader.has("scene_file"):
        from forte.model.scene_files import read_scene_file

        path = Path(str(reader.get("scene_file")))
        try:
            objects += read_scene_file((path if path.is_absolute() else base / path).resolve())
        except ForteError as exc:
            raise reader.error("scene_file", str(exc)) from exc
    names = [o.name for o in objects]
    for i, name in enumerate(names):
        if name in names[:i]:
            raise reader.error("scene", f"two bodies are named {name!r}; give each a unique name")
    return Scene(tuple(objects), floor)


def floor_value(reader: Reader) -> float | None:
    """The task's ``floor:`` height (m), :data:`~forte.model.scene.DEFAULT_FLOOR` when absent,
    ``None`` for ``floor: none``."""
    if "floor" not in reader.data:
        return DEFAULT_FLOOR
    value = reader.get("floor")
    if value == "none":
        return None
    if not isinstance(value, dict):
        raise reader.error("floor", f"expected {{height: h}} (m) or none, got {_short(value)}")
    r = reader.sub("floor")
    r.unknown({"height"})
    height = r.number("height")
    if abs(height) > MAX_LENGTH_M:
        raise r.error("height", f"expected a height within {MAX_LENGTH_M:g} m of the robot's start, got {height:g}")
    return height


def check_floor(reader: Reader, robot: Any, q: FloatArray, scene: Scene, clearance: float, fixed_start: bool,
                start_field: str) -> None:
    """The floor's rules at the start configuration ``q`` (module docstring); ``start_field``: the
    field that gives ``q``."""
    if scene.floor is None:
        return
    from forte.model.clearance import floor_contact

    found = floor_contact(robot, scene.floor, q, clearance, moving=fixed_start)
    if found is None:
        return
    where = f"the floor at z = {scene.floor:g} m"
    if found.grounded:
        raise reader.error("robot", f"{found.name}, rigid with the base, reaches {-found.distance:.3g} m below "
                           f"{where}: the arm is mounted at or below the floor; raise robot.mount, or move the "
                           "floor (floor: {height: h}) or leave it out (floor: none)")
    raise reader.error(start_field, f"puts {found.name} {found.distance:.3g} m from {where}, closer than the "
                       f"clearance {clearance:g} m: no plan from it keeps the clearance (lower clearance, move "
                       "the floor or leave it out: floor: none)")

def clearance_value(reader: Reader) -> float:
    """The task's ``clearance:`` (m), default :data:`DEFAULT_CLEARANCE`."""
    return reader.number("clearance", DEFAULT_CLEARANCE, nonnegative=True, maximum=1.0, unit=" m")


def _entry(r: Reader, index: int, base: Path, robot: Any, floor: float | None) -> tuple[SceneObject, ...]:
    from forte.planning.tasks.sensed_section import SENSED_KINDS, capture_configuration, sensed_objects

    kinds = [k for k in (*SHAPE_KINDS, *SENSED_KINDS) if k in r.data]
    r.unknown({"name", "pose", "capture_configuration", *SHAPE_KINDS, *SENSED_KINDS})
    if len(kinds) != 1:
        found = f"got {', '.join(kinds)}" if kinds else "got none"
        raise r.error("", f"expected exactly one shape of {', '.join((*SHAPE_KINDS, *SENSED_KINDS))}; {found}")
    name = r.get("name", f"body{index}")
    if not isinstance(name, str) or not name:
        raise r.error("name", f"expected a non-empty string, got {name!r}")
    pose = r.vector("pose", 6)
    if np.any(np.abs(pose[:3]) > MAX_LENGTH_M):
        raise r.error("pose", f"expected a position within {MAX_LENGTH_M:g} m of the robot's start, got {pose[:3]}")
    if kinds[0] in SENSED_KINDS:
        if robot is None and r.has("capture_configuration"):
            raise r.error("capture_configuration", "needs the task's robot")
        capture = capture_configuration(r, robot) if robot is not None else None
        return sensed_objects(r, kinds[0], name, pose_matrix(pose), base, (robot, capture, floor))
    if r.has("capture_configuration"):
        raise r.error("capture_configuration", f"belongs to a point_cloud or depth_image entry, not a {kinds[0]}")
    return (SceneObject(name, _shape(r.sub(kinds[0]), kinds[0], base), pose_matrix(pose)),)


def _shape(r: Reader, kind: str, base: Path) -> Any:
    def length(name: str) -> float:
        return r.number(name, positive=True, maximum=MAX_LENGTH_M, unit=" m")

    if kind == "box":
        r.unknown({"size"})
        size = r.vector("size", 3)
        if np.any(size <= 0) or np.any(size > MAX_LENGTH_M):
            raise r.error("size", f"expected 3 edge lengths in (0, {MAX_LENGTH_M:g}] m, got {size.tolist()}")
        return Box(tuple(map(float, size)))
    if kind in ("cylinder", "capsule"):
        r.unknown({"radius", "length"})
        cls = Cylinder if kind == "cylinder" else Capsule
        return cls(length("radius"), length("length"))
    if kind == "sphere":
        r.unknown({"radius"})
        return Sphere(length("radius"))
    r.unknown({"file", "scale"})
    file = r.get("file")
    if not isinstance(file, str) or not file:
        raise r.error("file", f"expected a mesh file path, got {file!r}")
    scale_value = r.get("scale", 1.0)
    scale = np.full(3, r.number("scale", 1.0, positive=True)) if not isinstance(scale_value, list) \
        else r.vector("scale", 3)
    if np.any(scale <= 0):
        raise r.error("scale", f"expected scale factors > 0, got {scale.tolist()}")
    path = (Path(file) if Path(file).is_absolute() else base / file).resolve()  # plan.json: from anywhere
    mesh = Mesh(path, tuple(map(float, scale)))
    try:
        SceneObject("check", mesh, np.eye(4)).proxy()  # reads the file: errors now, not mid-plan
    except ForteError as exc:
        raise r.error("file", str(exc).split(": ", 1)[-1]) from exc
    return mesh
