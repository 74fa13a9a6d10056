"""What every requirement of :mod:`forte.planning.verdict.requirements` is made of: the judged context, a
sampled measure, the requirement's base class and the violation it reports."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, ClassVar, NamedTuple

import numpy as np

from forte.model.clearance import Clearances
from forte.model.robot import MobileManipulator
from forte.model.scene import Scene
from forte.planning.tasks.scene_section import DEFAULT_CLEARANCE
from forte.planning.verdict.motion_samples import MotionSamples, SampledForce
from forte.validation import FloatArray


class Violation(NamedTuple):
    """A failed requirement.

    Attributes:
        requirement: the requirement's name (``capacity``, ``torque``, ...).
        detail: one line: what failed, where and by how much.
        worst: the worst value of the judged quantity, ``limit``: the value it had to respect
            (both in ``units``).
        waypoints: waypoints at which it fails (empty when only between waypoints or for the solver).
        first_time: the first time (s) at which it fails (``None`` for the solver).
    """

    requirement: str
    detail: str
    worst: float
    limit: float
    units: str
    waypoints: tuple[int, ...]
    first_time: float | None

    def to_json(self) -> dict[str, Any]:
        return {"requirement": self.requirement, "detail": self.detail, "worst": self.worst, "limit": self.limit,
                "units": self.units, "waypoints": list(self.waypoints), "first_time": self.first_time}


class Context(NamedTuple):
    """What the requirements judge: the sampled plan, its force, the robot and the solver facts.

    Attributes:
        robot, samples: the robot and the plan sampled (:mod:`forte.planning.verdict.motion_samples`).
        force: the task force and ball radii at the samples.
        alpha: the metric's ``alpha``.
        targets: the task's end-effector poses at the samples (K x 4 x 4), ``None``: unknown.
        velocity_limits, acceleration_limits: whole-body limits (nq; ``inf`` where none).
        solver: the solver's facts (``{}`` for a plan that was not optimized).
        optimized: whether the plan came from the solver.
        scene, clearance: the static bodies around the robot and the distance (m) to keep from them.
        distances: the exact robot-scene clearance at every sample (``None``: not computed yet;
            :class:`Clearance` computes it when the scene is not empty).
        goal: a goal task's goal (:class:`~forte.planning.tasks.goals.Goal`): tracking judges the
            last configuration against it alone; ``None``: the task's path (``targets``).
        keep_level: the task's ``path.keep_level`` (:class:`~forte.planning.tasks.keep_level.KeepLevel`),
            judged by :class:`forte.planning.verdict.keep_level.TiltLimit`; ``None``: none.
    """

    robot: MobileManipulator
    samples: MotionSamples
    force: SampledForce
    alpha: float
    targets: FloatArray | None
    velocity_limits: FloatArray
    acceleration_limits: FloatArray
    solver: dict[str, Any]
    optimized: bool
    scene: Scene = Scene()
    clearance: float = DEFAULT_CLEARANCE
    distances: Clearances | None = None
    goal: Any = None
    keep_level: Any = None


def exceeded(ctx: Context, name: str, value: FloatArray, limit: float, units: str, what: str,
             which: Sequence[str] | None = None) -> Violation | None:
    """The violation where ``value`` (one per sample) exceeds ``limit``, else ``None``; ``which``
    names, per sample, the part that gives the value there (a joint), named at the worst sample."""
    bad = value > limit
    if not np.any(bad):
        return None
    s = ctx.samples
    worst = int(np.argmax(value))
    at_waypoints = tuple(int(k) for k in np.flatnonzero(bad[s.waypoint]))
    first = float(s.t[np.flatnonzero(bad)[0]])
    where = (f"at {len(at_waypoints)} of {len(s.waypoint)} waypoints" if at_waypoints
             else "between waypoints only")
    part = f" ({which[worst]})" if which is not None else ""
    detail = (f"{what} {where}, first at t = {first:.3g} s; worst {value[worst]:.4g} {units}{part} "
              f"(limit {limit:.4g}) at t = {s.t[worst]:.3g} s{where_on_path(s, worst)}")
    return Violation(name, detail, float(value[worst]), float(limit), units, at_waypoints, first)


def where_on_path(samples: MotionSamples, i: int) -> str:
    """Where sample ``i`` lies: ``(waypoint k)`` on a waypoint, else ``(between waypoints k and k+1)``."""
    k = samples.segment_of(i)
    if samples.t[i] == samples.t[samples.waypoint[k]]:
        return f" (waypoint {k})"
    return f" (between waypoints {k} and {k + 1})"


class Measure(NamedTuple):
    """One sampled quantity a requirement bounds: it fails where ``value > limit``; ``which``
    (optional) names the part that gives the value at each sample (a joint's name)."""

    value: FloatArray
    limit: float
    units: str
    what: str
    which: Sequence[str] | None = None


@dataclass(frozen=True)
class Requirement:
    """One requirement: :meth:`measures` gives its sampled quantities and their limits, and
    :meth:`check` returns ``None`` or a :class:`Violation` for the first one that is exceeded."""

    name: ClassVar[str] = ""
    mass_dependent: ClassVar[bool] = False  # changes with the payload mass (the force)

    def measures(self, ctx: Context) -> list[Measure]:
        raise NotImplementedError

    def check(self, ctx: Context) -> Violation | None:
        for m in self.measures(ctx):
            found = exceeded(ctx, self.name, m.value, m.limit, m.units, m.what, m.which)
            if found is not None:
                return found
        return None
