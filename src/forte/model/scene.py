"""The world around the robot: static bodies of simple shapes or meshes, posed in the world frame.

The world frame is the robot's start base frame (z up, the floor at z = 0 unless the task moves
it); lengths are metres, angles radians, and a pose ``[x, y, z, roll, pitch, yaw]`` places a body's centre with the
rotation ``Rz(yaw) Ry(pitch) Rx(roll)`` (URDF's convention).

Shapes (each centred on its pose; a cylinder's and a capsule's axis is the body's z axis):

- :class:`Box` ``size`` = full edge lengths (x, y, z);
- :class:`Cylinder` ``radius``, ``length``;
- :class:`Sphere` ``radius``;
- :class:`Capsule` ``radius``, ``length`` (of the segment between the two cap centres);
- :class:`Mesh` a triangle mesh file (STL, OBJ, DAE, ... as coal's loader reads), scaled.

Two views of every body serve two consumers:

- the exact geometry (:meth:`SceneObject.collision_geometry`, a coal shape or mesh) for the
  after-solve clearance check and MuJoCo;
- a *proxy* for the optimizer (:meth:`SceneObject.proxy`): a rounded box, the Minkowski sum of a
  box of half extents ``(hx, hy, hz)``, a disk of radius ``rho`` in its xy-plane and a ball of
  radius ``sigma``, whose signed distance has a closed form (:func:`proxy_distance`). Box, cylinder,
  sphere and capsule are proxies exactly; a mesh's proxy is its bounding box in its own axes,
  which contains it, so a distance to the proxy never exceeds the distance to the mesh.

**The floor** is part of every world: the half-space ``z <= floor`` (:attr:`Scene.floor`, the
height in the world frame, default 0, the plane MuJoCo's robot rides on; ``None``: no floor). It
is not one of the scene's ``objects``: the exact check takes it as coal's half-space, MuJoCo as
its plane, and the optimizer as :func:`floor_proxy`, a box of half extent :data:`FLOOR_HALF`
whose top face is the floor (for a point above the floor and within the box's sides the rounded
box distance is ``z - floor`` exactly, below it ``z - floor`` too: the top face is the nearest).
The parts rigid with the base (the base box, the arm's links with no joint between them and the
base) rest on it and are never checked against it.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import pinocchio as pin

from forte.exceptions import InvalidInputError
from forte.validation import FloatArray


class Box(NamedTuple):
    size: tuple[float, float, float]


class Cylinder(NamedTuple):
    radius: float
    length: float


class Sphere(NamedTuple):
    radius: float


class Capsule(NamedTuple):
    radius: float
    length: float


class Mesh(NamedTuple):
    file: Path
    scale: tuple[float, float, float] = (1.0, 1.0, 1.0)


Shape = Box | Cylinder | Sphere | Capsule | Mesh

#: The shape names of a scene entry, as the task file spells them.
SHAPE_KINDS: dict[str, type] = {"box": Box, "cylinder": Cylinder, "sphere": Sphere, "capsule": Capsule,
                                "mesh": Mesh}


class Proxy(NamedTuple):
    """The optimizer's view of a body: a rounded box (see the module docstring).

    ``pose`` (4x4) is the proxy's centre and axes in the world; ``half`` = (hx, hy, hz) the box's
    half extents; ``rho`` the radius of the disk swept in the xy-plane; ``sigma`` the ball's.
    """

    pose: FloatArray
    half: FloatArray
    rho: float
    sigma: float

    def vector(self) -> FloatArray:
        """The 17 numbers the optimizer's kernels take: ``R`` (column-major 9), centre 3, half 3,
        rho, sigma."""
        return np.concatenate([self.pose[:3, :3].ravel(order="F"), self.pose[:3, 3], self.half,
                               [self.rho, self.sigma]])


#: Length of :meth:`Proxy.vector`.
PROXY_SIZE = 17


def pose_matrix(values: Any) -> FloatArray:
    """4x4 transform of ``[x, y, z, roll, pitch, yaw]``."""
    x = np.asarray(values, dtype=float)
    T = np.eye(4)
    T[:3, :3] = pin.rpy.rpyToMatrix(*x[3:])
    T[:3, 3] = x[:3]
    return T


def proxy_distance(proxy: Proxy, points: Any) -> FloatArray:
    """Signed distance (m) from each point (... x 3) to ``proxy``: negative inside.

    In the proxy's axes, ``p``: the xy cross-section is a rectangle of half extents (hx, hy)
    grown by ``rho``, with signed distance ``a = |max(|p_xy| - h_xy, 0)| + min(max(|p_xy| - h_xy),
    0) - rho``; extruding it over ``|p_z| <= hz`` gives ``|max((a, b), 0)| + min(max(a, b), 0)``
    with ``b = |p_z| - hz``; the ball subtracts ``sigma``. Each step is the exact signed distance
    of the grown shape (a rounding or an extrusion of an exact distance stays exact).
    """
    p = (np.asarray(points, dtype=float) - proxy.pose[:3, 3]) @ proxy.pose[:3, :3]
    return rounded_box_distance(p, proxy.half, proxy.rho, proxy.sigma)


def rounded_box_distance(p: Any, half: Any, rho: Any, sigma: Any) -> FloatArray:
    """:func:`proxy_distance` for points ``p`` (... x 3) already in the proxy's axes; ``half``
    (... x 3), ``rho`` and ``sigma`` broadcast against the points (many proxies at once)."""
    half = np.asarray(half, dtype=float)
    qx, qy = np.abs(p[..., 0]) - half[..., 0], np.abs(p[..., 1]) - half[..., 1]
    a = np.hypot(np.maximum(qx, 0), np.maximum(qy, 0)) + np.minimum(np.maximum(qx, qy), 0) - rho
    b = np.abs(p[..., 2]) - half[..., 2]
    return np.hypot(np.maximum(a, 0), np.maximum(b, 0)) + np.minimum(np.maximum(a, b), 0) - sigma


class SceneObject(NamedTuple):
    """One static body: its ``name``, ``shape`` and ``pose`` (4x4, world frame)."""

    name: str
    shape: Shape
    pose: FloatArray

    def proxy(self) -> Proxy:
        """The optimizer's rounded box for this body (exact, or a mesh's bounding box)."""
        s, T = self.shape, self.pose
        if isinstance(s, Box):
            return Proxy(T, np.asarray(s.size, float) / 2, 0.0, 0.0)
        if isinstance(s, Cylinder):
            return Proxy(T, np.array([0.0, 0.0, s.length / 2]), float(s.radius), 0.0)
        if isinstance(s, Sphere):
            return Proxy(T, np.zeros(3), 0.0, float(s.radius))
        if isinstance(s, Capsule):
            return Proxy(T, np.array([0.0, 0.0, s.length / 2]), 0.0, float(s.radius))
        vertices = mesh_vertices(s)
        lo, hi = vertices.min(axis=0), vertices.max(axis=0)
        centre = np.eye(4)
        centre[:3, 3] = (lo + hi) / 2
        return Proxy(T @ centre, (hi - lo) / 2, 0.0, 0.0)

    def collision_geometry(self) -> Any:
        """The exact shape as a coal geometry (in the body's own frame)."""
        import coal

        s = self.shape
        if isinstance(s, Box):
            return coal.Box(*map(float, s.size))
        if isinstance(s, Cylinder):
            return coal.Cylinder(float(s.radius), float(s.length))
        if isinstance(s, Sphere):
            return coal.Sphere(float(s.radius))
        if isinstance(s, Capsule):
            return coal.Capsule(float(s.radius), float(s.length))
        return _load_mesh(s)


#: What the floor is called in clearances, violations and contacts.
FLOOR = "floor"
#: The floor's height (m, world z) when the task does not say.
DEFAULT_FLOOR = 0.0
#: Half extent (m) of the optimizer's floor box (:func:`floor_proxy`): far beyond any task's reach.
FLOOR_HALF = 1000.0


def floor_proxy(height: float) -> Proxy:
    """The optimizer's floor: a box of half extent :data:`FLOOR_HALF` whose top face is ``z = height``."""
    pose = np.eye(4)
    pose[2, 3] = height - FLOOR_HALF
    return Proxy(pose, np.full(3, FLOOR_HALF), 0.0, 0.0)


class Scene(NamedTuple):
    """Static bodies around the robot (empty: planning in free space, as the paper does) and the
    floor's height (m; ``None``: no floor). ``bool(scene)`` says whether there are bodies: the
    floor alone does not send a plan through the scene's solve (the planner gives it rows only
    when the robot comes near it, :mod:`forte.planning.scene.scene_solve`)."""

    objects: tuple[SceneObject, ...] = ()
    floor: float | None = DEFAULT_FLOOR

    def __bool__(self) -> bool:
        return bool(self.objects)

    @property
    def solid(self) -> bool:
        """Whether there is anything to keep clear of: a body or the floor."""
        return bool(self.objects) or self.floor is not None

    @property
    def names(self) -> list[str]:
        return [o.name for o in self.objects]

    def proxies(self) -> list[Proxy]:
        return [o.proxy() for o in self.objects]

    def distance(self, points: Any) -> FloatArray:
        """Signed distance (m) from each point (M x 3) to the nearest proxy (M x len(scene))."""
        pts = np.atleast_2d(np.asarray(points, dtype=float))
        if not self.objects:
            return np.full((len(pts), 0), np.inf)
        return np.stack([proxy_distance(p, pts) for p in self.proxies()], axis=-1)

    def describe(self) -> list[dict[str, Any]]:
        """The scene as plain data (plan.json): name, shape kind and parameters, pose 4x4."""
        out = []
        for o in self.objects:
            kind = next(k for k, cls in SHAPE_KINDS.items() if isinstance(o.shape, cls))
            params = {k: (str(v) if isinstance(v, Path) else (list(v) if isinstance(v, tuple) else v))
                      for k, v in o.shape._asdict().items()}
            out.append({"name": o.name, kind: params, "pose": o.pose.tolist()})
        return out


def mesh_vertices(mesh: Mesh) -> FloatArray:
    """The mesh's vertices (V x 3, scaled, in its own frame)."""
    return np.array(_load_mesh(mesh).vertices(), dtype=float).reshape(-1, 3)


def _load_mesh(mesh: Mesh) -> Any:
    import coal

    if not Path(mesh.file).is_file():
        raise InvalidInputError(f"mesh.file: no such file {mesh.file}")
    try:
        geometry = coal.MeshLoader().load(str(mesh.file), np.asarray(mesh.scale, dtype=float))
    except Exception as exc:  # assimp's errors come as RuntimeError / ValueError
        raise InvalidInputError(f"mesh.file: cannot read {mesh.file}: {str(exc).splitlines()[0]}") from exc
    if geometry.num_vertices == 0:
        raise InvalidInputError(f"mesh.file: {mesh.file} has no vertices")
    return geometry


def scene_from_json(entries: Any, floor: Any = DEFAULT_FLOOR) -> Scene:
    """The scene :meth:`Scene.describe` wrote (plan.json) with the ``floor`` height (``None``: no
    floor); ``ValueError`` when malformed."""
    if floor is not None:
        if isinstance(floor, bool) or not isinstance(floor, int | float) or not np.isfinite(floor):
            raise ValueError(f"floor: expected a height (m) or null, got {floor!r}")
        floor = float(floor)
    if entries is None:
        return Scene((), floor)
    if not isinstance(entries, list):
        raise ValueError("expected a list of bodies")
    objects = []
    for entry in entries:
        kind = next((k for k in SHAPE_KINDS if k in entry), None)
        if kind is None or not isinstance(entry[kind], dict):
            raise ValueError(f"body {entry.get('name')!r}: no shape")
        params = dict(entry[kind])
        if kind == "mesh":
            params = {"file": Path(params["file"]), "scale": tuple(map(float, params.get("scale", (1, 1, 1))))}
        elif kind == "box":
            params = {"size": tuple(map(float, params["size"]))}
        else:
            params = {k: float(v) for k, v in params.items()}
        pose = np.asarray(entry["pose"], dtype=float)
        if pose.shape != (4, 4) or not np.all(np.isfinite(pose)):
            raise ValueError(f"body {entry.get('name')!r}: pose is not a 4x4 matrix")
        objects.append(SceneObject(str(entry["name"]), SHAPE_KINDS[kind](**params), pose))
    return Scene(tuple(objects), floor)

