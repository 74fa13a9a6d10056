"""Collision geometry of a mobile manipulator: spheres fixed to the end effector or to the base.

The one owner of the sphere lists. The ``collision`` cost term
(:class:`forte.planning.terms.motion_terms.Collision`) penalizes every pair (end-effector sphere,
base sphere) that comes closer than a safe distance.

A sphere hangs on a frame of the robot and its centre is given in that frame's axes (m):

- ``"ee"``: the end-effector frame (:attr:`MobileManipulator.ee_frame_id`), so the sphere
  moves with the arm;
- ``"base"``: the base frame (the footprint: ``[x, y, 0]`` rotated by ``yaw``; the arm's mount
  is expressed in it), so the sphere moves with the base only.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from forte.exceptions import InvalidInputError

#: The frames a collision sphere can hang on.
SPHERE_FRAMES: tuple[str, ...] = ("ee", "base")


class CollisionSphere(NamedTuple):
    """A sphere of ``radius`` (m) centred at ``centre`` (m) in the axes of ``frame``."""

    frame: str
    centre: tuple[float, float, float]
    radius: float

    def check(self, name: str) -> CollisionSphere:
        """This sphere, validated (errors name ``name``)."""
        if self.frame not in SPHERE_FRAMES:
            raise InvalidInputError(f"{name}.frame: expected one of {', '.join(SPHERE_FRAMES)}, got {self.frame!r}")
        centre = np.asarray(self.centre, dtype=float)
        if centre.shape != (3,) or not np.all(np.isfinite(centre)):
            raise InvalidInputError(f"{name}.centre: expected 3 finite numbers, got {self.centre!r}")
        if not (np.isfinite(self.radius) and self.radius > 0):
            raise InvalidInputError(f"{name}.radius: expected a finite number > 0, got {self.radius!r}")
        return self


class SpherePairs(NamedTuple):
    """Two sphere sets whose every cross pair is checked: ``basket`` (what the end effector
    carries) against ``body`` (the robot's base)."""

    basket: tuple[CollisionSphere, ...]
    body: tuple[CollisionSphere, ...]

    def check(self) -> SpherePairs:
        """These sets, validated: both non-empty, every sphere well formed."""
        for label, spheres in (("basket", self.basket), ("body", self.body)):
            if not spheres:
                raise InvalidInputError(f"collision spheres: the {label} set is empty")
            for i, sphere in enumerate(spheres):
                CollisionSphere(*sphere).check(f"collision spheres: {label}[{i}]")
        return self


#: The authors' spheres (their experiments' configuration, ``optimizer_collision_*_spheres``): a
#: basket on the end effector (radius 0.15 m centred 0.1 m along the end effector's z axis; three
#: of 0.18 m at 0.3 m, one on the axis and two 0.15 m off it along the x = y diagonal) against the
#: MOCA base (0.52 m centred 0.35 m above the footprint) and the arm's shoulder (0.15 m at
#: (0.2, 0, 0.8) m, around the Panda's first links: its mount is at (0.2575, 0, 0.52) m). No
#: spheres on the moving arm links: the arm itself is not checked.
AUTHORS_SPHERES = SpherePairs(
    basket=(CollisionSphere("ee", (0.0, 0.0, 0.1), 0.15), CollisionSphere("ee", (0.0, 0.0, 0.3), 0.18),
            CollisionSphere("ee", (0.106, 0.106, 0.3), 0.18), CollisionSphere("ee", (-0.106, -0.106, 0.3), 0.18)),
    body=(CollisionSphere("base", (0.0, 0.0, 0.35), 0.52), CollisionSphere("base", (0.2, 0.0, 0.8), 0.15)),
)
