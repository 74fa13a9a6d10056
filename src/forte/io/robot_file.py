"""The robot description a plan directory carries, so that the directory travels.

``robot.urdf`` (:data:`ROBOT_FILE`) beside ``plan.json`` is a byte-for-byte copy of the URDF the
plan was made with; plan.json's ``robot`` block names it (``urdf_file``) and records its sha256
(``urdf_sha256``), the self-collision pairs the plan was judged with (``self_collision``: the SRDF
used or ``null``, its disabled pairs per stated reason, the pairs checked;
:meth:`forte.model.self_collision.ArmGeometry.record`) and where the URDF came from (``urdf``:
``erd:<path inside example-robot-data>`` for example-robot-data's descriptions, else the original
path). Meshes stay package references
(``package://example-robot-data/...``), which resolve against the installed example-robot-data
wherever the directory is read (:func:`forte.model.description.mesh_package_dirs`).

Reading (:func:`stored_description`): a copy whose sha256 differs from plan.json's is refused; when
``urdf`` resolves on this machine to the same bytes, that file is used (same bytes, and its
package's SRDF and meshes beside it), else the stored copy (no SRDF beside it: the pairs of adjacent
links alone are left out, as ``self_collision`` then records). Either way the model is the one planned.
A plan.json of format 1-3 (no ``urdf_file``) names its URDF by absolute path; a path into another
installation of example-robot-data is read from this one's.
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Any

from forte.exceptions import RobotModelError, TaskFileError
from forte.model.description import resolve_urdf
from forte.model.robot import MobileManipulator
from forte.model.self_collision import arm_geometry

#: The stored copy of the robot's URDF in a plan directory.
ROBOT_FILE = "robot.urdf"
#: Where example-robot-data's descriptions live inside any installation of it.
_ERD_MARK = "/share/example-robot-data/robots/"


def sha256_of(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def store_robot(robot: MobileManipulator, directory: Path) -> dict[str, Any]:
    """Copy ``robot``'s URDF into ``directory`` as :data:`ROBOT_FILE`; its ``robot`` block for plan.json."""
    data = robot.urdf_path.read_bytes()
    (directory / ROBOT_FILE).write_bytes(data)
    geometry = arm_geometry(robot)
    pairs = geometry.record() if geometry is not None else {"srdf": None, "pairs_checked": 0}
    return robot.describe() | {"urdf_file": ROBOT_FILE, "urdf_sha256": hashlib.sha256(data).hexdigest(),
                               "self_collision": pairs}


def stored_description(plan_dir: Path, desc: dict[str, Any]) -> dict[str, Any]:
    """plan.json's ``robot`` block with ``urdf`` a file that exists here and holds the planned bytes.

    Raises:
        TaskFileError: the stored copy is missing or not the one planned (sha256 mismatch).
    """
    plan_json = plan_dir / "plan.json"
    if not isinstance(desc.get("urdf"), str):
        raise TaskFileError(f"{plan_json}: field 'robot.urdf': expected the URDF's reference (a string)")
    name = desc.get("urdf_file")
    if name is None:  # format 1-3: an absolute path
        return desc | {"urdf": _older_reference(desc["urdf"])}
    if name != ROBOT_FILE:
        raise TaskFileError(f"{plan_json}: field 'robot.urdf_file': expected {ROBOT_FILE!r}, got {name!r}")
    stored = plan_dir / ROBOT_FILE
    if not stored.is_file():
        raise TaskFileError(f"{stored}: file missing (the robot description the plan was made with)")
    sha = sha256_of(stored)
    if sha != desc.get("urdf_sha256"):
        raise TaskFileError(f"{stored}: sha256 {sha[:12]}... differs from plan.json's robot.urdf_sha256 "
                            f"{str(desc.get('urdf_sha256'))[:12]}...: not the description the plan was made with")
    try:
        here = resolve_urdf(desc["urdf"])
        if sha256_of(here) == sha:
            return desc | {"urdf": str(here)}
    except (RobotModelError, OSError):
        pass
    return desc | {"urdf": str(stored)}


def _older_reference(urdf: str) -> str:
    """A format 1-3 URDF path: as written, or, when it no longer exists but pointed into an
    installation of example-robot-data, the same description in this one."""
    if Path(urdf).is_file() or _ERD_MARK not in urdf.replace("\\", "/"):
        return urdf
    return "erd:" + urdf.replace("\\", "/").split(_ERD_MARK, 1)[1]
