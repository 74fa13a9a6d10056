"""Contact between the robot and its world in the MuJoCo model: the scene's static bodies, the
floor, and which pairs of geometries may touch.

The robot's collision geometry is the arm's URDF collision elements (meshes or primitives, as
MuJoCo loads them), the base box (:data:`forte.model.description.BASE_BOX_HALF_XY`) and the
payload sphere held by the hand; all of it carries no mass (the bodies' inertias are the URDF's,
so ``mj_inverse`` still equals ``robot.rnea``). MuJoCo makes a contact pair of two geoms when
``contype_1 & conaffinity_2`` or ``contype_2 & conaffinity_1`` is non-zero, so with

| geom | contype | conaffinity |
|---|---|---|
| arm, payload | `ARM` | 0 |
| base box, the arm's links rigid with the base | `BASE` | 0 |
| floor | 0 | `ARM` (0 with ``floor: none``) |
| scene body | 0 | `ARM` and `BASE` |

the only pairs are arm-vs-scene, base-vs-scene and arm-vs-floor: never the arm against itself
(the plan's verdict judges self-collision) nor the base against the floor it rides on (its slide
joints hold it). The arm's links with no joint between them and the base (its root link, a whole
mobile base's wheels) belong to the base, as in the exact clearance check. The floor plane is at
the scene's floor height (:attr:`forte.model.scene.Scene.floor`).

MuJoCo collides a mesh as its convex hull: a concave scene mesh (an open shelf) touches
wherever its hull does; give such a body as boxes or convex pieces.

Scene bodies are static bodies ``scene/<name>`` posed by the scene's 4x4 poses in the world frame
(the robot's start base frame, the floor at z = 0); a mesh becomes a MuJoCo mesh asset read from
its file (STL, OBJ or MSH: the formats MuJoCo reads).
"""

from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import mujoco
import numpy as np

from forte.exceptions import SimulationError
from forte.model.scene import Box, Capsule, Cylinder, Mesh, Scene, Sphere

#: Contact bits (see the module docstring).
ARM = 1
BASE = 2
#: Contact bit of a contact task's object and the hand's pusher plate (:mod:`forte.execution.contact_objects`):
#: their contacts are the task's, not touches of the robot.
OBJECT = 4
#: Contact bit of a floor base's wheels and casters and of the ground they stand on
#: (:mod:`forte.execution.floor_base`): standing is not a touch.
SUPPORT = 8
#: Name prefix of the scene's bodies in the MuJoCo model.
SCENE_PREFIX = "scene/"
#: What a touch of the floor plane (a geom of the world body) is called.
FLOOR = "floor"
#: Mesh formats MuJoCo reads.
MUJOCO_MESH_SUFFIXES = (".stl", ".obj", ".msh")
SCENE_RGBA = (0.55, 0.45, 0.35, 0.6)


def add_scene(spec: mujoco.MjSpec, scene: Scene) -> None:
    """Add the scene's bodies to ``spec``'s world as static bodies that the robot touches."""
    for obj in scene.objects:
        R, p = obj.pose[:3, :3], obj.pose[:3, 3]
        quat = np.zeros(4)
        mujoco.mju_mat2Quat(quat, np.ascontiguousarray(R, dtype=float).reshape(9))
        body = spec.worldbody.add_body(name=SCENE_PREFIX + obj.name, pos=p.tolist(), quat=quat.tolist())
        geom = body.add_geom(name=SCENE_PREFIX + obj.name, contype=0, conaffinity=ARM | BASE, rgba=list(SCENE_RGBA),
                             mass=0.0, density=0.0)  # static: no inertia needed
        s = obj.shape
        if isinstance(s, Box):
            geom.type, geom.size = mujoco.mjtGeom.mjGEOM_BOX, [v / 2 for v in s.size]
        elif isinstance(s, Sphere):
            geom.type, geom.size = mujoco.mjtGeom.mjGEOM_SPHERE, [s.radius, 0, 0]
        elif isinstance(s, Cylinder):
            geom.type, geom.size = mujoco.mjtGeom.mjGEOM_CYLINDER, [s.radius, s.length / 2, 0]
        elif isinstance(s, Capsule):
            geom.type, geom.size = mujoco.mjtGeom.mjGEOM_CAPSULE, [s.radius, s.length / 2, 0]
        elif isinstance(s, Mesh):
            geom.type, geom.meshname = mujoco.mjtGeom.mjGEOM_MESH, _add_mesh(spec, obj.name, s)
        else:  # pragma: no cover - Shape is a closed union
            raise SimulationError(f"scene body {obj.name}: unknown shape {type(s).__name__}")


def _add_mesh(spec: mujoco.MjSpec, name: str, mesh: Mesh) -> str:
    path = Path(mesh.file).resolve()
    if path.suffix.lower() not in MUJOCO_MESH_SUFFIXES:
        raise SimulationError(f"scene body {name}: mesh {path.name}: MuJoCo reads {', '.join(MUJOCO_MESH_SUFFIXES)} "
                              "meshes only; convert it (e.g. to STL)")
    if not path.is_file():
        raise SimulationError(f"scene body {name}: mesh file {path} does not exist")
    spec.add_mesh(name=SCENE_PREFIX + name, file=str(path), scale=[float(v) for v in mesh.scale])
    return SCENE_PREFIX + name


def enable_robot_contacts(spec: mujoco.MjSpec, base: mujoco.MjsBody, floor: float | None = 0.0) -> None:
    """Give every robot geom its contact bit (``BASE`` for the base's box and every geom with no
    joint between it and the base, the rest ``ARM``) and the floor (the world's plane, moved to
    height ``floor``) ``conaffinity = ARM``, or none without a floor (``None``); all robot geoms
    stay massless."""
    for geom in spec.worldbody.geoms:
        if geom.type == mujoco.mjtGeom.mjGEOM_PLANE and not geom.conaffinity & SUPPORT:  # not the base's ground
            geom.conaffinity = 0 if floor is None else ARM
            geom.pos = [0.0, 0.0, 0.0 if floor is None else float(floor)]
    for geom in spec.geoms:
        if geom.parent.name.startswith(SCENE_PREFIX) or geom.parent == spec.worldbody or geom.contype & SUPPORT:
            continue
        geom.contype = BASE if _rigid_with(geom.parent, base) else ARM
        geom.conaffinity = 0
        geom.mass, geom.density = 0.0, 0.0


def _rigid_with(body: mujoco.MjsBody, base: mujoco.MjsBody) -> bool:
    """Whether ``body`` is ``base`` or hangs from it with no joint on the way."""
    while body != base:
        if body.joints or body.parent is None or body.parent == body:
            return False
        body = body.parent
    return True


class Touch(NamedTuple):
    """One pair in contact at one step: the robot's body, the world's body, the normal force (N)
    summed over the pair's contact points."""

    robot: str
    world: str
    force: float


def body_label(model: mujoco.MjModel, body: int, arm_prefix: str) -> str:
    """A body's name as reports give it: the floor, a scene body's own name, a robot link's URDF name."""
    if body == 0:
        return FLOOR
    name = model.body(body).name
    for prefix in (SCENE_PREFIX, arm_prefix):
        if name.startswith(prefix):
            return name[len(prefix):]
    return name


def touches(model: mujoco.MjModel, data: mujoco.MjData, arm_prefix: str) -> list[Touch]:
    """The robot-versus-world pairs in contact in ``data`` (after ``mj_step``: the contacts and
    forces of the step's start state), one entry per pair."""
    if data.ncon == 0:
        return []
    forces: dict[tuple[str, str], float] = {}
    wrench = np.zeros(6)
    for i in range(data.ncon):
        c = data.contact[i]
        if (model.geom_contype[c.geom1] | model.geom_contype[c.geom2]) & (OBJECT | SUPPORT):
            continue  # the task's object (its contacts are the task) or the base standing on the floor
        b1, b2 = int(model.geom_bodyid[c.geom1]), int(model.geom_bodyid[c.geom2])
        static1, static2 = model.body_weldid[b1] == 0, model.body_weldid[b2] == 0
        if static1 == static2:  # not a robot-versus-world pair (the contact bits never make one)
            continue
        robot, world = (b2, b1) if static1 else (b1, b2)
        mujoco.mj_contactForce(model, data, i, wrench)
        key = (body_label(model, robot, arm_prefix), body_label(model, world, arm_prefix))
        forces[key] = forces.get(key, 0.0) + float(wrench[0])
    return [Touch(r, w, f) for (r, w), f in forces.items()]

