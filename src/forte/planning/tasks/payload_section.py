"""The task file's ``payload:`` section: mass, description, image, and the payload's geometry.

``payload: {mass: 2.7, com: [x, y, z], inertia: ..., moment_scale: L}``: ``com`` is the centre of
mass in the end-effector frame (m), ``inertia`` its rotational inertia about the centre of mass
(3 principal moments or a 3 x 3 matrix, end-effector axes, kg m^2), ``moment_scale`` the length
(m) that scales moments against forces in the wrench metric (default ``|com|``, see
:mod:`forte.capability.wrench`). Every error names the field.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from forte.exceptions import InvalidInputError, TaskFileError
from forte.force.payload import MAX_COM_OFFSET_M, Payload, check_com, check_inertia
from forte.planning.tasks.schema import Reader
from forte.validation import MAX_MASS_KG, payload_mass


def payload_section(reader: Reader, base: Path, mass: float | None) -> Payload | None:
    """The payload section (``None`` when the task has none), with ``--mass`` taking precedence."""
    found = None
    if reader.has("payload"):
        pr = reader.sub("payload")
        pr.unknown({"mass", "description", "image", "com", "inertia", "moment_scale"})
        image = Path(str(pr.get("image"))) if pr.has("image") else None
        if image is not None:
            located = image if image.is_absolute() else base / image
            if not located.is_file():
                raise pr.error("image", f"{located}: file does not exist (expected a PNG, JPEG, WebP or GIF image)")
        found = Payload(mass=pr.number("mass", nonnegative=True, maximum=MAX_MASS_KG, unit=" kg")
                        if pr.has("mass") else None,
                        description=str(pr.get("description")) if pr.has("description") else None,
                        image=None if image is None else str(image if image.is_absolute() else base / image),
                        **payload_geometry(pr))
        if found.mass is None and found.description is None and found.image is None:
            if found.com is not None or found.inertia is not None:
                raise pr.error("mass", "a payload with com or inertia needs a mass, a description or an image")
            found = None
    if mass is not None:
        try:
            payload_mass(mass, "--mass")
        except InvalidInputError as exc:
            raise TaskFileError(str(exc)) from None
        found = (found or Payload()).with_mass(mass, source="cli")
    return found


def payload_geometry(pr: Reader) -> dict[str, Any]:
    """``com``, ``inertia`` and ``moment_scale`` of a payload section, each checked with an error
    naming its field (:func:`forte.force.payload.check_com`, :func:`~forte.force.payload.check_inertia`)."""
    out: dict[str, Any] = {}
    try:
        if pr.has("com"):
            out["com"] = tuple(check_com(pr.vector("com", 3), "com"))
        if pr.has("inertia"):
            value = pr.get("inertia")
            flat = isinstance(value, list | tuple) and len(value) == 3 and not any(
                isinstance(v, list | tuple) for v in value)
            matrix = np.diag(pr.vector("inertia", 3)) if flat else pr.matrix("inertia", 3, 3)
            out["inertia"] = tuple(map(tuple, check_inertia(matrix, "inertia")))
        if pr.has("moment_scale"):
            out["moment_scale"] = pr.number("moment_scale", positive=True, maximum=MAX_COM_OFFSET_M, unit=" m")
    except InvalidInputError as exc:
        field_name, _, message = str(exc).partition(": ")
        raise pr.error(field_name, message) from None
    return out
