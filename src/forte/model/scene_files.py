"""Static bodies read from a URDF, an MJCF or a MoveIt PlanningScene file (a task's ``scene_file:``).

- URDF: every ``<collision>`` element, placed by the forward kinematics of the file's neutral
  configuration (Pinocchio); the bodies are named ``<link>/<index>`` as Pinocchio names them.
- MJCF: every geom welded to the world (its body has no joint up to the world), placed by
  MuJoCo's forward kinematics; planes are skipped (forte's floor is z = 0). Geoms with
  ``contype = conaffinity = 0`` are visual only and skipped too.

Both keep boxes, cylinders, spheres and capsules as such and meshes as meshes (the file the
description names, with its scale). A ``.yaml``/``.yml`` file is a MoveIt ``PlanningScene``
(recognised by its ``world:`` key), read by :mod:`forte.model.moveit_scene`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from forte.exceptions import InvalidInputError
from forte.model.scene import Box, Capsule, Cylinder, Mesh, SceneObject, Shape, Sphere


def read_scene_file(path: Path) -> tuple[SceneObject, ...]:
    """The static bodies of ``path`` (``.urdf``, ``.xml``/``.mjcf`` or a PlanningScene ``.yaml``)."""
    if not path.is_file():
        raise InvalidInputError(f"no such file {path}")
    suffix = path.suffix.lower()
    if suffix == ".urdf":
        return _from_urdf(path)
    if suffix in (".xml", ".mjcf"):
        return _from_mjcf(path)
    if suffix in (".yaml", ".yml"):
        from forte.model.moveit_scene import read_planning_scene

        return read_planning_scene(path)
    raise InvalidInputError(f"{path.name}: expected a .urdf, an MJCF .xml or a MoveIt PlanningScene .yaml file")


def _from_urdf(path: Path) -> tuple[SceneObject, ...]:
    import coal
    import pinocchio as pin

    try:
        model = pin.buildModelFromUrdf(str(path))
        geom = pin.buildGeomFromUrdf(model, str(path), pin.COLLISION, package_dirs=[str(path.parent)])
    except Exception as exc:  # Pinocchio raises plain RuntimeError / ValueError
        raise InvalidInputError(f"{path.name}: cannot read it as a URDF: {str(exc).splitlines()[0]}") from exc
    data, geom_data = model.createData(), geom.createData()
    pin.updateGeometryPlacements(model, data, geom, geom_data, pin.neutral(model))
    objects = []
    for obj, placement in zip(geom.geometryObjects, geom_data.oMg, strict=True):
        g = obj.geometry
        if isinstance(g, coal.Box):
            shape: Shape = Box(tuple(float(v) for v in 2 * np.asarray(g.halfSide)))
        elif isinstance(g, coal.Cylinder):
            shape = Cylinder(float(g.radius), 2 * float(g.halfLength))
        elif isinstance(g, coal.Sphere):
            shape = Sphere(float(g.radius))
        elif isinstance(g, coal.Capsule):
            shape = Capsule(float(g.radius), 2 * float(g.halfLength))
        elif obj.meshPath:
            shape = Mesh(Path(obj.meshPath), tuple(float(v) for v in obj.meshScale))
        else:
            raise InvalidInputError(f"{path.name}: collision geometry {obj.name} has a shape forte does not read")
        objects.append(SceneObject(obj.name, shape, np.array(placement.homogeneous)))
    return tuple(objects)


def _from_mjcf(path: Path) -> tuple[SceneObject, ...]:
    import mujoco

    try:
        spec = mujoco.MjSpec.from_file(str(path))
        model = spec.compile()
    except Exception as exc:  # MuJoCo reports parse and compile errors as ValueError
        raise InvalidInputError(f"{path.name}: cannot read it as MJCF: {str(exc).splitlines()[0]}") from exc
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    meshdir = path.parent / (spec.meshdir or "")
    objects = []
    for i in range(model.ngeom):
        if model.body_weldid[model.geom_bodyid[i]] != 0 or model.geom_type[i] == mujoco.mjtGeom.mjGEOM_PLANE:
            continue
        if model.geom_contype[i] == 0 and model.geom_conaffinity[i] == 0:
            continue
        name = model.geom(i).name or f"geom{i}"
        shape = _mjcf_shape(spec, model, i, meshdir, path)
        T = np.eye(4)
        T[:3, :3] = data.geom_xmat[i].reshape(3, 3)
        T[:3, 3] = data.geom_xpos[i]
        if isinstance(shape, Mesh):  # MuJoCo recentres a mesh: back to the file's own frame
            T = T @ np.linalg.inv(_mesh_offset(model, int(model.geom_dataid[i])))
        objects.append(SceneObject(name, shape, T))
    return tuple(objects)


def _mjcf_shape(spec: Any, model: Any, i: int, meshdir: Path, path: Path) -> Shape:
    import mujoco

    kind, size = model.geom_type[i], model.geom_size[i]
    if kind == mujoco.mjtGeom.mjGEOM_BOX:
        return Box(tuple(float(2 * v) for v in size))
    if kind == mujoco.mjtGeom.mjGEOM_SPHERE:
        return Sphere(float(size[0]))
    if kind == mujoco.mjtGeom.mjGEOM_CYLINDER:
        return Cylinder(float(size[0]), float(2 * size[1]))
    if kind == mujoco.mjtGeom.mjGEOM_CAPSULE:
        return Capsule(float(size[0]), float(2 * size[1]))
    if kind == mujoco.mjtGeom.mjGEOM_MESH:
        mesh_id = int(model.geom_dataid[i])
        mesh = spec.mesh(model.mesh(mesh_id).name)
        return Mesh(meshdir / mesh.file, tuple(float(v) for v in model.mesh_scale[mesh_id]))
    raise InvalidInputError(f"{path.name}: geom {model.geom(i).name or i} has a type forte does not read")


def _mesh_offset(model: Any, mesh_id: int) -> Any:
    """The transform MuJoCo applied to mesh ``mesh_id``'s file frame (``mesh_pos``, ``mesh_quat``)."""
    import mujoco

    T = np.eye(4)
    R = np.zeros(9)
    mujoco.mju_quat2Mat(R, model.mesh_quat[mesh_id])
    T[:3, :3] = R.reshape(3, 3)
    T[:3, 3] = model.mesh_pos[mesh_id]
    return T
