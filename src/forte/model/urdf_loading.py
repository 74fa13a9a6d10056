"""Loading a URDF into Pinocchio the way forte plans with it: continuous joints become revolute.

Pinocchio models a continuous joint by ``(cos q, sin q)`` (two coordinates, one velocity); forte's
planner, its CasADi twin and its NLP take one coordinate per joint. A continuous joint is therefore
loaded as a revolute joint limited to +-:data:`CONTINUOUS_RANGE` (two turns each way, more than a
trajectory of seconds uses; the URDF's effort and velocity limits kept). Everything that builds a
Pinocchio model or geometry from a robot's URDF goes through here, so the planner, the
self-collision check and the clearance check agree; MuJoCo reads the URDF itself and keeps the
joint unlimited.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

#: The range (rad) a continuous joint is planned within, each way.
CONTINUOUS_RANGE = 2 * np.pi
#: Effort (Nm) and velocity (rad/s) given to a continuous joint whose URDF has no <limit>.
UNLIMITED_EFFORT, UNLIMITED_VELOCITY = 1e3, 10.0


@lru_cache(maxsize=16)
def _text(path: str, mtime: float) -> str:
    text = Path(path).read_text(encoding="utf-8")
    if 'type="continuous"' not in text and "type='continuous'" not in text:
        return text
    root = ET.fromstring(text)
    for joint in root.iter("joint"):
        if joint.get("type") != "continuous":
            continue
        joint.set("type", "revolute")
        limit = joint.find("limit")
        if limit is None:
            limit = ET.SubElement(joint, "limit", {"effort": f"{UNLIMITED_EFFORT:g}",
                                                   "velocity": f"{UNLIMITED_VELOCITY:g}"})
        limit.set("lower", repr(-CONTINUOUS_RANGE))
        limit.set("upper", repr(CONTINUOUS_RANGE))
    return ET.tostring(root, encoding="unicode")


def planning_urdf_text(path: Path) -> str:
    """The URDF's text with every continuous joint revolute within +-:data:`CONTINUOUS_RANGE`."""
    path = Path(path)
    return _text(str(path.resolve()), path.stat().st_mtime)


def load_model(path: Path) -> pin.Model:
    """The Pinocchio model of the URDF at ``path`` (continuous joints as revolute)."""
    return pin.buildModelFromXML(planning_urdf_text(path))


def load_geometry(model: pin.Model, path: Path, kind: Any, package_dirs: list[str]) -> pin.GeometryModel:
    """The URDF's geometry of ``kind`` (``pin.COLLISION`` or ``pin.VISUAL``) for ``model``."""
    return pin.buildGeomFromUrdfString(model, planning_urdf_text(path), kind, package_dirs=package_dirs)
