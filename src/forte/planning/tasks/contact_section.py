"""The task file's ``contact:`` section: a contact-rich task and the parameters of its force model.

::

    contact: {kind: push-box, mass: 10.0, friction: 0.3, size: [0.4, 0.4, 0.4]}
    contact: {kind: drawer, mass: 2.0, stiffness: 100.0, damping: 20.0, friction: 15.0, rest: 0.0}
    contact: {kind: carry, mass: 2.0, com: [0, 0, 0.3], partner: [0, 0, 0.6], share: 0.5,
              release_time: 6.0, release_duration: 0.5}

Units: kg, N/m, N s/m, N, m, s; ``com`` and ``partner`` in the end-effector frame. The models are
:mod:`forte.force.contact`'s. A push and a drawer need a straight path (horizontal for the push);
a contact task gives neither a payload nor a force profile. Every error names the field.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from forte.exceptions import InvalidInputError, TaskFileError
from forte.force.contact import CONTACT_KINDS, Carry, Contact, Drawer, PushBox, straight_direction
from forte.force.payload import MAX_COM_OFFSET_M, Payload
from forte.planning.tasks.schema import Reader
from forte.validation import MAX_DURATION_S, MAX_MASS_KG, FloatArray

#: Bounds of the contact parameters (forte's documented bounds).
MAX_FRICTION = 2.0
MAX_STIFFNESS = 1e5  # N/m
MAX_DAMPING = 1e4  # N s/m
MAX_FRICTION_FORCE = 1e4  # N
MAX_BOX_SIZE = 2.0  # m
#: How far (m) the push path may rise or sink: it must stay horizontal.
HORIZONTAL_TOLERANCE = 1e-3


def contact_section(reader: Reader) -> Contact | None:
    """The ``contact:`` section (``None`` when the task has none)."""
    if not reader.has("contact"):
        return None
    r = reader.sub("contact")
    kind = r.choice("kind", CONTACT_KINDS, "")
    mass = r.number("mass", positive=True, maximum=MAX_MASS_KG, unit=" kg")
    if kind == "push-box":
        r.unknown({"kind", "mass", "friction", "size"})
        size = r.vector("size", 3, [0.4, 0.4, 0.4])
        if np.any(size <= 0) or np.any(size > MAX_BOX_SIZE):
            raise r.error("size", f"expected 3 lengths in (0, {MAX_BOX_SIZE:g}] m, got {size.tolist()}")
        return PushBox(mass, r.number("friction", positive=True, maximum=MAX_FRICTION), tuple(size.tolist()))
    if kind == "drawer":
        r.unknown({"kind", "mass", "stiffness", "damping", "friction", "rest"})
        return Drawer(mass, r.number("stiffness", 0.0, nonnegative=True, maximum=MAX_STIFFNESS, unit=" N/m"),
                      r.number("damping", 0.0, nonnegative=True, maximum=MAX_DAMPING, unit=" N s/m"),
                      r.number("friction", 0.0, nonnegative=True, maximum=MAX_FRICTION_FORCE, unit=" N"),
                      r.number("rest", 0.0))
    r.unknown({"kind", "mass", "com", "partner", "share", "release_time", "release_duration"})
    com, partner = (_offset(r, name) for name in ("com", "partner"))
    if np.linalg.norm(partner) < 1e-3:
        raise r.error("partner", "expected the partner's grip away from the hand (|partner| >= 0.001 m)")
    share = r.number("share", nonnegative=True, maximum=1.0) if r.has("share") else None
    release = r.number("release_time", nonnegative=True, maximum=MAX_DURATION_S, unit=" s") \
        if r.has("release_time") else None
    duration = r.number("release_duration", 0.5, positive=True, maximum=MAX_DURATION_S, unit=" s")
    return Carry(mass, tuple(com.tolist()), tuple(partner.tolist()), share, release, duration)


def _offset(r: Reader, name: str) -> FloatArray:
    v = r.vector(name, 3)
    if np.linalg.norm(v) > MAX_COM_OFFSET_M:
        raise r.error(name, f"expected an offset of at most {MAX_COM_OFFSET_M:g} m, got {np.linalg.norm(v):.3g} m")
    return v


def check_contact_path(reader: Reader, contact: Contact | None, targets: FloatArray, mode: str) -> None:
    """A push and a drawer need a straight path (the push's horizontal); a contact task a trajectory."""
    if contact is None:
        return
    if mode != "trajectory":
        raise reader.error("contact", f"a contact task needs mode 'trajectory', got {mode!r}")
    if isinstance(contact, Carry):
        return
    try:
        straight_direction(targets[:, :3, 3], "path")
    except InvalidInputError as exc:
        raise reader.error("path", str(exc).partition(": ")[2]) from None
    rise = float(np.max(np.abs(targets[:, 2, 3] - targets[0, 2, 3])))
    if isinstance(contact, PushBox) and rise > HORIZONTAL_TOLERANCE:
        raise reader.error("path", f"the end effector rises or sinks {rise:.4f} m; a push along the floor "
                           f"needs a horizontal path (within {HORIZONTAL_TOLERANCE:g} m)")


def contact_conflicts(reader: Reader, contact: Contact | None) -> None:
    """A contact task gives its force by its model: no payload, force profile or force model."""
    if contact is None:
        return
    for name in ("payload", "force", "force_model", "uncertainty_rule"):
        if reader.has(name):
            raise reader.error(name, f"not used by a contact task (contact.kind {contact.kind!r} gives the force); "
                               "leave it out")


def read_contact(reader: Reader, targets: FloatArray, mode: str, mass: float | None
                 ) -> tuple[Contact | None, Payload | None]:
    """The task's ``contact:`` section checked against the rest of the task (its path, the fields it
    excludes), and what the hand carries: a carried object (simulated at its centre of mass; ``mass``,
    the command line's ``--mass``, replaces its mass), else nothing."""
    contact = contact_section(reader)
    if contact is None:
        return None, None
    if isinstance(contact, Carry) and mass is not None:
        contact = replace(contact, mass=mass)
    contact_conflicts(reader, contact)
    check_contact_path(reader, contact, targets, mode)
    if not isinstance(contact, Carry):
        if mass is not None:
            raise TaskFileError(f"--mass: a {contact.kind} task carries no payload; its masses are in contact:")
        return contact, None
    return contact, Payload(mass=contact.mass, source="contact", com=contact.com)
