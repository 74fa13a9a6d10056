"""Contact-rich tasks (issue 25, item 4): the force the end effector must exert, from physics.

Each model turns the task's end-effector path into a :class:`~forte.force.taskforce.TaskForce`, as
:func:`~forte.force.taskforce.payload_force` turns a payload's: the force (and moment) the hand
must *exert on the object*, world frame, at the path's samples. Velocities and accelerations are
the paper's backward differences, starting at rest (:func:`forte.model.trajectory.backward_differences`),
so the planner, the verdict and the baselines apply unchanged.

**Push a box** (:class:`PushBox`, mass ``m``, Coulomb friction ``mu`` against the floor). The hand
pushes the box along the path's straight horizontal direction ``d``; with the speed
``v_k = p'_k . d`` and acceleration ``a_k = p''_k . d`` along it::

    f_k = (m a_k + mu m g sgn(v_k)) d,        sgn(0) = 0

(Newton along ``d``: the push minus the kinetic friction ``mu m g`` accelerates the box; at rest the
box needs no push, static friction holds it). The hand holds nothing vertically: ``f_z = 0``.

**Open a drawer** (:class:`Drawer`, moving mass ``m_d``, spring ``k`` with rest position ``s_0``,
viscous damping ``c``, Coulomb friction ``F_c``). The hand holds the handle and follows the
drawer's axis ``d`` (the path's straight direction, opening); the opening ``s_k = (p_k - p_1) . d``::

    f_k = (m_d s''_k + k (s_k - s_0) + c s'_k + F_c sgn(s'_k)) d

(Newton along the slide: the drawer resists with ``-(k (s - s_0) + c s' + F_c sgn(s'))``; the hand
exerts the opposite plus ``m_d s''``). The slide carries the drawer's weight.

**Carry a long object with a person** (:class:`Carry`, mass ``m``, centre of mass ``c`` and the
partner's grip ``e``, both in the end-effector frame). The robot holds its end rigidly and leads
the motion; the partner holds the other end like a pin and supports the share ``sigma(t)`` of the
object's weight, ``f_p = sigma(t) m g e_z`` (up), until they let go: ``sigma(t) = sigma_0`` before
``release_time`` and ``sigma_0 (1 - s((t - t_r) / T))`` after (``s`` the quintic blend, ``T`` the
release duration). With ``c_k = R_k c``, ``e_k = R_k e`` in the world frame, Newton-Euler for the
object about the robot's grip (a point mass, the centre of mass moving with the hand) gives the
robot's wrench::

    f_k = m (p''_k - g) - f_p(t_k)  +  m_tool (p''_k - g)
    m_k = c_k x m (p''_k - g) - e_k x f_p(t_k)

(``m_tool`` the robot's end-effector load that a payload task's force includes too). The default
``sigma_0 = (c . e) / |e|^2`` is the lever rule: the partner takes the share that leaves the robot
no moment while both hold. The uncertainty set is the force ball ``r`` and the moment ball
``|l| r`` with ``l = max(|c|, |e|)``: a force error of at most ``r`` anywhere between the grip and the
partner's hand (:mod:`forte.force.wrench`).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from forte.exceptions import InvalidInputError
from forte.force.taskforce import TaskForce
from forte.model.robot import STANDARD_GRAVITY
from forte.model.trajectory import backward_differences, quintic_blend
from forte.validation import FloatArray, as_array, as_positive, check_times

#: The contact task kinds (``contact.kind`` in a task file).
CONTACT_KINDS: tuple[str, ...] = ("push-box", "drawer", "carry")
#: Below this speed (m/s) the Coulomb term's sign is 0: the object is at rest.
REST_SPEED = 1e-9


@dataclass(frozen=True)
class PushBox:
    """A box pushed across the floor: ``mass`` (kg), floor friction ``friction`` (mu) and its
    ``size`` (m, length along the push, width, height; the simulation's box)."""

    mass: float
    friction: float
    size: tuple[float, float, float] = (0.4, 0.4, 0.4)
    kind: str = "push-box"


@dataclass(frozen=True)
class Drawer:
    """A drawer on a slide: moving ``mass`` (kg), ``stiffness`` (N/m) with rest opening ``rest``
    (m), ``damping`` (N s/m) and Coulomb ``friction`` (N)."""

    mass: float
    stiffness: float = 0.0
    damping: float = 0.0
    friction: float = 0.0
    rest: float = 0.0
    kind: str = "drawer"


@dataclass(frozen=True)
class Carry:
    """A long object carried with a partner: ``mass`` (kg), centre of mass ``com`` and the
    partner's grip ``partner`` (end-effector frame, m), the partner's weight share ``share``
    (``None``: the lever rule), and when they let go: ``release_time`` (s, ``None``: never) over
    ``release_duration`` (s)."""

    mass: float
    com: tuple[float, float, float]
    partner: tuple[float, float, float]
    share: float | None = None
    release_time: float | None = None
    release_duration: float = 0.5
    kind: str = "carry"

    @property
    def initial_share(self) -> float:
        """``sigma_0``: the given share, else the lever rule ``(c . e) / |e|^2``."""
        if self.share is not None:
            return float(self.share)
        e = np.asarray(self.partner, dtype=float)
        return float(np.clip(np.dot(self.com, e) / max(float(e @ e), 1e-12), 0.0, 1.0))

    @property
    def lever(self) -> float:
        """``max(|c|, |e|)`` (m): the moment ball's radius per newton of the force ball's."""
        return float(max(np.linalg.norm(self.com), np.linalg.norm(self.partner)))

    def share_at(self, t: Any) -> FloatArray:
        """``sigma(t)`` (module docstring) at times ``t``."""
        times = np.asarray(t, dtype=float)
        sigma = np.full(times.shape, self.initial_share)
        if self.release_time is not None:
            x = np.clip((times - self.release_time) / max(self.release_duration, 1e-9), 0.0, 1.0)
            sigma = sigma * (1.0 - quintic_blend(x))
        return sigma

    def partner_force(self, t: Any, gravity: float = STANDARD_GRAVITY) -> FloatArray:
        """``f_p(t) = sigma(t) m g e_z`` (N x 3, world frame): the partner's force on the object."""
        sigma = self.share_at(np.atleast_1d(t))
        f = np.zeros((sigma.size, 3))
        f[:, 2] = sigma * self.mass * gravity
        return f


Contact = PushBox | Drawer | Carry


def contact_to_dict(contact: Contact) -> dict[str, Any]:
    """The contact's fields as plain values (recorded in plan.json)."""
    return {k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(contact).items()}


def contact_from_dict(doc: Any) -> Contact:
    """The inverse of :func:`contact_to_dict` (``InvalidInputError`` naming the field otherwise)."""
    if not isinstance(doc, dict) or doc.get("kind") not in CONTACT_KINDS:
        raise InvalidInputError(f"contact.kind: expected one of {', '.join(CONTACT_KINDS)}, got "
                                f"{doc.get('kind') if isinstance(doc, dict) else doc!r}")
    cls = {"push-box": PushBox, "drawer": Drawer, "carry": Carry}[doc["kind"]]
    fields = {k: (tuple(float(x) for x in v) if isinstance(v, list) else v) for k, v in doc.items()}
    try:
        return cls(**fields)
    except TypeError as exc:
        raise InvalidInputError(f"contact: {exc}") from None


def straight_direction(positions: Any, what: str = "path", tolerance: float = 1e-3) -> FloatArray:
    """The unit direction from the first to the last of ``positions`` (N x 3); every sample must
    lie within ``tolerance`` (m) of that line (``InvalidInputError`` otherwise)."""
    p = as_array(positions, "positions", (None, 3))
    chord = p[-1] - p[0]
    length = float(np.linalg.norm(chord))
    if length < 1e-6:
        raise InvalidInputError(f"{what}: the end effector does not move (expected a straight motion)")
    d = chord / length
    rel = p - p[0]
    off = np.linalg.norm(rel - np.outer(rel @ d, d), axis=1)
    if np.max(off) > tolerance:
        k = int(np.argmax(off))
        raise InvalidInputError(f"{what}: sample {k} lies {off[k]:.4f} m off the straight line from start to end; "
                                f"expected a straight motion (within {tolerance:g} m)")
    return d


def _sgn(v: FloatArray) -> FloatArray:
    return np.where(np.abs(v) > REST_SPEED, np.sign(v), 0.0)


def _along(t: Any, positions: Any, d: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """``(times, s, s', s'')`` of the positions' coordinate along ``d`` (backward differences)."""
    times = check_times(t)
    p = as_array(positions, "positions", (times.size, 3))
    s = (p - p[0]) @ d
    v, a = backward_differences(s[:, None], times, "positions")
    return times, s, v[:, 0], a[:, 0]


def push_force(t: Any, positions: Any, box: PushBox, radius: Any, gravity: float = STANDARD_GRAVITY) -> TaskForce:
    """``f_k = (m a_k + mu m g sgn(v_k)) d`` (module docstring) along the path ``positions`` (N x 3).

    Examples:
        A 10 kg box, mu = 0.3, pushed 0.2 m along x at constant speed (0.1 m/s): the hand pushes
        with the kinetic friction ``mu m g`` once the box moves (the first step accelerates it):

        >>> import numpy as np
        >>> p = np.c_[np.linspace(0.0, 0.2, 5), np.zeros(5), np.zeros(5)]
        >>> f = push_force(np.linspace(0.0, 2.0, 5), p, PushBox(10.0, 0.3), 10.0).f
        >>> np.round(f[:, 0], 2).tolist()
        [0.0, 31.43, 29.43, 29.43, 29.43]
    """
    d = straight_direction(positions, "path")
    times, _, v, a = _along(t, positions, d)
    mass = as_positive(box.mass, "contact.mass")
    along = mass * a + box.friction * mass * gravity * _sgn(v)
    return TaskForce(times, along[:, None] * d, _radii(radius, times.size))


def drawer_force(t: Any, positions: Any, drawer: Drawer, radius: Any) -> TaskForce:
    """``f_k = (m_d s'' + k (s - s_0) + c s' + F_c sgn(s')) d`` (module docstring) along ``positions``."""
    d = straight_direction(positions, "path")
    times, s, v, a = _along(t, positions, d)
    along = drawer.mass * a + drawer.stiffness * (s - drawer.rest) + drawer.damping * v + drawer.friction * _sgn(v)
    return TaskForce(times, along[:, None] * d, _radii(radius, times.size))


def carry_wrench(t: Any, poses: Any, carry: Carry, radius: Any, tool_mass: float = 0.0,
                 gravity: float = STANDARD_GRAVITY) -> TaskForce:
    """The robot's share ``(f_k, m_k)`` of a carried object (module docstring) along the
    end-effector ``poses`` (N x 4 x 4)."""
    times = check_times(t)
    T = as_array(poses, "poses", (times.size, 4, 4))
    _, acc = backward_differences(T[:, :3, 3], times, "positions")
    load = acc - np.array([0.0, 0.0, -gravity])
    total = carry.mass * load
    f_p = carry.partner_force(times, gravity)
    c_w = T[:, :3, :3] @ np.asarray(carry.com, dtype=float)
    e_w = T[:, :3, :3] @ np.asarray(carry.partner, dtype=float)
    f = total - f_p + tool_mass * load
    m = np.cross(c_w, total) - np.cross(e_w, f_p)
    return TaskForce(times, f, _radii(radius, times.size), m, lever=carry.lever, moment_scale=carry.lever)


def contact_force(contact: Contact, t: Any, poses: Any, radius: Any, tool_mass: float = 0.0,
                  gravity: float = STANDARD_GRAVITY) -> TaskForce:
    """The task force of ``contact`` along the end-effector ``poses`` (N x 4 x 4)."""
    P = np.asarray(poses, dtype=float)
    if isinstance(contact, PushBox):
        return push_force(t, P[:, :3, 3], contact, radius, gravity)
    if isinstance(contact, Drawer):
        return drawer_force(t, P[:, :3, 3], contact, radius)
    return carry_wrench(t, P, contact, radius, tool_mass, gravity)


def _radii(radius: Any, n: int) -> FloatArray:
    if np.ndim(radius) == 0:
        return np.full(n, as_positive(radius, "radius", allow_zero=True))
    return as_array(radius, "radius", (n,))


__all__ = ["CONTACT_KINDS", "Carry", "Contact", "Drawer", "PushBox", "carry_wrench", "contact_force",
           "contact_from_dict", "contact_to_dict", "drawer_force", "push_force", "straight_direction"]
