"""The mobile base's support: the polygon it stands on, and its mass (issue 25, item 3).

A :class:`BaseSupport` states, in the base frame (origin on the floor under the base, z up, the
frame of ``q_b = [x, y, yaw]``):

- ``footprint``: the support polygon, the convex hull of the base's ground contacts (its wheels'
  or casters' contact points), vertices in order around it (either way round; stored
  counter-clockwise);
- ``mass`` and ``com``: the base's mass (kg) and centre of mass (m) *besides* the links of the arm's
  URDF that are rigid with the base (Pinocchio's universe body of the arm model: the Panda's
  ``panda_link0``, or a whole mobile base when the URDF carries one, as TIAGo's does), which count
  with their own inertials (:mod:`forte.model.stability`).

The polygon's half-planes are ``n_i . p <= h_i`` (``n_i`` the unit outward normal of edge ``i``);
the signed distance of a point ``p`` to the polygon's edge (m, positive inside) is

    s(p) = min_i (h_i - n_i . p)                 inside (exact for a convex polygon),
    s(p) = -min_i dist(p, edge_i)                outside (the Euclidean distance to the polygon).

**The built-in robot** (:data:`AUTHORS_BASE`) is the authors' MOCA platform, a Robotnik Summit-XL
Steel, as their optimizer URDF describes it (``polytope_ros/urdf/my_robot_fix_wheels.urdf``, GitHub
``yeying256/FORTE``): chassis ``moca_base_link`` 125 kg with its centre of mass at its origin, 0.127
m above ``moca_base_footprint`` (the base frame; the Panda sits at (0.2575, 0, 0.52) m from it);
four omni wheels of 6.5 kg, radius 0.127 m, centred at (+-0.2225, +-0.2045, 0.127) m. The base is
their 151 kg at (0, 0, 0.127) m and the support polygon the rectangle of the wheels' contact points
(+-0.2225, +-0.2045) m. Left out: the chassis's sensors (two 0.13 kg lasers, a 0.3 kg camera,
0.57 kg in all). The arm's ``panda_link0`` comes from the arm's URDF (0.63 kg in
example-robot-data's; the authors' description gives 3.06 kg). The simulator's base body keeps its
own 60 kg (:data:`~forte.model.description.BASE_MASS`) on the kinematic base model, which slides
on joints and cannot tip; ``forte simulate --base-model floor`` (:mod:`forte.execution.floor_base`)
carries this description's mass and centre of mass on wheels and casters at the polygon, and tips.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from forte.exceptions import InvalidInputError
from forte.model.description import BASE_BOX_HALF_XY, BASE_BOX_MIN_HEIGHT, BASE_MASS
from forte.validation import FloatArray


@dataclass(frozen=True)
class BaseSupport:
    """A base's support polygon, mass and centre of mass (module docstring), base frame.

    Attributes:
        footprint: the support polygon's vertices ``(x, y)`` (m), convex, in order.
        mass: kg besides the arm URDF's links rigid with the base (>= 0).
        com: its centre of mass (m).
        source: where the numbers come from (recorded in plan.json).
    """

    footprint: tuple[tuple[float, float], ...]
    mass: float = 0.0
    com: tuple[float, float, float] = (0.0, 0.0, 0.0)
    source: str = ""

    def __post_init__(self) -> None:
        try:
            poly = np.asarray(self.footprint, dtype=float)
        except (TypeError, ValueError):
            raise InvalidInputError(f"base_footprint: expected a list of [x, y] vertices, "
                                    f"got {self.footprint!r}") from None
        if poly.ndim != 2 or poly.shape[1] != 2 or poly.shape[0] < 3 or not np.all(np.isfinite(poly)):
            raise InvalidInputError(f"base_footprint: expected at least 3 [x, y] vertices (m), "
                                    f"got {self.footprint!r}")
        if _area(poly) < 0:  # clockwise: store counter-clockwise
            poly = poly[::-1]
        if not _convex(poly):
            raise InvalidInputError("base_footprint: expected a convex polygon with its vertices in order "
                                    f"around it, got {self.footprint!r}")
        mass = self.mass
        if isinstance(mass, bool) or not isinstance(mass, int | float) or not np.isfinite(mass) or mass < 0:
            raise InvalidInputError(f"base_mass: expected a finite number >= 0 (kg), got {mass!r}")
        com = np.asarray(self.com, dtype=float)
        if com.shape != (3,) or not np.all(np.isfinite(com)):
            raise InvalidInputError(f"base_com: expected 3 finite numbers (m), got {self.com!r}")
        object.__setattr__(self, "footprint", tuple((float(x), float(y)) for x, y in poly))
        object.__setattr__(self, "mass", float(mass))
        object.__setattr__(self, "com", tuple(float(v) for v in com))

    @property
    def polygon(self) -> FloatArray:
        """The vertices (K x 2), counter-clockwise."""
        return np.asarray(self.footprint, dtype=float)

    def halfplanes(self) -> tuple[FloatArray, FloatArray]:
        """``(n, h)``: unit outward normals (K x 2) and offsets (K), ``n_i . p <= h_i`` inside."""
        poly = self.polygon
        edge = np.roll(poly, -1, axis=0) - poly
        normal = np.column_stack([edge[:, 1], -edge[:, 0]]) / np.linalg.norm(edge, axis=1)[:, None]
        return normal, np.einsum("ij,ij->i", normal, poly)

    def margin(self, points: Any) -> FloatArray:
        """Signed distance (m) of ``points`` (... x 2, base frame) to the polygon's edge, > 0 inside."""
        p = np.asarray(points, dtype=float)
        normal, h = self.halfplanes()
        slack = h - np.einsum("ij,...j->...i", normal, p)
        inside = slack.min(axis=-1)
        a = self.polygon
        e = np.roll(a, -1, axis=0) - a
        s = np.clip(np.einsum("...ij,ij->...i", p[..., None, :] - a, e) / np.einsum("ij,ij->i", e, e), 0.0, 1.0)
        outside = np.linalg.norm(p[..., None, :] - (a + s[..., None] * e), axis=-1).min(axis=-1)
        return np.where(inside >= 0, inside, -outside)

    def to_dict(self) -> dict[str, Any]:
        return {"footprint": [list(v) for v in self.footprint], "mass": self.mass, "com": list(self.com),
                "source": self.source}

    @classmethod
    def from_dict(cls, doc: dict[str, Any]) -> BaseSupport:
        return cls(tuple(tuple(v) for v in doc["footprint"]), doc.get("mass", 0.0),
                   tuple(doc.get("com", (0.0, 0.0, 0.0))), str(doc.get("source", "")))


def _area(poly: FloatArray) -> float:
    """Signed area (> 0 counter-clockwise)."""
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def _convex(poly: FloatArray) -> bool:
    """Counter-clockwise ``poly`` turns left at every vertex (and has an area)."""
    e = np.roll(poly, -1, axis=0) - poly
    turn = e[:, 0] * np.roll(e, -1, axis=0)[:, 1] - e[:, 1] * np.roll(e, -1, axis=0)[:, 0]
    return bool(np.all(turn > 0) and _area(poly) > 0)


def check_support(value: Any) -> BaseSupport | None:
    """A :class:`BaseSupport` from itself, its :meth:`~BaseSupport.to_dict` or ``None``."""
    if value is None or isinstance(value, BaseSupport):
        return value
    if isinstance(value, dict) and "footprint" in value:
        return BaseSupport.from_dict(value)
    raise InvalidInputError(f"base_support: expected a footprint, mass and com, got {value!r}")


def rectangle(half_x: float, half_y: float, cx: float = 0.0, cy: float = 0.0) -> tuple[tuple[float, float], ...]:
    """The corners of an axis-aligned rectangle, counter-clockwise."""
    return ((cx + half_x, cy + half_y), (cx - half_x, cy + half_y), (cx - half_x, cy - half_y),
            (cx + half_x, cy - half_y))


#: The authors' MOCA platform (module docstring).
AUTHORS_BASE = BaseSupport(
    rectangle(0.2225, 0.2045), 151.0, (0.0, 0.0, 0.127),
    "the authors' description (my_robot_fix_wheels.urdf): chassis 125 kg and four 6.5 kg wheels, centre of "
    "mass 0.127 m up; support polygon = the wheels' contact points (+-0.2225, +-0.2045) m")


def box_support(mount_height: float) -> BaseSupport:
    """forte's base box (the collision geometry of a base the URDF does not carry, and MuJoCo's base
    body): its footprint, the simulator's :data:`~forte.model.description.BASE_MASS` at its centre."""
    height = max(float(mount_height), BASE_BOX_MIN_HEIGHT)
    return BaseSupport(rectangle(*BASE_BOX_HALF_XY), BASE_MASS, (0.0, 0.0, height / 2),
                       f"forte's base box {2 * BASE_BOX_HALF_XY[0]:g} x {2 * BASE_BOX_HALF_XY[1]:g} m, "
                       f"the simulator's {BASE_MASS:g} kg at its centre")


#: TIAGo's PMB2 base (its URDF, ``base_footprint`` frame): the contact points of its two drive
#: wheels (0, +-0.2022) m and of its four casters (0.1535, +-0.102) and (-0.1895, +-0.102) m
#: (``caster_*_2_link``); its mass is in the URDF (the links rigid with the base, 46.8 kg with the
#: torso's fixed part).
TIAGO_BASE = BaseSupport(
    ((0.1535, -0.102), (0.1535, 0.102), (0.0, 0.2022), (-0.1895, 0.102), (-0.1895, -0.102), (0.0, -0.2022)),
    0.0, (0.0, 0.0, 0.0), "TIAGo's URDF: wheel and caster contact points; its base links' inertials")
