"""Self-collision of the arm on its URDF's collision meshes (coal, through Pinocchio's geometry model).

The geometry is the URDF's ``<collision>`` elements, reduced like the kinematic model (fingers and
every joint outside the arm locked at neutral, or at the robot's ``locked_joints``) and mounted on
the base like it. Pairs that never count: geometries on the same or on adjacent links (their meshes
usually overlap at the joint), and every pair the robot's SRDF disables (``<disable_collisions>``;
:func:`package_srdf` finds it, :attr:`ArmGeometry.record` says which file it was and how many pairs
it disabled for which stated reason).
The check is exact on the meshes (coal's narrow phase), ~50 us per configuration for the Panda.
Many configurations at once (:meth:`ArmGeometry.contacts`, the verdict's samples) go through a
broad phase first: each geometry's bounding sphere (its local AABB's), placed by batched forward
kinematics (:mod:`forte.model.joint_placements`); a configuration where every checked pair's spheres
are more than :data:`BROAD_PHASE_MARGIN` apart has no contact (the spheres contain the geometries);
elsewhere only the pairs whose spheres come that close are given to coal, in :meth:`ArmGeometry.contact`'s
order, so the answers are its answers. (Within GJK's tolerance of touching, coal's answer for a
pair of convex shapes depends on the configuration it checked that pair at before: it starts
from the last separating direction. There, and only there, skipping far configurations can
change an answer, as checking them in another order would.)
The base of the built-in robot is not in the URDF, so the arm is not checked against it here.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections import Counter
from functools import cached_property, lru_cache
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import pinocchio as pin

from forte.model.description import mesh_package_dirs, urdf_reference
from forte.model.joint_placements import joint_placements
from forte.model.urdf_loading import load_geometry, load_model, locked_configuration

#: How far apart (m) two geometries' bounding spheres must be for the broad phase to skip the
#: pair: far above the placements' rounding (~1e-15 m) and coal's collision threshold (~1e-8 m).
BROAD_PHASE_MARGIN = 1e-3
#: Configurations placed per batch by the broad phase (bounds its arrays).
BROAD_PHASE_BATCH = 1024


class Spheres(NamedTuple):
    """Bounding spheres of an arm's geometries (``centre`` in the parent joint's frame, G x 3,
    ``radius``, G; ``joint``: the parent joint of each) and the checked pairs (``first``, ``second``)."""

    centre: Any
    radius: Any
    joint: Any
    first: Any
    second: Any


class Contact(NamedTuple):
    """The first colliding pair of a configuration: the two geometries' names."""

    first: str
    second: str


class LinkContact(NamedTuple):
    """Two links whose meshes interpenetrate, ``depth`` (m) deep (:meth:`ArmGeometry.link_contacts`)."""

    depth: float
    first: str
    second: str


def package_srdf(urdf: Path) -> Path | None:
    """The SRDF that goes with ``urdf``: a file named after the URDF's stem, else after its robot
    (``<robot name=...>``), with the suffix ``.srdf``, beside the URDF or in its package's ``srdf/``
    folder (the folder beside the URDF's own: example-robot-data keeps its URDFs in ``urdf/`` or
    ``robots/`` and its SRDFs in ``srdf/``); ``None`` when there is none. An SRDF named after
    neither is another variant of the robot (``ur3_gripper.srdf`` beside ``ur5.srdf``): not used."""
    urdf = Path(urdf)
    folders = (urdf.parent, urdf.parent.parent / "srdf")
    for name in dict.fromkeys((urdf.stem, _robot_name(urdf))):
        for folder in folders:
            if name and (folder / f"{name}.srdf").is_file():
                return folder / f"{name}.srdf"
    return None


def _robot_name(urdf: Path) -> str:
    try:
        for _, element in ET.iterparse(urdf, events=("start",)):
            return element.get("name") or ""
    except (ET.ParseError, OSError):
        pass
    return ""


def disabled_reasons(srdf: Path) -> dict[str, int]:
    """How many ``<disable_collisions>`` the SRDF states per ``reason`` (``Adjacent``, ``Never``,
    ``Default``, ...; ``unstated`` where it gives none)."""
    root = ET.parse(srdf).getroot()
    return dict(Counter(e.get("reason") or "unstated" for e in root.iter("disable_collisions")))


class ArmGeometry:
    """The arm's collision meshes and the pairs that are checked (see the module docstring)."""

    def __init__(self, urdf: Path, arm_joints: tuple[str, ...], locked: tuple[tuple[str, float], ...] = ()) -> None:
        full = load_model(urdf)
        geom = load_geometry(full, urdf, pin.COLLISION, _package_dirs(urdf))
        keep = {full.getJointId(j) for j in arm_joints}
        lock = [j for j in range(1, full.njoints) if j not in keep]
        q_ref = locked_configuration(full, dict(locked))
        self.model, self.geom = pin.buildReducedModel(full, geom, lock, q_ref) if lock else (full, geom)
        self.geom.addAllCollisionPairs()
        self.srdf = package_srdf(urdf)
        if self.srdf is not None:
            pin.removeCollisionPairs(self.model, self.geom, str(self.srdf))
        self._remove_adjacent()
        self.data, self.geom_data = self.model.createData(), self.geom.createData()
        self.source = (f"{self.srdf.name} and adjacent links excluded" if self.srdf is not None
                       else "adjacent links excluded")

    def _remove_adjacent(self) -> None:
        objs = self.geom.geometryObjects
        # the indices first: the pairs Python sees are views into the vector that removals shift
        for first, second in [(p.first, p.second) for p in self.geom.collisionPairs]:
            a, b = objs[first].parentJoint, objs[second].parentJoint
            if a == b or self.model.parents[a] == b or self.model.parents[b] == a:
                self.geom.removeCollisionPair(pin.CollisionPair(first, second))

    @property
    def pairs(self) -> int:
        return len(self.geom.collisionPairs)

    def record(self) -> dict[str, Any]:
        """Which pairs are left out, for the robot's description: the SRDF used (``None``: none
        found), the ``<disable_collisions>`` it states per reason, and how many geometry pairs are
        checked."""
        return {"srdf": None if self.srdf is None else urdf_reference(self.srdf),
                "srdf_disabled": {} if self.srdf is None else disabled_reasons(self.srdf),
                "adjacent_links_excluded": True, "pairs_checked": self.pairs}

    def contact(self, q_arm: Any) -> Contact | None:
        """The first colliding pair at arm configuration ``q_arm``, or ``None``."""
        if not pin.computeCollisions(self.model, self.data, self.geom, self.geom_data, np.asarray(q_arm, float), True):
            return None
        for pair, result in zip(self.geom.collisionPairs, self.geom_data.collisionResults, strict=True):
            if result.isCollision():
                objs = self.geom.geometryObjects
                return Contact(objs[pair.first].name, objs[pair.second].name)
        return None  # pragma: no cover - coal reported a collision without a pair

    def contacts(self, Q_arm: Any) -> list[Contact | None]:
        """:meth:`contact` at each arm configuration (K x nq), through the broad phase (module
        docstring): coal checks only the pairs whose spheres come close, in :meth:`contact`'s
        order, and a configuration with none is ``None`` without it."""
        Q = np.asarray(Q_arm, float).reshape(-1, self.model.nq)
        near = self.near_pairs(Q)
        if near is None:
            return [self.contact(q) for q in Q]
        return [self._first_contact(q, np.flatnonzero(row)) if row.any() else None
                for q, row in zip(Q, near, strict=True)]

    def _first_contact(self, q_arm: Any, pairs: Any) -> Contact | None:
        """The first of ``pairs`` (indices, ascending) that collides at ``q_arm``, or ``None``."""
        pin.updateGeometryPlacements(self.model, self.data, self.geom, self.geom_data, q_arm)
        for i in pairs:
            if pin.computeCollision(self.geom, self.geom_data, int(i)):
                pair, objs = self.geom.collisionPairs[int(i)], self.geom.geometryObjects
                return Contact(objs[pair.first].name, objs[pair.second].name)
        return None

    def near_pairs(self, Q_arm: Any) -> Any:
        """Per arm configuration (K x nq) and checked pair (K x pairs): whether the pair's bounding
        spheres come within :data:`BROAD_PHASE_MARGIN` (``False``: no contact there); ``None``
        when a joint's type is not one :func:`~forte.model.joint_placements.joint_placements` places."""
        Q = np.asarray(Q_arm, float).reshape(-1, self.model.nq)
        out = np.empty((len(Q), self.pairs), dtype=bool)
        s = self.spheres
        for start in range(0, len(Q), BROAD_PHASE_BATCH):
            oMi = joint_placements(self.model, Q[start:start + BROAD_PHASE_BATCH])
            if oMi is None:
                return None
            T = oMi[:, s.joint]  # K x G x 4 x 4
            centre = np.einsum("kgij,gj->kgi", T[..., :3, :3], s.centre) + T[..., :3, 3]
            d = centre[:, s.first] - centre[:, s.second]
            gap = np.sqrt((d * d).sum(axis=-1)) - s.radius[s.first] - s.radius[s.second]
            out[start:start + BROAD_PHASE_BATCH] = gap <= BROAD_PHASE_MARGIN
        return out

    @cached_property
    def spheres(self) -> Spheres:
        """The geometries' bounding spheres (coal's local AABB, computed on a copy: the geometries
        checked stay as loaded) and the checked pairs."""
        centre, radius = [], []
        for obj in self.geom.geometryObjects:
            box = obj.geometry.clone()
            box.computeLocalAABB()
            centre.append(obj.placement.act(np.array(box.aabb_center, dtype=float)))
            radius.append(float(box.aabb_radius))
        pairs = np.array([(p.first, p.second) for p in self.geom.collisionPairs], dtype=int).reshape(-1, 2)
        joint = np.array([obj.parentJoint for obj in self.geom.geometryObjects], dtype=int)
        return Spheres(np.array(centre).reshape(-1, 3), np.array(radius), joint, pairs[:, 0], pairs[:, 1])

    def link_contacts(self, q_arm: Any) -> list[LinkContact]:
        """Every pair of links whose meshes interpenetrate at ``q_arm``, deepest first, each at its
        deepest pair of geometries. The depth is coal's signed distance, negated, where it computes
        one (a box, sphere or cylinder in the pair), else, mesh against mesh (whose distance is 0
        in contact), the depth of coal's contact."""
        if not pin.computeCollisions(self.model, self.data, self.geom, self.geom_data, np.asarray(q_arm, float), False):
            return []
        objs, deepest = self.geom.geometryObjects, {}
        for i, (pair, result) in enumerate(zip(self.geom.collisionPairs, self.geom_data.collisionResults, strict=True)):
            if not result.isCollision():
                continue
            depth = -pin.computeDistance(self.geom, self.geom_data, i).min_distance
            if depth <= 0.0 and result.numContacts():
                depth = abs(result.getContact(0).penetration_depth)
            links = (link_of(objs[pair.first].name), link_of(objs[pair.second].name))
            key = frozenset(links)
            if key not in deepest or depth > deepest[key].depth:
                deepest[key] = LinkContact(max(depth, 0.0), *links)
        return sorted(deepest.values(), key=lambda c: -c.depth)


def link_of(geometry_name: str) -> str:
    """The link a URDF collision geometry belongs to: Pinocchio names them ``<link>_<index>``."""
    stem, _, index = geometry_name.rpartition("_")
    return stem if stem and index.isdigit() else geometry_name


def _package_dirs(urdf: Path) -> list[str]:
    """Folders that ``package://NAME/...`` mesh URIs resolve against: the ``share`` above the URDF
    (else the folder two above it), then example-robot-data's (a description stored in a plan
    directory names its meshes ``package://example-robot-data/...``)."""
    parents = urdf.resolve().parents
    here = [str(p) for p in parents if p.name == "share"] or [str(parents[min(2, len(parents) - 1)])]
    return here + [d for d in mesh_package_dirs() if d not in here]


@lru_cache(maxsize=8)
def loaded_geometry(urdf: str, arm_joints: tuple[str, ...],
                    locked: tuple[tuple[str, float], ...] = ()) -> ArmGeometry | None:
    """The arm's geometry, loaded once per URDF, joints and locks (the meshes take ~10 ms) for this
    check and the clearance's parts (:mod:`forte.model.clearance`, which builds hulls beside the
    meshes and bounds its own copies; each keeps its own Pinocchio data); ``None`` when no
    collision geometry can be loaded."""
    try:
        return ArmGeometry(Path(urdf), arm_joints, locked)
    except (ValueError, RuntimeError):  # no collision meshes found: nothing to check on
        return None


def _arm_geometry(urdf: str, arm_joints: tuple[str, ...], locked: tuple[tuple[str, float], ...]) -> ArmGeometry | None:
    geometry = loaded_geometry(urdf, arm_joints, locked)
    return geometry if geometry is not None and geometry.pairs else None


def arm_geometry(robot: Any) -> ArmGeometry | None:
    """The robot's arm collision geometry (cached per URDF and joints); ``None`` when its URDF has
    no collision meshes that can be loaded or no pair to check."""
    return _arm_geometry(str(robot.urdf_path), tuple(robot.arm_joints), locked_key(robot))


def locked_key(robot: Any) -> tuple[tuple[str, float], ...]:
    """The robot's ``locked_joints`` as a hashable key (cached geometries)."""
    return tuple(sorted((getattr(robot, "locked_joints", None) or {}).items()))
