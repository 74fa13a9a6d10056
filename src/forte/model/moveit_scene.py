"""Static bodies read from a MoveIt ``PlanningScene`` YAML file (a task's ``scene_file:``).

A ``moveit_msgs/PlanningScene`` (or a bare ``PlanningSceneWorld``) lists its obstacles in
``world.collision_objects[]``; each object has an ``id``, an optional object ``pose`` and
``primitives[]`` with ``primitive_poses[]`` (and ``meshes[]`` with ``mesh_poses[]``), every
primitive and mesh pose relative to the object's pose:

    T_world(body k) = T(object.pose) @ T(primitive_poses[k])

A pose is ``position`` ``[x, y, z]`` (or ``{x, y, z}``) and ``orientation`` a quaternion ``[x, y, z, w]``
(or ``{x, y, z, w}``), normalized here (a zero one is an error); a missing pose is the identity.
Primitives (``type`` by name or by MoveIt's number) keep their sizes as forte's shapes:
``box`` ``[x, y, z]`` full edges; ``cylinder`` ``[height, radius]`` along the body's z axis (forte's
and coal's axis too); ``sphere`` ``[radius]``; a ``cone`` has no forte shape and is refused. A mesh
(``vertices`` and ``triangles[].vertex_indices``) is written once as an OBJ file named by the hash
of its contents under ``$FORTE_CACHE/meshes`` (``~/.cache/forte/meshes``) and read back as a
:class:`~forte.model.scene.Mesh`. Only ``operation: ADD`` (or none) is read: a scene file lists what
is there. Every pose is taken in the world frame (the robot's base frame for a fixed arm);
``header.frame_id`` is not resolved.

Bodies are named by the object's ``id``; an object of several shapes gives ``id_0``, ``id_1``, ...
(primitives first, then meshes). Every error is one line naming the file and the field path.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from forte.exceptions import InvalidInputError
from forte.model.scene import Box, Cylinder, Mesh, SceneObject, Shape, Sphere
from forte.validation import FloatArray

#: MoveIt's ``shape_msgs/SolidPrimitive`` type numbers.
PRIMITIVE_TYPES = {1: "box", 2: "sphere", 3: "cylinder", 4: "cone"}
#: Each primitive's dimensions, in MoveIt's order.
DIMENSIONS = {"box": ("x, y, z", 3), "cylinder": ("height, radius", 2), "sphere": ("radius", 1)}
#: MoveIt's ``CollisionObject`` operations by number; only ADD is read.
OPERATIONS = {0: "ADD", 1: "REMOVE", 2: "APPEND", 3: "MOVE"}


def read_planning_scene(path: Path, data: Any = None) -> tuple[SceneObject, ...]:
    """The bodies of the PlanningScene YAML ``path`` (its parsed ``data`` when already read)."""
    if data is None:
        data = load_yaml(path)
    where = Where(path.name)
    if not isinstance(data, dict):
        raise where.error("(top level)", f"expected a MoveIt PlanningScene mapping, got {type(data).__name__}")
    if "world" in data:
        world, prefix = data["world"], "world."
        if not isinstance(world, dict):
            raise where.error("world", f"expected a mapping with collision_objects, got {type(world).__name__}")
    elif "collision_objects" in data:
        world, prefix = data, ""
    else:
        raise where.error("world", "required (a MoveIt PlanningScene's world.collision_objects); scene_file takes a "
                          ".urdf, an MJCF .xml or a PlanningScene .yaml")
    objects = world.get("collision_objects") or []
    if not isinstance(objects, list):
        raise where.error(f"{prefix}collision_objects", f"expected a list, got {type(objects).__name__}")
    bodies: list[SceneObject] = []
    for i, obj in enumerate(objects):
        bodies += _object(obj, where, f"{prefix}collision_objects[{i}]")
    return tuple(bodies)


def load_yaml(path: Path) -> Any:
    """The YAML document at ``path`` (libyaml's safe loader when built in: 10x faster on these files)."""
    import yaml

    try:
        return yaml.load(path.read_text(encoding="utf-8"), Loader=getattr(yaml, "CSafeLoader", yaml.SafeLoader))
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as exc:
        raise InvalidInputError(f"{path.name}: cannot read it as YAML: {str(exc).splitlines()[0]}") from exc


class Where:
    """Errors that name the file and the field path."""

    def __init__(self, name: str) -> None:
        self.name = name

    def error(self, field: str, message: str) -> InvalidInputError:
        return InvalidInputError(f"{self.name}: {field}: {message}")


def _object(obj: Any, where: Where, at: str) -> list[SceneObject]:
    if not isinstance(obj, dict):
        raise where.error(at, f"expected a collision object mapping, got {type(obj).__name__}")
    name = obj.get("id")
    if not isinstance(name, str | int) or isinstance(name, bool) or str(name) == "":
        raise where.error(f"{at}.id", f"expected a non-empty name, got {name!r}")
    operation = obj.get("operation", "ADD")
    operation = OPERATIONS.get(operation, operation) if isinstance(operation, int) else str(operation).upper()
    if operation != "ADD":
        raise where.error(f"{at}.operation", f"only ADD is read (a scene file lists what is there), got {operation}")
    T_obj = moveit_pose(obj["pose"], where, f"{at}.pose") if obj.get("pose") is not None else np.eye(4)
    shapes: list[tuple[Shape, FloatArray]] = []
    for key, poses_key, read in (("primitives", "primitive_poses", primitive_shape), ("meshes", "mesh_poses", _mesh)):
        items, poses = obj.get(key) or [], obj.get(poses_key) or []
        if not isinstance(items, list) or not isinstance(poses, list):
            raise where.error(f"{at}.{key}", "expected lists of shapes and of their poses")
        if len(poses) != len(items):
            raise where.error(f"{at}.{poses_key}", f"expected {len(items)} poses (one per entry of {key}), "
                              f"got {len(poses)}")
        for k, (item, pose) in enumerate(zip(items, poses, strict=True)):
            shape = read(item, where, f"{at}.{key}[{k}]")
            shapes.append((shape, T_obj @ moveit_pose(pose, where, f"{at}.{poses_key}[{k}]")))
    if not shapes:
        raise where.error(at, f"object {name!r} has no primitives or meshes")
    if len(shapes) == 1:
        return [SceneObject(str(name), shapes[0][0], shapes[0][1])]
    return [SceneObject(f"{name}_{k}", shape, T) for k, (shape, T) in enumerate(shapes)]


def primitive_shape(item: Any, where: Where, at: str) -> Shape:
    if not isinstance(item, dict):
        raise where.error(at, f"expected a primitive mapping (type, dimensions), got {type(item).__name__}")
    kind = item.get("type")
    kind = PRIMITIVE_TYPES.get(kind, kind) if isinstance(kind, int) and not isinstance(kind, bool) else kind
    if kind == "cone":
        raise where.error(f"{at}.type", "a cone has no forte shape; replace it by a cylinder or a mesh")
    if kind not in DIMENSIONS:
        raise where.error(f"{at}.type", f"expected one of box, cylinder, sphere, got {kind!r}")
    words, count = DIMENSIONS[kind]
    dims = item.get("dimensions")
    if not isinstance(dims, list) or len(dims) != count:
        got = f"{len(dims)}" if isinstance(dims, list) else repr(dims)
        raise where.error(f"{at}.dimensions", f"expected {count} number{'s' if count > 1 else ''} ({words}) "
                          f"for a {kind}, got {got}")
    values = _numbers(dims, where, f"{at}.dimensions")
    if np.any(values <= 0):
        raise where.error(f"{at}.dimensions", f"expected sizes > 0 m, got {values.tolist()}")
    if kind == "box":
        return Box(tuple(map(float, values)))
    if kind == "cylinder":
        return Cylinder(radius=float(values[1]), length=float(values[0]))
    return Sphere(float(values[0]))


def _mesh(item: Any, where: Where, at: str) -> Mesh:
    if not isinstance(item, dict):
        raise where.error(at, f"expected a mesh mapping (vertices, triangles), got {type(item).__name__}")
    vertices, triangles = item.get("vertices"), item.get("triangles")
    if not isinstance(vertices, list) or not vertices:
        raise where.error(f"{at}.vertices", "expected a list of points")
    if not isinstance(triangles, list) or not triangles:
        raise where.error(f"{at}.triangles", "expected a list of triangles (vertex_indices)")
    V = np.array([_point(v, where, f"{at}.vertices[{i}]") for i, v in enumerate(vertices)])
    faces = []
    for i, tri in enumerate(triangles):
        idx = tri.get("vertex_indices") if isinstance(tri, dict) else tri
        ints = isinstance(idx, list) and all(isinstance(j, int) and not isinstance(j, bool) for j in idx)
        if not ints or len(idx) != 3 or min(idx) < 0 or max(idx) >= len(V):
            raise where.error(f"{at}.triangles[{i}].vertex_indices",
                              f"expected 3 vertex indices in [0, {len(V) - 1}], got {idx!r}")
        faces.append(idx)
    return Mesh(_obj_file(V, np.array(faces)))


def _obj_file(V: FloatArray, F: Any) -> Path:
    """An OBJ file of the mesh, named by the hash of its text (written once, then reused)."""
    text = "".join(f"v {x!r} {y!r} {z!r}\n" for x, y, z in V.tolist())
    text += "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in F.tolist())
    root = Path(os.environ.get("FORTE_CACHE") or Path.home() / ".cache" / "forte") / "meshes"
    path = root / f"{hashlib.sha256(text.encode()).hexdigest()[:20]}.obj"
    if not path.is_file():
        root.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(f".{os.getpid()}.tmp")
        tmp.write_text(text, encoding="utf-8")
        os.replace(tmp, path)
    return path


def _numbers(values: Any, where: Where, at: str) -> FloatArray:
    if not isinstance(values, list) or any(isinstance(v, bool) or not isinstance(v, int | float) for v in values):
        raise where.error(at, f"expected numbers, got {values!r}")
    arr = np.asarray(values, dtype=float)
    if not np.all(np.isfinite(arr)):
        raise where.error(at, f"expected finite numbers, got {values!r}")
    return arr


def _point(value: Any, where: Where, at: str) -> FloatArray:
    """``[x, y, z]`` or ``{x, y, z}``."""
    if isinstance(value, dict):
        value = [value.get(k) for k in "xyz"]
    if not isinstance(value, list) or len(value) != 3:
        raise where.error(at, f"expected 3 numbers (x, y, z), got {value!r}")
    return _numbers(value, where, at)


def moveit_pose(value: Any, where: Where, at: str) -> FloatArray:
    """4x4 transform of a MoveIt pose (module docstring)."""
    if not isinstance(value, dict):
        raise where.error(at, f"expected a pose mapping (position, orientation), got {type(value).__name__}")
    T = np.eye(4)
    if value.get("position") is not None:
        T[:3, 3] = _point(value["position"], where, f"{at}.position")
    if value.get("orientation") is not None:
        T[:3, :3] = quaternion_matrix(unit_quaternion(value["orientation"], where, f"{at}.orientation"))
    return T


def unit_quaternion(value: Any, where: Where, at: str) -> FloatArray:
    if isinstance(value, dict):
        value = [value.get(k) for k in "xyzw"]
    if not isinstance(value, list) or len(value) != 4:
        raise where.error(at, f"expected a quaternion of 4 numbers (x, y, z, w), got {value!r}")
    q = _numbers(value, where, at)
    norm = float(np.linalg.norm(q))
    if norm < 1e-9:
        raise where.error(at, f"a zero quaternion is no rotation; expected (x, y, z, w) of norm 1, got {value!r}")
    return q / norm


def quaternion_matrix(q: Any) -> FloatArray:
    """Rotation matrix of the unit quaternion ``q = (x, y, z, w)`` (Pinocchio's, as the task files'
    ``orientation.quaternion``)."""
    x, y, z, w = np.asarray(q, dtype=float)
    return pin.Quaternion(w, x, y, z).toRotationMatrix()
