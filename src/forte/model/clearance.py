"""Exact clearance between the whole robot and the scene (coal), for the after-solve check.

**The robot's parts** (:class:`Part`), placed in the world frame for a whole-body configuration:

- the arm's URDF collision geometry (links, hand and fingers, the fingers at neutral or their locked values as in
  :class:`~forte.model.self_collision.ArmGeometry`), placed by forward kinematics, the mount and the
  base transform. A mesh enters as its convex hull (qhull, through coal): for a convex mesh, as
  every collision mesh of the Panda is (hull volume within 0.1 % of the mesh's, distances equal to
  1e-4 m: tested), the hull *is* the mesh; for a concave one it contains the mesh, so the check
  never reports more clearance than there is (:attr:`ClearanceChecker.hull_excess` says by how
  much each hull is larger);
- the base box (:data:`~forte.model.description.BASE_BOX_HALF_XY`, from the floor up to the arm's
  mount), named ``base``;
- the payload, a sphere of :data:`~forte.model.description.PAYLOAD_RADIUS` at the end effector
  (the body MuJoCo's hand holds), named ``payload``.

**The floor** (:attr:`~forte.model.scene.Scene.floor`) is coal's half-space ``z <= floor``, named
``floor``; the parts rigid with the base (the base box and the arm's geometry with no joint
between it and the base, :attr:`ClearanceChecker.grounded`) rest on it and are not checked
against it: the base moves in the plane, so their height never changes
(:func:`floor_violation` checks it once, for the task).

**Signed distances.** Convex pairs (every robot part against a box, cylinder, sphere or capsule)
get coal's GJK distance, and when they overlap its EPA penetration depth, negated: the true
signed distance. A scene *mesh* stays a triangle mesh (shelves are concave): coal's distance is
then the smallest signed distance between one of its triangles and the robot part, negative by
that triangle's depth when they overlap (not the depth of the solids), and positive for a part
wholly inside a closed mesh that touches none of its triangles (a mesh has no inside for coal).

**Broad phase.** Every part has a bounding sphere (coal's local AABB: its centre ``c`` and the
radius ``r`` that contains the box) and every scene body its oriented box (that AABB in the body's
frame, placed by its pose). The pair's signed distance is bounded from below by both
``|c - c_b| - r - r_b`` (the body's sphere) and ``s(c) - r``, where ``s`` is the signed distance
of the point ``c`` to the body's box (negative inside, by its depth): outside the box by ``s``, the
part keeps at least ``s - r``; inside by ``e``, a shift of ``e + r`` along the nearest face takes
the part's sphere out of the box, so no overlap is deeper (for a mesh, no triangle's). The box
bound is the tight one for the long thin boards and walls of shelves and cages (whose spheres
contain the arm): a tenth of the coal calls on MotionBenchMaker's scenes. For the floor the bound
is the centre's height above it minus the radius. Per configuration, the pairs are tried in the
order of that bound and the narrow phase stops when the next bound is no smaller than the best
distance found: the exact minimum over all pairs, after typically one to five coal calls,
whatever the number of bodies.
"""

from __future__ import annotations

from functools import lru_cache
from typing import Any, NamedTuple

import numpy as np
import pinocchio as pin

from forte.model.description import BASE_BOX_HALF_XY, BASE_BOX_MIN_HEIGHT, PAYLOAD_RADIUS, has_base_box
from forte.model.robot import N_BASE, MobileManipulator
from forte.model.scene import FLOOR, Scene
from forte.model.self_collision import loaded_geometry, locked_key
from forte.validation import FloatArray

#: The names of the base box and the payload among the robot's parts.
BASE_PART = "base"
PAYLOAD_PART = "payload"


#: About how many (part, body) pairs' bounds :meth:`ClearanceChecker.evaluate` computes in one batch.
BOUND_PAIRS = 8192


class Part(NamedTuple):
    """A rigid piece of geometry: its ``name`` (the link, or a scene body's name), the coal
    ``geometry`` in its own frame, and its bounding sphere (``centre`` in that frame, ``radius``)."""

    name: str
    geometry: Any
    centre: FloatArray
    radius: float


class Clearances(NamedTuple):
    """Per configuration: the smallest signed distance (m) between the robot and the scene and
    the pair that has it (``robot`` part, scene ``body``), with the witness points on each (world
    frame). An empty scene gives ``inf``, empty names and ``nan`` points."""

    distance: FloatArray
    robot: tuple[str, ...]
    body: tuple[str, ...]
    witness_robot: FloatArray
    witness_body: FloatArray

    def closest(self) -> int:
        """Index of the configuration with the smallest distance."""
        return int(np.argmin(self.distance))


def _part(name: str, geometry: Any) -> Part:
    geometry.computeLocalAABB()
    return Part(name, geometry, np.array(geometry.aabb_center, dtype=float), float(geometry.aabb_radius))


def _convex(geometry: Any) -> tuple[Any, float]:
    """A mesh's convex hull and its relative excess volume (0 for a convex mesh); a shape as is."""
    if not hasattr(geometry, "buildConvexHull"):
        return geometry, 0.0
    geometry.buildConvexHull(True, "Qt")
    volume = geometry.computeVolume()
    excess = geometry.convex.computeVolume() / volume - 1.0 if volume > 0 else 0.0
    return geometry.convex, float(excess)


class _Arm(NamedTuple):
    model: pin.Model
    geom: pin.GeometryModel
    parts: tuple[Part, ...]
    hull_excess: dict[str, float]
    grounded: tuple[bool, ...]


@lru_cache(maxsize=8)
def _arm(urdf: str, arm_joints: tuple[str, ...], locked: tuple[tuple[str, float], ...] = ()) -> _Arm | None:
    arm = loaded_geometry(urdf, arm_joints, locked)  # shared with the self-collision check
    if arm is None:  # no collision geometry that can be loaded
        return None
    parts, excess = [], {}
    for obj in arm.geom.geometryObjects:
        geometry, extra = _convex(obj.geometry)
        name = arm.model.frames[obj.parentFrame].name
        parts.append(_part(name, geometry))
        excess[obj.name] = extra
    grounded = tuple(obj.parentJoint == 0 for obj in arm.geom.geometryObjects)  # no joint up to the base
    return _Arm(arm.model, arm.geom, tuple(parts), excess, grounded)


def base_box(robot: MobileManipulator) -> tuple[Any, FloatArray]:
    """The base's box (coal) and its pose in the base frame: from the floor to the arm's mount
    (at least :data:`BASE_BOX_MIN_HEIGHT`), centred under the base frame's origin."""
    import coal

    height = max(float(robot.mount[2, 3]), BASE_BOX_MIN_HEIGHT)
    offset = np.eye(4)
    offset[2, 3] = height / 2
    return coal.Box(2 * BASE_BOX_HALF_XY[0], 2 * BASE_BOX_HALF_XY[1], height), offset


class ClearanceChecker:
    """The robot's parts against the scene's bodies (see the module docstring)."""

    def __init__(self, robot: MobileManipulator, scene: Scene) -> None:
        self.robot, self.scene = robot, scene
        self._arm = _arm(str(robot.urdf_path), tuple(robot.arm_joints or ()), locked_key(robot))
        box, self._base_offset = base_box(robot)
        import coal

        base = (_part(BASE_PART, box),) if has_base_box(robot) else ()
        self.parts: tuple[Part, ...] = (*(self._arm.parts if self._arm else ()), *base,
                                        _part(PAYLOAD_PART, coal.Sphere(PAYLOAD_RADIUS)))
        #: Per part: rigid with the base (never checked against the floor).
        self.grounded = np.array([*(self._arm.grounded if self._arm else ()), *(True for _ in base), False])
        self._part_centres = np.array([p.centre for p in self.parts])
        self._part_radii = np.array([p.radius for p in self.parts])
        bodies = [_part(o.name, o.collision_geometry()) for o in scene.objects]
        poses = [o.pose for o in scene.objects]
        self._body_centres = np.array([T[:3, :3] @ b.centre + T[:3, 3] for T, b in zip(poses, bodies,
                                                                                       strict=True)]).reshape(-1, 3)
        self._floor = scene.floor
        if scene.floor is not None:  # the last body: the half-space z <= floor
            bodies.append(Part(FLOOR, coal.Halfspace(np.array([0.0, 0.0, 1.0]), float(scene.floor)), np.zeros(3),
                               0.0))
            poses.append(np.eye(4))
        self.bodies = tuple(bodies)
        self._scene_radii = np.array([b.radius for b in bodies[:len(scene.objects)]])
        # the bodies' oriented boxes: rotation (B x 3 x 3), origin, the local AABB's corners
        self._body_rotations = np.array([T[:3, :3] for T in poses[:len(scene.objects)]]).reshape(-1, 3, 3)
        self._body_origins = np.array([T[:3, 3] for T in poses[:len(scene.objects)]]).reshape(-1, 3)
        self._box_low = np.array([b.geometry.aabb_local.min_ for b in bodies[:len(scene.objects)]]).reshape(-1, 3)
        self._box_high = np.array([b.geometry.aabb_local.max_ for b in bodies[:len(scene.objects)]]).reshape(-1, 3)
        self._body_transforms = [coal.Transform3s(T[:3, :3].copy(), T[:3, 3].copy()) for T in poses]
        self._request = coal.DistanceRequest()
        if self._arm is not None:
            self._data, self._geom_data = self._arm.model.createData(), self._arm.geom.createData()

    @property
    def hull_excess(self) -> dict[str, float]:
        """Per arm collision mesh: how much larger its convex hull's volume is (relative; 0: convex)."""
        return dict(self._arm.hull_excess) if self._arm else {}

    def placements(self, q: Any) -> FloatArray:
        """World poses (G x 4 x 4) of the robot's parts at whole-body configuration ``q``."""
        q = np.asarray(q, dtype=float)
        base = self.robot.base_transform(q[:N_BASE])
        out = np.empty((len(self.parts), 4, 4))
        if self._arm is not None:
            model, geom = self._arm.model, self._arm.geom
            pin.forwardKinematics(model, self._data, np.ascontiguousarray(q[N_BASE:]))
            pin.updateGeometryPlacements(model, self._data, geom, self._geom_data)
            arm = len(self._geom_data.oMg)
            out[:arm] = base @ self.robot.mount @ np.array([m.homogeneous for m in self._geom_data.oMg])
        if len(self.parts) - 1 > (0 if self._arm is None else len(self._arm.parts)):  # the base box
            out[-2] = base @ self._base_offset
        if q.shape != (self.robot.nq,) or not np.isfinite(q).all():
            q = self.robot.check_configuration(q)  # raises ee_pose's error (checked only then: cheaper)
        out[-1] = base @ self.robot.arm_ee_pose(q[N_BASE:])  # robot.ee_pose(q), its base transform computed once
        return out

    def evaluate(self, Q: Any) -> Clearances:
        """The clearance of every configuration (K x nq); nothing is computed for an empty scene."""
        Q = np.atleast_2d(np.asarray(Q, dtype=float))
        k = len(Q)
        distance, robot, body = np.full(k, np.inf), [""] * k, [""] * k
        wr, wb = np.full((k, 3), np.nan), np.full((k, 3), np.nan)
        if self.bodies:
            hint = 0 if self.scene.objects else int(np.flatnonzero(~self.grounded)[0]) * len(self.bodies)
            T = np.array([self.placements(q) for q in Q])  # K x parts x 4 x 4
            step = max(1, BOUND_PAIRS // max(1, len(self.parts) * len(self.bodies)))  # arrays that stay in cache
            bound = np.concatenate([self.pair_bounds(T[i:i + step]) for i in range(0, k, step)])
            for i in range(k):
                hint, distance[i], wr[i], wb[i] = self._closest(T[i], hint, bound[i])
                g, b = divmod(hint, len(self.bodies))
                robot[i], body[i] = self.parts[g].name, self.bodies[b].name
        return Clearances(distance, tuple(robot), tuple(body), wr, wb)

    def pair_bounds(self, T: FloatArray) -> FloatArray:
        """:meth:`bounds` of every pair (K x parts * bodies, flat index part x body) with the parts
        placed at ``T`` (K x parts x 4 x 4)."""
        centres = np.einsum("kgij,gj->kgi", T[..., :3, :3], self._part_centres) + T[..., :3, 3]
        parts = np.tile(np.arange(len(self.parts)), len(T))
        return self.bounds(centres.reshape(-1, 3), parts).reshape(len(T), -1)

    def bounds(self, centres: FloatArray, parts: FloatArray) -> FloatArray:
        """Lower bounds (len(parts) x bodies) on the signed distance of each of ``parts`` (indices)
        whose bounding spheres are centred at ``centres`` (world) to each body; ``inf`` for a part
        rigid with the base against the floor (not a pair)."""
        radii = self._part_radii[parts]
        d = centres[:, None, :] - self._body_centres[None]
        spheres = np.sqrt(d[..., 0] ** 2 + d[..., 1] ** 2 + d[..., 2] ** 2) - self._scene_radii
        scene = np.maximum(spheres, self._box_distance(centres)) - radii[:, None]
        if self._floor is None:
            return scene
        floor = np.where(self.grounded[parts], np.inf, centres[:, 2] - self._floor - radii)
        return np.column_stack([scene, floor])

    def _box_distance(self, points: FloatArray) -> FloatArray:
        """Signed distance (P x bodies) of each world point to each body's oriented box (negative
        inside, by the depth to its nearest face)."""
        # body frame, one batched product per body (bodies x points x 3): R_b^T (p - o_b)
        local = np.matmul(points[None, :, :] - self._body_origins[:, None, :], self._body_rotations)
        beyond = np.maximum(self._box_low[:, None] - local, local - self._box_high[:, None])  # > 0: outside that face
        x, y, z = beyond[..., 0], beyond[..., 1], beyond[..., 2]  # by component: numpy's reductions over an axis
        inside = np.minimum(np.maximum(np.maximum(x, y), z), 0.0)  # of 3 cost more than the rest together
        np.maximum(beyond, 0.0, out=beyond)
        return (np.sqrt(x * x + y * y + z * z) + inside).T

    def _closest(self, T: FloatArray, hint: int, bound: FloatArray) -> tuple[int, float, FloatArray, FloatArray]:
        """Branch and bound over the pairs of one configuration (module docstring; ``bound``: its
        row of :meth:`pair_bounds`), starting with pair ``hint`` (the previous sample's closest:
        usually close again, so few bounds pass). Returns the closest pair's flat index (part x
        body), its distance and witness points."""
        best = (hint, *self._distance(T, hint))
        candidates = np.flatnonzero(bound < best[1])
        for idx in candidates[np.argsort(bound[candidates])]:
            if bound[idx] >= best[1]:
                break
            if idx != hint:
                found = self._distance(T, int(idx))
                if found[0] < best[1]:
                    best = (int(idx), *found)
        return best

    def _distance(self, T: FloatArray, pair: int) -> tuple[float, FloatArray, FloatArray]:
        """coal's signed distance of one pair (flat index part x body) and its witness points."""
        import coal

        g, b = divmod(pair, len(self.bodies))
        result = coal.DistanceResult()
        d = coal.distance(self.parts[g].geometry, coal.Transform3s(T[g, :3, :3], T[g, :3, 3]),
                          self.bodies[b].geometry, self._body_transforms[b], self._request, result)
        return float(d), np.array(result.getNearestPoint1()), np.array(result.getNearestPoint2())


def path_clearances(robot: MobileManipulator, scene: Scene, targets: Any) -> Clearances:
    """The clearance of the parts rigid with the end effector (the hand, the fingers: every part
    on the end effector's joint; the payload) with the end effector at each target pose (K x 4 x 4),
    to the scene's bodies and the floor. The rest
    of the robot cannot change it: where it is below the task's clearance, no plan of the path is
    clear. Parts elsewhere and the base count as infinitely far; so does a body more than 1 m
    away (bounding spheres), which no clearance forte accepts reaches."""
    checker = ClearanceChecker(robot, scene)
    targets = np.asarray(targets, dtype=float).reshape(-1, 4, 4)
    k = len(targets)
    out = Clearances(np.full(k, np.inf), ("",) * k, ("",) * k, np.full((k, 3), np.nan), np.full((k, 3), np.nan))
    if checker._arm is None or not checker.bodies:
        return out  # no arm geometry: the payload alone is not worth a check
    ee = robot.model.frames[robot.ee_frame_id]
    joint = robot.model.names[ee.parentJoint]
    objs = checker._arm.geom.geometryObjects
    rigid = [i for i, obj in enumerate(objs) if checker._arm.model.names[obj.parentJoint] == joint]
    joint_from_ee = np.linalg.inv(ee.placement.homogeneous)
    local = np.array([objs[i].placement.homogeneous for i in rigid] + [ee.placement.homogeneous])
    rigid.append(len(checker.parts) - 1)  # the payload, at the end effector
    distance, robot_names, body_names = out.distance.copy(), list(out.robot), list(out.body)
    wr, wb = out.witness_robot.copy(), out.witness_body.copy()
    for k_, T_ee in enumerate(targets):
        T = np.repeat(np.eye(4)[None], len(checker.parts), axis=0)
        T[rigid] = T_ee @ joint_from_ee @ local
        centres = np.einsum("gij,gj->gi", T[rigid, :3, :3], checker._part_centres[rigid]) + T[rigid, :3, 3]
        bound = checker.bounds(centres, np.array(rigid))
        for r, b in zip(*np.nonzero(bound < min(distance[k_], 1.0)), strict=True):  # bounding spheres first
            if bound[r, b] < distance[k_]:
                i = rigid[r]
                d, p1, p2 = checker._distance(T, i * len(checker.bodies) + int(b))
                if d < distance[k_]:
                    distance[k_], wr[k_], wb[k_] = d, p1, p2
                    robot_names[k_], body_names[k_] = checker.parts[i].name, checker.bodies[int(b)].name
    return Clearances(distance, tuple(robot_names), tuple(body_names), wr, wb)


def clearances(robot: MobileManipulator, scene: Scene, Q: Any) -> Clearances:
    """The clearance of every configuration ``Q`` (K x nq) of ``robot`` in ``scene``."""
    return ClearanceChecker(robot, scene).evaluate(Q)


#: How far (m) a part rigid with the base may reach below the floor: it rests on it (TIAGo's
#: wheels and casters touch it, to round-off), it does not stand in it.
FLOOR_TOLERANCE = 1e-3


class FloorContact(NamedTuple):
    """A part of the robot where it may not be against the floor: its ``name``, its signed
    distance (m) to the floor and whether it is rigid with the base (``grounded``)."""

    name: str
    distance: float
    grounded: bool


def floor_contact(robot: MobileManipulator, floor: float, q: Any, clearance: float,
                  moving: bool = True) -> FloorContact | None:
    """The worst part at whole-body configuration ``q`` (exact geometry) that breaks the floor's
    rules, or ``None``: a part rigid with the base (the arm's root link: an arm mounted at or below
    the floor) reaching more than :data:`FLOOR_TOLERANCE` below the floor, anywhere the base goes;
    with ``moving``, an arm link or the payload closer to the floor than ``clearance``."""
    checker = ClearanceChecker(robot, Scene((), float(floor)))
    T = checker.placements(q)
    found = []
    for i, part in enumerate(checker.parts):
        grounded = bool(checker.grounded[i])
        if part.name == BASE_PART or (not grounded and not moving):
            continue
        d = checker._distance(T, i)[0]
        if d < (-FLOOR_TOLERANCE if grounded else clearance):
            found.append(FloorContact(part.name, d, grounded))
    # a mount in the floor first (no plan helps), then the lowest moving part
    return min(found, key=lambda c: (not c.grounded, c.distance), default=None)
