"""The robot's collision geometry for the optimizer: spheres and vertical capsules that contain it.

Every primitive hangs on a frame: an arm joint (index ``j`` of the arm's joints, root to tip) or
the base frame (``-1``). It is a segment of half length ``half_height`` along the *world* z axis
(the base's frame stays upright, so only base primitives have one; an arm primitive is a
sphere, ``half_height = 0``) swollen by ``radius``.

How the cover is built, and why it contains the real geometry:

- **Arm links** (the URDF's collision meshes): a capsule per link (over all its meshes), its
  axis the vertices' principal direction through their mean, its segment spanning their projections (shortened
  while that shrinks its volume), its radius ``R`` the largest distance of a vertex to the
  segment. The capsule is convex and holds every vertex, so it holds the mesh (every point of
  a triangle is a convex combination of its vertices). The capsule is then covered by ``k``
  spheres centred on the segment, the two ends included, ``s = L / (k - 1) <= R`` apart, of
  radius ``sqrt(R^2 + (s / 2)^2)``: a point within ``R`` of the segment is within ``s / 2`` of a
  centre along it (or within ``R`` of an end centre), so within that radius of a centre. The
  cover is at most ``(sqrt(1.25) - 1) R`` (~12 % of ``R``) thicker than the capsule.
- **A box fixed to the base, upright** (TIAGo's torso column): vertical capsules on a grid of
  its footprint, as the base below (:func:`upright_box_capsules`): tighter than a capsule
  around a square section, whose corners it must reach.
- **The base** (a box of :data:`~forte.model.description.BASE_BOX_HALF_XY` from the floor to the
  mount): vertical capsules from z = 0 to the mount height on a grid of the footprint, each of
  the radius of its grid cell's half diagonal, so the cells' circles cover the rectangle.

- **The payload**: its sphere (:func:`payload_primitive`), exactly.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np
import pinocchio as pin

from forte.model.description import BASE_BOX_HALF_XY, BASE_BOX_MIN_HEIGHT, PAYLOAD_RADIUS, has_base_box
from forte.model.self_collision import link_of
from forte.validation import FloatArray

#: Frame index of a primitive fixed to the base.
BASE_FRAME = -1

#: Grid of vertical capsules over the base's footprint (along x, along y).
BASE_GRID = (4, 3)


class Primitive(NamedTuple):
    """A segment of half length ``half_height`` along world z, centred at ``centre`` (frame
    axes), swollen by ``radius`` (m); ``piece`` names the geometry it covers."""

    frame: int
    centre: FloatArray
    half_height: float
    radius: float
    piece: str


def capsule_of(points: FloatArray) -> tuple[FloatArray, FloatArray, float]:
    """A capsule ``(a, b, R)`` that contains ``points`` (M x 3): segment ``a``-``b``, radius ``R``."""
    mean = points.mean(axis=0)
    centred = points - mean
    axis = np.linalg.svd(centred, full_matrices=False)[2][0]
    t = centred @ axis
    lo, hi = float(t.min()), float(t.max())
    best = None
    for shrink in np.linspace(0.0, 0.5, 26):  # shorten the segment while the volume drops
        a_t, b_t = lo + shrink * (hi - lo) / 2, hi - shrink * (hi - lo) / 2
        foot = np.clip(t, a_t, b_t)
        radius = float(np.max(np.linalg.norm(centred - foot[:, None] * axis, axis=1)))
        volume = np.pi * radius**2 * (b_t - a_t) + 4 / 3 * np.pi * radius**3
        if best is None or volume < best[0]:
            best = (volume, mean + a_t * axis, mean + b_t * axis, radius)
    return best[1], best[2], best[3]


def spheres_of_capsule(a: FloatArray, b: FloatArray, radius: float) -> tuple[FloatArray, float]:
    """Centres (k x 3) and the common radius of spheres that cover capsule ``(a, b, radius)``."""
    length = float(np.linalg.norm(b - a))
    if length < 1e-9:
        return a[None].copy(), radius
    intervals = max(1, int(np.ceil(length / radius)))
    s = length / intervals
    centres = a + np.linspace(0.0, 1.0, intervals + 1)[:, None] * (b - a)
    return centres, float(np.sqrt(radius**2 + (s / 2) ** 2))


def base_primitives(height: float) -> list[Primitive]:
    """Vertical capsules whose union holds the base box (see the module docstring)."""
    hx, hy = BASE_BOX_HALF_XY
    nx, ny = BASE_GRID
    cx, cy = hx / nx, hy / ny  # half cell
    radius = float(np.hypot(cx, cy))
    out = []
    for x in np.linspace(-hx + cx, hx - cx, nx):
        for y in np.linspace(-hy + cy, hy - cy, ny):
            out.append(Primitive(BASE_FRAME, np.array([x, y, height / 2]), height / 2, radius, "base"))
    return out


def arm_primitives(robot: Any) -> list[Primitive]:
    """Sphere chains over the arm's URDF collision meshes (none when it has no meshes)."""
    from forte.model.self_collision import arm_geometry

    geometry = arm_geometry(robot)
    if geometry is None:
        return []
    mount = pin.SE3(robot.mount[:3, :3].copy(), robot.mount[:3, 3].copy())
    links: dict[str, tuple[int, list[FloatArray], list[Primitive] | None]] = {}
    for obj in geometry.geom.geometryObjects:
        vertices = _vertices(obj.geometry)
        if vertices is None:
            continue
        placement, joint = obj.placement, obj.parentJoint
        if joint == 0:  # on the arm's root link: fixed to the base, through the mount
            placement, frame = mount * placement, BASE_FRAME
        else:
            frame = robot.model.getJointId(geometry.model.names[joint]) - 1
        points = vertices @ placement.rotation.T + placement.translation
        link = link_of(obj.name)
        columns = upright_box_capsules(obj.geometry, placement, link) if frame == BASE_FRAME else None
        links.setdefault(link, (frame, [], columns))[1].append(points)
    out = []
    for link, (frame, parts, columns) in links.items():  # one capsule per link, over all its pieces
        if columns is not None and len(parts) == 1:
            out += columns
            continue
        centres, radius = spheres_of_capsule(*capsule_of(np.vstack(parts)))
        out += [Primitive(frame, c, 0.0, radius, link) for c in centres]
    return out


#: Largest half cell (m) of the grid of vertical capsules over an upright box fixed to the base.
BOX_HALF_CELL = 0.06


def upright_box_capsules(shape: Any, placement: pin.SE3, link: str) -> list[Primitive] | None:
    """Vertical capsules whose union holds a box fixed to the base with its z axis upright (e.g.
    TIAGo's torso column), as :func:`base_primitives` covers the base box: its footprint cut into
    ``n_x x n_y`` cells of half sides at most :data:`BOX_HALF_CELL`, a capsule through each cell's
    centre over the box's height, of the cell's half diagonal. A square column of 0.23 m is 4
    capsules of 0.081 m, at most 2.4 cm outside its faces, where one chain of spheres around it
    (0.185 m) is up to 7 cm outside and 2.2 cm at its edges: the cover's distance then follows the
    box's as a hand moves round it. ``None`` for any other shape or a tilted box."""
    import coal

    rotation = placement.rotation
    if not isinstance(shape, coal.Box) or abs(rotation[2, 2]) < 1.0 - 1e-9:
        return None
    hx, hy, hz = np.asarray(shape.halfSide, dtype=float)
    nx, ny = (max(1, int(np.ceil(h / BOX_HALF_CELL - 1e-9))) for h in (hx, hy))
    cx, cy = hx / nx, hy / ny
    radius = float(np.hypot(cx, cy))
    return [Primitive(BASE_FRAME, rotation @ np.array([x, y, 0.0]) + placement.translation, float(hz), radius, link)
            for x in np.linspace(-hx + cx, hx - cx, nx) for y in np.linspace(-hy + cy, hy - cy, ny)]


def payload_primitive(robot: Any) -> Primitive:
    """The payload's sphere (:data:`~forte.model.description.PAYLOAD_RADIUS`, centred at the end
    effector) on the end effector's joint: the shape MuJoCo's hand holds."""
    frame = robot.model.frames[robot.ee_frame_id]
    return Primitive(frame.parentJoint - 1, np.array(frame.placement.translation), 0.0, PAYLOAD_RADIUS, "payload")


def _vertices(shape: Any) -> FloatArray | None:
    """Vertices of a coal mesh, or of a box / sphere / cylinder / capsule's bounding corners."""
    import coal

    if hasattr(shape, "num_vertices") and shape.num_vertices:
        return np.asarray(shape.vertices(), dtype=float).reshape(-1, 3)
    if isinstance(shape, coal.Box):
        h = np.asarray(shape.halfSide)
        return np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * h
    if isinstance(shape, coal.Sphere | coal.Cylinder | coal.Capsule):
        r = float(shape.radius)
        h = float(getattr(shape, "halfLength", 0.0)) + (r if isinstance(shape, coal.Capsule | coal.Sphere) else 0.0)
        return np.array([[sx * r, sy * r, sz * h] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    return None


_CACHE: dict[str, tuple[Primitive, ...]] = {}


def robot_primitives(robot: Any) -> tuple[Primitive, ...]:
    """The robot's cover: the base's capsules, the arm's spheres, the payload's sphere (cached
    per robot)."""
    key = robot.fingerprint + str(robot.urdf_path)
    if key not in _CACHE:
        height = max(float(robot.mount[2, 3]), BASE_BOX_MIN_HEIGHT)
        base = base_primitives(height) if has_base_box(robot) else []
        _CACHE[key] = tuple(base + arm_primitives(robot) + [payload_primitive(robot)])
    return _CACHE[key]


def primitive_centres(robot: Any, q: Any, primitives: tuple[Primitive, ...]) -> FloatArray:
    """World-frame centres (P x 3) of ``primitives`` at whole-body configuration ``q``."""
    q = np.asarray(q, dtype=float)
    pin.forwardKinematics(robot.model, robot.data, q[3:])
    base = robot.base_transform(q[:3])
    frames = np.array([p.frame + 1 for p in primitives], dtype=int)
    local = np.array([p.centre for p in primitives]).reshape(-1, 3)
    rotations = np.empty((robot.n_arm + 1, 3, 3))
    offsets = np.empty((robot.n_arm + 1, 3))
    rotations[0], offsets[0] = np.eye(3), 0.0
    for j in range(robot.n_arm):
        placement = robot.data.oMi[j + 1]
        rotations[j + 1], offsets[j + 1] = placement.rotation, placement.translation
    in_base = np.einsum("pij,pj->pi", rotations[frames], local) + offsets[frames]
    return in_base @ base[:3, :3].T + base[:3, 3]
