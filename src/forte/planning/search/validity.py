"""Is a whole-body configuration free? One C++ call per state on forte's collision model.

**The model.** The same parts and bodies as :class:`~forte.model.clearance.ClearanceChecker`
(the arm's collision meshes as their convex hulls, the fingers at neutral, the base box, the
payload sphere at the end effector; the scene's bodies; the floor as a half-space, not checked
against the parts rigid with the base), put into one Pinocchio model and geometry model: a planar
joint ``(x, y, yaw)`` for the base, the arm appended on it at the robot's mount, the scene's bodies
on the universe. Its collision pairs are

- every robot part against every scene body (and the floor), with coal's *security margin* set to
  the clearance ``c``: such a pair counts as a collision when its distance is below ``c``, so a
  state passes only when the exact clearance (the hull distance :class:`ClearanceChecker` reports)
  is ``>= c``;
- the arm's self-collision pairs (:class:`~forte.model.self_collision.ArmGeometry`: non-adjacent
  links, less the pairs the package's SRDF disables) with no margin. They are checked on the hulls, which contain the
  meshes: for a convex mesh (every Panda link) this is the mesh check, for a concave one it is
  conservative.

``pin.computeCollisions(..., stop_at_first_collision=True)`` runs the forward kinematics, places
every geometry and tests the pairs until one collides: no Python per pair. The pairs go through
Pinocchio's broad phase (coal's dynamic AABB tree, each geometry's box inflated by its pairs'
security margins), so only pairs whose boxes overlap reach GJK: 23-25 us per state instead of
49-90 us trying every pair on MotionBenchMaker's Panda scenes (170-314 pairs; the same verdict on
3,500 states per scene, measured). A state is *valid* when it is within the joint limits and no pair
collides.
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import pinocchio as pin

from forte.model.clearance import BASE_PART, PAYLOAD_PART, ClearanceChecker, base_box
from forte.model.description import PAYLOAD_RADIUS, has_base_box
from forte.model.robot import N_BASE, MobileManipulator
from forte.model.scene import FLOOR, Scene
from forte.model.self_collision import ArmGeometry, arm_geometry
from forte.validation import FloatArray


class _Model(NamedTuple):
    model: pin.Model
    geom: pin.GeometryModel
    self_pairs: tuple[tuple[int, int], ...]
    grounded: tuple[bool, ...]
    frame: int


def _hull(geometry: Any) -> Any:
    if not hasattr(geometry, "buildConvexHull"):
        return geometry
    geometry.buildConvexHull(True, "Qt")
    return geometry.convex


@lru_cache(maxsize=8)
def _robot_model(urdf: str, arm_joints: tuple[str, ...], mount: bytes,
                 locked: tuple[tuple[str, float], ...] = ()) -> _Model:
    """The base's planar joint (id 1, frame :attr:`_Model.frame`) with the arm's hulls on it at ``mount``."""
    arm = ArmGeometry(Path(urdf), arm_joints, locked)
    for obj in arm.geom.geometryObjects:
        obj.geometry = _hull(obj.geometry)
    base = pin.Model()
    joint = base.addJoint(0, pin.JointModelPlanar(), pin.SE3.Identity(), "forte_base")
    frame = base.addJointFrame(joint, 0)
    mount_se3 = pin.SE3(np.frombuffer(mount).reshape(4, 4).copy())
    model, geom = pin.appendModel(base, arm.model, pin.GeometryModel(), arm.geom, frame, mount_se3)
    names = [o.name for o in arm.geom.geometryObjects]
    index = {name: geom.getGeometryId(name) for name in names}
    self_pairs = tuple((index[names[p.first]], index[names[p.second]]) for p in arm.geom.collisionPairs)
    grounded = tuple(geom.geometryObjects[index[n]].parentJoint == joint for n in names)
    return _Model(model, geom, self_pairs, grounded, frame)


class StateChecker:
    """Validity of whole-body configurations of ``robot`` in ``scene`` with ``clearance`` (m)
    (module docstring). ``floor`` replaces the scene's floor when given. Two departures from
    :class:`ClearanceChecker`'s model, for measurements only (its ``why`` still reports on that
    model): ``locked`` holds joints outside the arm (the fingers) at given values instead of
    the robot's ``locked_joints``, and ``base_box`` overrides whether the base box is there (default: as forte's
    model, :func:`~forte.model.description.has_base_box`)."""

    def __init__(self, robot: MobileManipulator, scene: Scene, clearance: float = 0.0, floor: float | None = None,
                 *, locked: dict[str, float] | None = None, base_box: bool | None = None) -> None:
        self.robot, self.clearance = robot, float(clearance)
        self.scene = scene if floor is None else scene._replace(floor=float(floor))
        built = _robot_model(str(robot.urdf_path), tuple(robot.arm_joints), np.ascontiguousarray(robot.mount).tobytes(),
                             tuple(sorted((robot.locked_joints if locked is None else locked).items())))
        self.model, self.geom = built.model, pin.GeometryModel(built.geom)  # parts and bodies go into a copy
        base_box = has_base_box(robot) if base_box is None else base_box
        self._add_base_and_payload(built.frame, base_box)
        grounded = (*built.grounded, *((True,) if base_box else ()), False)
        bodies = self._add_bodies()
        scene_pairs = [(g, b) for b in bodies for g in range(len(grounded))
                       if not (self.geom.geometryObjects[b].name == FLOOR and grounded[g])]
        self.geom.removeAllCollisionPairs()  # the arm's, copied by appendModel: they go after the scene's
        for first, second in [*scene_pairs, *built.self_pairs]:
            self.geom.addCollisionPair(pin.CollisionPair(first, second))
        self.data, self.geom_data = self.model.createData(), self.geom.createData()
        for first, second in scene_pairs:
            index = self.geom.findCollisionPair(pin.CollisionPair(first, second))
            self.geom_data.collisionRequests[index].security_margin = self.clearance
        self._broad = pin.BroadPhaseManager_DynamicAABBTreeCollisionManager(self.model, self.geom, self.geom_data)
        self.lower, self.upper = robot.lower, robot.upper
        self._q = np.zeros(self.model.nq)
        self.checks = 0

    def _add_base_and_payload(self, frame: int, with_box: bool) -> None:
        import coal

        if with_box:
            box, offset = base_box(self.robot)
            self.geom.addGeometryObject(pin.GeometryObject(BASE_PART, 1, frame, pin.SE3(offset), box))
        ee_name = self.robot.ee_frame
        ee = self.model.frames[self.model.getFrameId(ee_name)]
        placement = ee.placement.homogeneous
        if self.robot.ee_offset is not None:
            placement = placement @ self.robot.ee_offset
        self.geom.addGeometryObject(pin.GeometryObject(PAYLOAD_PART, ee.parentJoint, self.model.getFrameId(ee_name),
                                                       pin.SE3(placement), coal.Sphere(PAYLOAD_RADIUS)))

    def _add_bodies(self) -> list[int]:
        import coal

        ids = [self.geom.addGeometryObject(pin.GeometryObject(o.name, 0, 0, pin.SE3(o.pose), o.collision_geometry()))
               for o in self.scene.objects]
        if self.scene.floor is not None:
            plane = coal.Halfspace(np.array([0.0, 0.0, 1.0]), float(self.scene.floor))
            ids.append(self.geom.addGeometryObject(pin.GeometryObject(FLOOR, 0, 0, pin.SE3.Identity(), plane)))
        return ids

    def pin_configuration(self, q: Any) -> FloatArray:
        """forte's ``[x, y, yaw, q_arm]`` as the model's ``[x, y, cos yaw, sin yaw, q_arm]``."""
        q = np.asarray(q, dtype=float)
        self._q[:2] = q[:2]
        self._q[2], self._q[3] = np.cos(q[2]), np.sin(q[2])
        self._q[4:] = q[N_BASE:]
        return self._q

    def _in_range(self, q: Any) -> bool:
        arm = np.asarray(q, dtype=float)[N_BASE:]
        return bool((arm >= self.lower).all() and (arm <= self.upper).all())  # the methods: no wrapper's cost

    def valid(self, q: Any) -> bool:
        """Within the joint limits, every scene distance >= the clearance, no self-collision."""
        self.checks += 1
        return self._in_range(q) and not pin.computeCollisions(self.model, self.data, self._broad,
                                                               self.pin_configuration(q), True)

    def valid_pairwise(self, q: Any) -> bool:
        """:meth:`valid` without the broad phase (every pair to GJK): the reference it is tested against."""
        return self._in_range(q) and not pin.computeCollisions(self.model, self.data, self.geom, self.geom_data,
                                                               self.pin_configuration(q), True)

    def why(self, q: Any) -> str:
        """Why ``q`` is not valid, in words (``""`` when it is): the joint beyond its limit, the
        closest robot part and scene body with their exact distance, or the self-colliding pair."""
        arm = np.asarray(q, dtype=float)[N_BASE:]
        for name, value, lo, hi in zip(self.robot.arm_joints, arm, self.lower, self.upper, strict=True):
            if not lo <= value <= hi:
                return f"{name} at {value:.3f} rad outside [{lo:.3f}, {hi:.3f}]"
        found = ClearanceChecker(self.robot, self.scene).evaluate(np.asarray(q, dtype=float))
        if found.distance[0] < self.clearance:
            return f"{found.robot[0]} vs {found.body[0]}, {found.distance[0]:.3f} m"
        contact = arm_geometry(self.robot)
        hit = contact.contact(arm) if contact is not None else None
        if hit is not None:
            return f"self-collision: {hit.first} vs {hit.second}"
        return "" if self.valid(q) else "in collision (hull check)"


def on_segment(q_a: Any, q_b: Any, s: Any) -> FloatArray:
    """The states ``q_a + s (q_b - q_a)`` (one row per ``s`` in [0, 1]), each joint kept between
    its two ends: the product rounds past ``q_b`` at ``s = 1`` by an ulp, which puts a goal at a
    joint's limit out of range (MotionBenchMaker's table_under_pick 0041: every segment into its
    goal failed the dense check at its last state)."""
    q_a, q_b = np.asarray(q_a, dtype=float), np.asarray(q_b, dtype=float)
    s = np.atleast_1d(np.asarray(s, dtype=float))
    return np.clip(q_a + s[:, None] * (q_b - q_a), np.minimum(q_a, q_b), np.maximum(q_a, q_b))


def segment_free(checker: StateChecker, q_a: Any, q_b: Any, resolution: float = 0.02) -> bool:
    """Whether the straight C-space segment from ``q_a`` to ``q_b`` is free: ``checker.valid`` at
    both ends and at ``ceil(|q_b - q_a|_inf / resolution)`` equal steps between (no joint moves more
    than ``resolution`` rad, or m for the base, between two checked states; :func:`on_segment`)."""
    q_a, q_b = np.asarray(q_a, dtype=float), np.asarray(q_b, dtype=float)
    steps = max(1, int(np.ceil(np.max(np.abs(q_b - q_a)) / resolution)))
    return all(checker.valid(q) for q in on_segment(q_a, q_b, np.linspace(0.0, 1.0, steps + 1)))
