"""Self-collision of the arm on its URDF's collision meshes (coal, through Pinocchio's geometry model).

The geometry is the URDF's ``<collision>`` elements, reduced like the kinematic model (fingers and
every joint outside the arm locked at neutral, or at the robot's ``locked_joints``) and mounted on
the base like it. Pairs that never count: every pair the robot's SRDF disables
(``<disable_collisions>``, found beside the URDF as ``../srdf/*.srdf``), and, for a URDF without
one, geometries on the same or on adjacent links.
The check is exact on the meshes (coal's narrow phase), ~50 us per configuration for the Panda.
The base of the built-in robot is not in the URDF, so the arm is not checked against it here.
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import pinocchio as pin

from forte.model.description import mesh_package_dirs
from forte.model.urdf_loading import load_geometry, load_model, locked_configuration


class Contact(NamedTuple):
    """The first colliding pair of a configuration: the two geometries' names."""

    first: str
    second: str


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
        srdf = sorted((urdf.parent.parent / "srdf").glob("*.srdf")) if urdf.parent.name == "urdf" else []
        if srdf:
            pin.removeCollisionPairs(self.model, self.geom, str(srdf[0]))
        else:
            self._remove_adjacent()
        self.data, self.geom_data = self.model.createData(), self.geom.createData()
        self.source = str(srdf[0].name) if srdf else "adjacent links excluded"

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

    def contact(self, q_arm: Any) -> Contact | None:
        """The first colliding pair at arm configuration ``q_arm``, or ``None``."""
        if not pin.computeCollisions(self.model, self.data, self.geom, self.geom_data, np.asarray(q_arm, float), True):
            return None
        for pair, result in zip(self.geom.collisionPairs, self.geom_data.collisionResults, strict=True):
            if result.isCollision():
                objs = self.geom.geometryObjects
                return Contact(objs[pair.first].name, objs[pair.second].name)
        return None  # pragma: no cover - coal reported a collision without a pair


def _package_dirs(urdf: Path) -> list[str]:
    """Folders that ``package://NAME/...`` mesh URIs resolve against: the ``share`` above the URDF
    (else the folder two above it), then example-robot-data's (a description stored in a plan
    directory names its meshes ``package://example-robot-data/...``)."""
    parents = urdf.resolve().parents
    here = [str(p) for p in parents if p.name == "share"] or [str(parents[min(2, len(parents) - 1)])]
    return here + [d for d in mesh_package_dirs() if d not in here]


@lru_cache(maxsize=8)
def _arm_geometry(urdf: str, arm_joints: tuple[str, ...], locked: tuple[tuple[str, float], ...]) -> ArmGeometry | None:
    try:
        geometry = ArmGeometry(Path(urdf), arm_joints, locked)
    except (ValueError, RuntimeError):  # no collision meshes found: nothing to check on
        return None
    return geometry if geometry.pairs else None


def arm_geometry(robot: Any) -> ArmGeometry | None:
    """The robot's arm collision geometry (cached per URDF and joints); ``None`` when its URDF has
    no collision meshes that can be loaded or no pair to check."""
    return _arm_geometry(str(robot.urdf_path), tuple(robot.arm_joints), locked_key(robot))


def locked_key(robot: Any) -> tuple[tuple[str, float], ...]:
    """The robot's ``locked_joints`` as a hashable key (cached geometries)."""
    return tuple(sorted((getattr(robot, "locked_joints", None) or {}).items()))
