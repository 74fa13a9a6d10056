"""The requirements a plan must meet to be executable, one small class each.

Every requirement looks at the plan sampled at its waypoints and between them
(:class:`~forte.planning.motion_samples.MotionSamples`) and returns ``None`` or one
:class:`Violation` that says which requirement failed, where (waypoints, first time), and by how
much. :func:`forte.planning.verdict.judge` runs the list :data:`REQUIREMENTS`.

- :class:`Capacity`: the force ball inside the alpha-scaled RFP, ``d >= 0`` (Section 4.2), and
  the RFP's capacity along the force at least ``|f| + r`` (a wrench: :mod:`forte.capability.wrench`);
- :class:`TorqueWithForce`: ``|tau_nom + J^T f| <= tau_max`` at every arm joint (``J6^T w`` with a moment);
- :class:`JointPositions`, :class:`JointVelocities`, :class:`JointAccelerations`: the arm
  within its joint range (URDF), velocity (URDF) and acceleration limits (the robot
  description), the base within its velocity limits (:class:`forte.settings.KinematicLimits`);
  checked whether or not the NLP imposed them;
- :class:`BaseMode`: the base moves as its mode allows (:attr:`MobileManipulator.base`): a fixed
  base stays put, a differential drive has no lateral velocity;
- :class:`Tracking`: the end effector on the task's path (position and orientation);
- :class:`SelfCollision`: no collision between the arm's URDF collision meshes;
- :class:`Clearance`: the whole robot (arm collision meshes, base box) keeps the task's
  ``clearance`` from every scene body, exactly on coal's geometry (:mod:`forte.model.clearance`);
- :class:`Solver`: the solver converged (its status) with a small constraint violation.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar, NamedTuple

import numpy as np

from forte.capability.metrics import capability_margin
from forte.capability.polytope import directional_capacity
from forte.capability.wrench import requirement_measures
from forte.force.taskforce import force_directions
from forte.model.clearance import Clearances, clearances
from forte.model.robot import N_BASE, MobileManipulator
from forte.model.scene import Scene
from forte.model.self_collision import arm_geometry
from forte.planning.base_rows import lateral_displacement
from forte.planning.motion_samples import MotionSamples, SampledForce
from forte.planning.scene_section import DEFAULT_CLEARANCE
from forte.validation import FloatArray

#: End-effector position error (m) and orientation error (rad) a plan may have against its task's path.
TRACKING_POSITION_TOL = 0.01
TRACKING_ORIENTATION_TOL = 0.05
#: Relative slack on the velocity, acceleration and torque limits (round-off of the solver's bounds).
LIMIT_SLACK = 1e-6
#: Joint position slack (rad): the NLP's bounds are met to IPOPT's tolerance.
POSITION_SLACK = 1e-6
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
#: IPOPT statuses that count as converged.
CONVERGED = ("Solve_Succeeded", "Solved_To_Acceptable_Level")


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
        robot, samples: the robot and the plan sampled (:mod:`forte.planning.motion_samples`).
        force: the task force and ball radii at the samples.
        alpha: the metric's ``alpha``.
        targets: the task's end-effector poses at the samples (K x 4 x 4), ``None``: unknown.
        velocity_limits, acceleration_limits: whole-body limits (nq; ``inf`` where none).
        solver: the solver's facts (``{}`` for a plan that was not optimized).
        optimized: whether the plan came from the solver.
        scene, clearance: the static bodies around the robot and the distance (m) to keep from them.
        distances: the exact robot-scene clearance at every sample (``None``: not computed yet;
            :class:`Clearance` computes it when the scene is not empty).
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


def exceeded(ctx: Context, name: str, value: FloatArray, limit: float, units: str, what: str) -> Violation | None:
    """The violation where ``value`` (one per sample) exceeds ``limit``, else ``None``."""
    bad = value > limit
    if not np.any(bad):
        return None
    s = ctx.samples
    worst = int(np.argmax(value))
    at_waypoints = tuple(int(k) for k in np.flatnonzero(bad[s.waypoint]))
    first = float(s.t[np.flatnonzero(bad)[0]])
    where = (f"at {len(at_waypoints)} of {len(s.waypoint)} waypoints" if at_waypoints
             else "between waypoints only")
    detail = (f"{what} {where}, first at t = {first:.3g} s; worst {value[worst]:.4g} {units} "
              f"(limit {limit:.4g}) at t = {s.t[worst]:.3g} s")
    return Violation(name, detail, float(value[worst]), float(limit), units, at_waypoints, first)


class Measure(NamedTuple):
    """One sampled quantity a requirement bounds: it fails where ``value > limit``."""

    value: FloatArray
    limit: float
    units: str
    what: str


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
            found = exceeded(ctx, self.name, m.value, m.limit, m.units, m.what)
            if found is not None:
                return found
        return None


@dataclass(frozen=True)
class Capacity(Requirement):
    """``d_k >= 0`` with ``alpha`` (the ball inside the scaled RFP) and ``capacity >= |f| + r``."""

    name: ClassVar[str] = "capacity"
    mass_dependent: ClassVar[bool] = True

    def measures(self, ctx: Context) -> list[Measure]:
        s, f = ctx.samples, ctx.force
        if f.m is not None:  # a wrench: the same two on the residual wrench polytope
            w = requirement_measures(s.task_jacobian, s.tau_nom, ctx.robot.torque_limits, f, ctx.alpha)
            return [Measure(-w["d"], 0.0, "N", "the wrench set leaves the alpha-scaled wrench polytope (-d > 0)"),
                    Measure(w["shortfall"], 0.0, "N", "the polytope's capacity along the wrench is below |f| + r")]
        d = capability_margin(s.A, ctx.alpha * s.b, f.f, f.r)
        short = (np.linalg.norm(f.f, axis=1) + f.r) - directional_capacity(s.A, s.b, force_directions(f.f))
        return [Measure(-d, 0.0, "N", "the force ball leaves the alpha-scaled RFP (-d > 0)"),
                Measure(short, 0.0, "N", "the RFP's capacity along the force is below |f| + r (shortfall)")]


@dataclass(frozen=True)
class TorqueWithForce(Requirement):
    """``max_i |tau_nom,i + (J^T f)_i| / tau_max,i <= 1``: the joint torques that move the arm and
    apply the task force stay within the limits (with a moment: ``J6^T w``, the full wrench)."""

    name: ClassVar[str] = "torque"
    mass_dependent: ClassVar[bool] = True

    def measures(self, ctx: Context) -> list[Measure]:
        s = ctx.samples
        tau = s.tau_nom + np.einsum("kij,ki->kj", s.task_jacobian, ctx.force.requirement)
        ratio = np.max(np.abs(tau) / ctx.robot.torque_limits, axis=1)
        return [Measure(ratio, 1.0 + LIMIT_SLACK, "x limit", "a joint torque with the task force exceeds its limit")]


@dataclass(frozen=True)
class JointPositions(Requirement):
    """Arm joints within ``[q_min, q_max]`` (URDF), by how far outside (rad)."""

    name: ClassVar[str] = "joint_position"

    def measures(self, ctx: Context) -> list[Measure]:
        qa, r = ctx.samples.q[:, N_BASE:], ctx.robot
        outside = np.max(np.maximum(qa - r.upper, r.lower - qa), axis=1)
        return [Measure(outside, POSITION_SLACK, "rad", "an arm joint leaves its range")]


def _ratio(values: FloatArray, limits: FloatArray) -> FloatArray:
    finite = np.isfinite(limits)
    if not np.any(finite):
        return np.zeros(len(values))
    return np.max(np.abs(values[:, finite]) / limits[finite], axis=1)


@dataclass(frozen=True)
class JointVelocities(Requirement):
    """``|dq_i| <= v_max,i`` for the base (x, y, yaw) and the arm joints."""

    name: ClassVar[str] = "velocity"

    def measures(self, ctx: Context) -> list[Measure]:
        ratio = _ratio(ctx.samples.dq, ctx.velocity_limits)
        return [Measure(ratio, 1.0 + LIMIT_SLACK, "x limit", "a joint or base velocity exceeds its limit")]


@dataclass(frozen=True)
class JointAccelerations(Requirement):
    """``|ddq_i| <= a_max,i`` for the arm joints (the robot description's limits: the Panda's
    datasheet for the built-in arm). The base's acceleration limits are the planner's own choice,
    not the robot's: its controller limits velocity only (Section 3.1), so only velocity is judged
    for the base."""

    name: ClassVar[str] = "acceleration"

    def measures(self, ctx: Context) -> list[Measure]:
        ratio = _ratio(ctx.samples.ddq[:, N_BASE:], ctx.acceleration_limits[N_BASE:])
        return [Measure(ratio, 1.0 + LIMIT_SLACK, "x limit", "an arm joint acceleration exceeds its limit")]

    @staticmethod
    def ratios(samples: MotionSamples, acceleration_limits: FloatArray) -> FloatArray:
        """Per arm joint: the worst ``|ddq_i| / a_max,i`` over the samples (whole-body limits in)."""
        return np.max(np.abs(samples.ddq[:, N_BASE:]) / acceleration_limits[N_BASE:], axis=0)


@dataclass(frozen=True)
class BaseMode(Requirement):
    """A ``fixed`` base never leaves its initial pose (m, rad); a ``differential`` one has no
    lateral velocity in its own frame: at the waypoints the plan's step at the interval's midpoint
    heading (the NLP's row, :mod:`forte.planning.base_rows`) over ``dt``, at most
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


def orientation_errors(ee: FloatArray, targets: FloatArray) -> FloatArray:
    """Angle (rad) of ``R_target^T R`` at every sample."""
    rel = np.einsum("kji,kjl->kil", targets[:, :3, :3], ee[:, :3, :3])
    cos = np.clip((np.trace(rel, axis1=1, axis2=2) - 1.0) / 2.0, -1.0, 1.0)
    return np.arccos(cos)


@dataclass(frozen=True)
class Tracking(Requirement):
    """The end effector within :data:`TRACKING_POSITION_TOL` (m) and
    :data:`TRACKING_ORIENTATION_TOL` (rad) of the task's path at every sample."""

    name: ClassVar[str] = "tracking"

    def measures(self, ctx: Context) -> list[Measure]:
        if ctx.targets is None:
            return []
        ee = ctx.samples.ee
        pos = np.linalg.norm(ee[:, :3, 3] - ctx.targets[:, :3, 3], axis=1)
        return [Measure(pos, TRACKING_POSITION_TOL, "m", "the end effector leaves the task's path"),
                Measure(orientation_errors(ee, ctx.targets), TRACKING_ORIENTATION_TOL, "rad",
                        "the end effector turns away from the task's orientation")]


@dataclass(frozen=True)
class SelfCollision(Requirement):
    """No contact between the arm's URDF collision meshes (coal, :mod:`forte.model.self_collision`).

    The authors' spheres (basket against base, :data:`forte.model.collision.AUTHORS_SPHERES`) are
    not judged here: they are a soft keep-out with a 0.08 m margin in the cost (a 0.52 m ball for
    the base), which the authors' own lift overlaps by up to 9 cm, not the robot's geometry. The
    base's own geometry is not in the URDF either (:class:`Clearance` judges it against a scene).
    """

    name: ClassVar[str] = "self_collision"

    def measures(self, ctx: Context) -> list[Measure]:
        geometry = arm_geometry(ctx.robot)
        if geometry is None:
            return []
        hit = np.array([geometry.contact(qk[N_BASE:]) is not None for qk in ctx.samples.q], dtype=float)
        return [Measure(hit, 0.5, "", "arm links collide")]

    def check(self, ctx: Context) -> Violation | None:
        found = super().check(ctx)
        if found is None:
            return None
        geometry = arm_geometry(ctx.robot)
        first = int(np.flatnonzero(ctx.samples.t == found.first_time)[0])
        pair = geometry.contact(ctx.samples.q[first, N_BASE:]) if geometry is not None else None
        names = f": {pair.first} with {pair.second}" if pair is not None else ""
        return found._replace(detail=f"{found.detail.split(';')[0]}{names}")


def scene_distances(ctx: Context) -> Clearances | None:
    """The exact clearance at every sample (``None`` for an empty scene: nothing to compute)."""
    if not ctx.scene:
        return None
    return ctx.distances if ctx.distances is not None else clearances(ctx.robot, ctx.scene, ctx.samples.q)


@dataclass(frozen=True)
class Clearance(Requirement):
    """Every robot part at least ``ctx.clearance`` (m) from every scene body, at every sample
    (signed distance on coal's exact geometry, :mod:`forte.model.clearance`); the violation names
    the closest pair and its time. An empty scene is not checked."""

    name: ClassVar[str] = "clearance"

    def measures(self, ctx: Context) -> list[Measure]:
        found = scene_distances(ctx)
        if found is None:
            return []
        return [Measure(-found.distance, -ctx.clearance, "m", "the robot comes closer to the scene than the "
                        "clearance (-distance > -clearance)")]

    def check(self, ctx: Context) -> Violation | None:
        found = scene_distances(ctx)
        if found is None:
            return None
        s, bad = ctx.samples, found.distance < ctx.clearance
        if not np.any(bad):
            return None
        worst = found.closest()
        at_waypoints = tuple(int(k) for k in np.flatnonzero(bad[s.waypoint]))
        first = float(s.t[np.flatnonzero(bad)[0]])
        where = (f"at {len(at_waypoints)} of {len(s.waypoint)} waypoints" if at_waypoints
                 else "between waypoints only")
        detail = (f"{found.robot[worst]} vs {found.body[worst]} {found.distance[worst]:.3g} m < "
                  f"{ctx.clearance:g} m at t = {s.t[worst]:.3g} s (below the clearance {where}, "
                  f"first at t = {first:.3g} s)")
        return Violation(self.name, detail, float(found.distance[worst]), float(ctx.clearance), "m",
                         at_waypoints, first)


@dataclass(frozen=True)
class Solver(Requirement):
    """An optimized plan: IPOPT converged (:data:`CONVERGED`) with a constraint violation within
    what the solver accepts (``accepted_violation`` of its facts, else ``max_violation``)."""

    name: ClassVar[str] = "solver"
    max_violation: float = 1e-5

    def measures(self, ctx: Context) -> list[Measure]:
        return []  # not sampled: judged on the solver's facts

    def check(self, ctx: Context) -> Violation | None:
        if not ctx.optimized:
            return None
        status = str(ctx.solver.get("status", "unknown"))
        violation = float(ctx.solver.get("constraint_violation", np.inf))
        accepted = float(ctx.solver.get("accepted_violation", self.max_violation))
        if status in CONVERGED and violation <= accepted:
            return None
        why = f"IPOPT stopped with {status}" if status not in CONVERGED else "constraints not met"
        detail = f"{why}; constraint violation {violation:.3g} (accepted up to {accepted:g})"
        return Violation(self.name, detail, violation, accepted, "", (), None)


#: The requirements every plan is judged on, in the order their failures are reported (a plan
#: that runs into the scene is reported for that first: one line names the pair).
REQUIREMENTS: tuple[Requirement, ...] = (
    Solver(), Clearance(), Capacity(), TorqueWithForce(), JointPositions(), JointVelocities(),
    JointAccelerations(), BaseMode(), Tracking(), SelfCollision(),
)
