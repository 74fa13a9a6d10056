"""The requirements on the mobile base: how it may move, and that it does not tip over.

- :class:`BaseMode`: the base moves as its mode allows (:attr:`MobileManipulator.base`): a fixed
  base stays put, a differential drive has no lateral velocity;
- :class:`Tipover`: the signed distance of the whole robot's zero-moment point to the edge of the
  base's support polygon is >= 0 (m) at every sample, with the sample's whole-body velocities and
  accelerations and the task wrench (:func:`forte.model.stability.tipover_margin`); judged for a
  robot that states its base support (``robot.base_support``), nothing otherwise.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from forte.model.robot import N_BASE
from forte.model.stability import tipover_margin
from forte.planning.nlp.base_rows import lateral_displacement
from forte.planning.verdict.requirement_base import Context, Measure, Requirement

#: Lateral base speed (m/s) a differential drive may show at the waypoints: the NLP's rows hold
#: there to IPOPT's tolerance (1e-13 m/s measured).
LATERAL_SPEED_TOL = 1e-3
#: ... and between them, on the executed spline: a cubic through (x, y, yaw) is not itself a
#: differential-drive path, it drifts sideways where the base turns while driving. Measured (forte
#: on the shipped tasks with ``base: differential``): 0.1 mm/s on lift.yaml, 0.2 mm/s on the test's
#: drive-and-turn, 2.8, 5.8 and 8.1 mm/s on around-the-crate, through-the-doorway and
#: table-to-shelf (base turning at up to 0.8 rad/s while driving at 0.5 m/s).
SPLINE_LATERAL_SPEED_TOL = 1e-2
#: How far (m, rad) a fixed base may move from its initial pose (its variables are bounded there).
FIXED_BASE_TOL = 1e-9


@dataclass(frozen=True)
class BaseMode(Requirement):
    """A ``fixed`` base never leaves its initial pose (m, rad); a ``differential`` one has no
    lateral velocity in its own frame: at the waypoints the plan's step at the interval's midpoint
    heading (the NLP's row, :mod:`forte.planning.nlp.base_rows`) over ``dt``, at most
    :data:`LATERAL_SPEED_TOL`; between them the spline's velocity at its own heading, at most
    :data:`SPLINE_LATERAL_SPEED_TOL`. Nothing for ``holonomic``."""

    name: ClassVar[str] = "base_mode"

    def measures(self, ctx: Context) -> list[Measure]:
        s, mode = ctx.samples, ctx.robot.base
        if mode == "fixed":
            moved = np.max(np.abs(s.q[:, :N_BASE] - s.q[:1, :N_BASE]), axis=1)
            return [Measure(moved, FIXED_BASE_TOL, "m or rad", "the fixed base moves")]
        if mode != "differential":
            return []
        yaw = s.q[:, 2]
        between = np.abs(-np.sin(yaw) * s.dq[:, 0] + np.cos(yaw) * s.dq[:, 1])
        between[s.waypoint] = 0.0
        at = np.zeros(len(s.t))  # the first waypoint has no step
        at[s.waypoint[1:]] = np.abs(lateral_displacement(s.q[s.waypoint])) / np.diff(s.t[s.waypoint])
        return [Measure(at, LATERAL_SPEED_TOL, "m/s", "the differential base moves sideways"),
                Measure(between, SPLINE_LATERAL_SPEED_TOL, "m/s",
                        "the differential base's spline moves sideways between waypoints")]



@dataclass(frozen=True)
class Tipover(Requirement):
    """The zero-moment point inside the base's support polygon: margin >= 0 m at every sample."""

    name: ClassVar[str] = "tipover"
    mass_dependent: ClassVar[bool] = True  # the payload's wrench moves the ZMP

    def measures(self, ctx: Context) -> list[Measure]:
        if ctx.robot.base_support is None:
            return []
        s = ctx.samples
        margin = tipover_margin(ctx.robot, s.q, s.dq, s.ddq, ctx.force.requirement)
        return [Measure(-margin, 0.0, "m", "the zero-moment point leaves the base's support polygon (-margin > 0)")]
