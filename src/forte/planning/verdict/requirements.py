"""The requirements a plan must meet to be executable, one small class each.

Every requirement looks at the plan sampled at its waypoints and between them
(:class:`~forte.planning.verdict.motion_samples.MotionSamples`) and returns ``None`` or one
:class:`Violation` that says which requirement failed, where (waypoints, first time), and by how
much. :func:`forte.planning.verdict.verdict.judge` runs the list :data:`REQUIREMENTS`.

- :class:`Capacity`: the force ball inside the alpha-scaled RFP, ``d >= 0`` (Section 4.2), and
  the RFP's capacity along the force at least ``|f| + r`` (a wrench: :mod:`forte.capability.wrench`);
- :class:`TorqueWithForce`: ``|tau_nom + J^T f| <= tau_max`` at every arm joint (``J6^T w`` with a moment);
- :class:`JointPositions`, :class:`JointVelocities`, :class:`JointAccelerations`: the arm
  within its joint range (URDF), velocity (URDF) and acceleration limits (the robot
  description), the base within its velocity limits (:class:`forte.settings.KinematicLimits`);
  checked whether or not the NLP imposed them;
- :class:`~forte.planning.verdict.base_requirements.Tipover`: the whole robot's zero-moment point inside the
  base's support polygon (a robot that states one), :mod:`forte.model.stability`;
- :class:`~forte.planning.verdict.base_requirements.BaseMode`: the base moves as its mode allows
  (:attr:`MobileManipulator.base`): a fixed base stays put, a differential drive has no lateral velocity;
- :class:`Tracking`: the end effector on the task's path (position and orientation);
- :class:`~forte.planning.verdict.keep_level.TiltLimit`: the tool axis within ``path.keep_level``'s
  tilt of its world axis;
- :class:`SelfCollision`: no collision between the arm's URDF collision meshes;
- :class:`Clearance`: the whole robot (arm collision meshes, base box, payload) keeps the task's
  ``clearance`` from every scene body and the floor (but the parts rigid with the base, which rest
  on it), exactly on coal's geometry (:mod:`forte.model.clearance`);
- :class:`Solver`: the solver converged (its status) with a small constraint violation.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from forte.capability.metrics import capability_margin
from forte.capability.polytope import directional_capacity
from forte.capability.wrench import requirement_measures
from forte.force.taskforce import force_directions
from forte.model.clearance import Clearances, clearances
from forte.model.robot import N_BASE, MobileManipulator
from forte.model.self_collision import arm_geometry
from forte.planning.tasks.goals import GOAL_CONFIGURATION_TOL
from forte.planning.verdict.base_requirements import (
    FIXED_BASE_TOL,
    LATERAL_SPEED_TOL,
    SPLINE_LATERAL_SPEED_TOL,
    BaseMode,
    Tipover,
)
from forte.planning.verdict.keep_level import TiltLimit
from forte.planning.verdict.margin import execution_margin, kept_clearance, margin_note
from forte.planning.verdict.motion_samples import MotionSamples
from forte.planning.verdict.requirement_base import Context, Measure, Requirement, Violation, exceeded, where_on_path
from forte.settings import PLAN_SOLVE_CPU_S, WALL_PER_CPU
from forte.validation import FloatArray

#: End-effector position error (m) and orientation error (rad) a plan may have against its task's path.
TRACKING_POSITION_TOL = 0.01
TRACKING_ORIENTATION_TOL = 0.05
#: Relative slack on the velocity, acceleration and torque limits (round-off of the solver's bounds).
LIMIT_SLACK = 1e-6
#: Joint position slack (rad): the NLP's bounds are met to IPOPT's tolerance.
POSITION_SLACK = 1e-6
#: IPOPT statuses that count as converged.
CONVERGED = ("Solve_Succeeded", "Solved_To_Acceptable_Level")


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
        ratio, which = _ratio(tau, ctx.robot.torque_limits, joint_names(ctx.robot)[N_BASE:])
        return [Measure(ratio, 1.0 + LIMIT_SLACK, "x limit", "a joint torque with the task force exceeds its limit",
                        which)]


@dataclass(frozen=True)
class JointPositions(Requirement):
    """Arm joints within ``[q_min, q_max]`` (URDF), by how far outside (rad)."""

    name: ClassVar[str] = "joint_position"

    def measures(self, ctx: Context) -> list[Measure]:
        qa, r = ctx.samples.q[:, N_BASE:], ctx.robot
        beyond = np.maximum(qa - r.upper, r.lower - qa)
        worst = np.argmax(beyond, axis=1)
        names = joint_names(r)[N_BASE:]
        return [Measure(beyond[np.arange(len(qa)), worst], POSITION_SLACK, "rad", "an arm joint leaves its range",
                        [names[i] for i in worst])]


#: The names of the base's coordinates, before the arm's joints in whole-body vectors.
BASE_COORDINATES = ("base x", "base y", "base yaw")


def joint_names(robot: MobileManipulator) -> tuple[str, ...]:
    """Whole-body coordinate names: :data:`BASE_COORDINATES`, then the arm's joints."""
    return BASE_COORDINATES + tuple(robot.arm_joints or ())


def _ratio(values: FloatArray, limits: FloatArray, names: Sequence[str]) -> tuple[FloatArray, list[str]]:
    """Per sample: the worst ``|value_i| / limit_i`` over the coordinates with a finite limit, and
    the name of the coordinate that gives it."""
    finite = np.flatnonzero(np.isfinite(limits))
    if finite.size == 0:
        return np.zeros(len(values)), [""] * len(values)
    ratios = np.abs(values[:, finite]) / limits[finite]
    worst = np.argmax(ratios, axis=1)
    return ratios[np.arange(len(values)), worst], [names[i] for i in finite[worst]]


@dataclass(frozen=True)
class JointVelocities(Requirement):
    """``|dq_i| <= v_max,i`` for the base (x, y, yaw) and the arm joints."""

    name: ClassVar[str] = "velocity"

    def measures(self, ctx: Context) -> list[Measure]:
        ratio, which = _ratio(ctx.samples.dq, ctx.velocity_limits, joint_names(ctx.robot))
        return [Measure(ratio, 1.0 + LIMIT_SLACK, "x limit", "a joint or base velocity exceeds its limit", which)]

    @staticmethod
    def ratios(samples: MotionSamples, velocity_limits: FloatArray) -> FloatArray:
        """Per whole-body coordinate: the worst ``|dq_i| / v_max,i`` over the samples (0 where unlimited)."""
        return np.max(np.abs(samples.dq) / velocity_limits, axis=0)


@dataclass(frozen=True)
class JointAccelerations(Requirement):
    """``|ddq_i| <= a_max,i`` for the arm joints (the robot description's limits: the Panda's
    datasheet for the built-in arm). The base's acceleration limits are the planner's own choice,
    not the robot's: its controller limits velocity only (Section 3.1), so only velocity is judged
    for the base."""

    name: ClassVar[str] = "acceleration"

    def measures(self, ctx: Context) -> list[Measure]:
        ratio, which = _ratio(ctx.samples.ddq[:, N_BASE:], ctx.acceleration_limits[N_BASE:],
                              joint_names(ctx.robot)[N_BASE:])
        return [Measure(ratio, 1.0 + LIMIT_SLACK, "x limit", "an arm joint acceleration exceeds its limit", which)]

    @staticmethod
    def ratios(samples: MotionSamples, acceleration_limits: FloatArray) -> FloatArray:
        """Per arm joint: the worst ``|ddq_i| / a_max,i`` over the samples (whole-body limits in)."""
        return np.max(np.abs(samples.ddq[:, N_BASE:]) / acceleration_limits[N_BASE:], axis=0)


def orientation_errors(ee: FloatArray, targets: FloatArray) -> FloatArray:
    """Angle (rad) of ``R_target^T R`` at every sample."""
    rel = np.einsum("kji,kjl->kil", targets[:, :3, :3], ee[:, :3, :3])
    cos = np.clip((np.trace(rel, axis1=1, axis2=2) - 1.0) / 2.0, -1.0, 1.0)
    return np.arccos(cos)


@dataclass(frozen=True)
class Tracking(Requirement):
    """The end effector within :data:`TRACKING_POSITION_TOL` (m) and
    :data:`TRACKING_ORIENTATION_TOL` (rad) of the task's path at every sample; a goal task (its
    path free): the last sample at the goal and each via at its waypoint (:func:`goal_measures`)."""

    name: ClassVar[str] = "tracking"

    def measures(self, ctx: Context) -> list[Measure]:
        if ctx.goal is not None:
            return goal_measures(ctx)
        if ctx.targets is None:
            return []
        ee = ctx.samples.ee
        pos = np.linalg.norm(ee[:, :3, 3] - ctx.targets[:, :3, 3], axis=1)
        return [Measure(pos, TRACKING_POSITION_TOL, "m", "the end effector leaves the task's path"),
                Measure(orientation_errors(ee, ctx.targets), TRACKING_ORIENTATION_TOL, "rad",
                        "the end effector turns away from the task's orientation")]


def goal_measures(ctx: Context) -> list[Measure]:
    """A goal at the last waypoint (zero before it): a configuration goal's worst coordinate
    ``max_i |q_N,i - q_goal,i|`` within :data:`~forte.planning.tasks.goals.GOAL_CONFIGURATION_TOL`
    (named), a pose goal's position and angle errors within its tolerances."""
    goal, s = ctx.goal, ctx.samples
    end = int(s.waypoint[-1])
    at_end = s.t >= s.t[end]  # the last waypoint's samples (the grid repeats it as the last interval's end)
    if goal.pose is None:
        gap = np.abs(s.q[end] - goal.q_end)
        worst = int(np.argmax(gap))
        return [Measure(np.where(at_end, gap[worst], 0.0), GOAL_CONFIGURATION_TOL, "rad or m",
                        "the plan does not end at the goal configuration", [joint_names(ctx.robot)[worst]] * len(s.t)),
                *via_measures(ctx)]
    ee = s.ee[end]
    position = np.where(at_end, np.linalg.norm(ee[:3, 3] - goal.pose[:3, 3]), 0.0)
    angle = np.where(at_end, orientation_errors(ee[None], goal.pose[None])[0], 0.0)
    return [Measure(position, goal.position_tol, "m", "the end effector ends away from the goal position"),
            Measure(angle, goal.angle_tol, "rad", "the end effector ends turned away from the goal orientation"),
            *via_measures(ctx)]


def via_measures(ctx: Context) -> list[Measure]:
    """Each via pose at its waypoint ``k_i`` (:mod:`forte.planning.tasks.goal_poses`; zero elsewhere):
    the position and angle errors within the via's tolerances."""
    goal, s = ctx.goal, ctx.samples
    measures = []
    for i, (via, k) in enumerate(zip(goal.vias, goal.steps(s.t[s.waypoint]), strict=True)):
        at = s.t == s.t[s.waypoint[k]]
        ee = s.ee[s.waypoint[k]]
        position = np.where(at, np.linalg.norm(ee[:3, 3] - via.pose[:3, 3]), 0.0)
        angle = np.where(at, orientation_errors(ee[None], via.pose[None])[0], 0.0)
        measures += [Measure(position, via.position_tol, "m", f"the end effector misses via {i}'s position"),
                     Measure(angle, via.angle_tol, "rad", f"the end effector passes via {i} turned away")]
    return measures


#: How many colliding pairs of links a self-collision violation names (deepest first).
NAMED_PAIRS = 3


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
        hit = np.array([c is not None for c in geometry.contacts(ctx.samples.q[:, N_BASE:])], dtype=float)
        return [Measure(hit, 0.5, "", "arm links collide")]

    def check(self, ctx: Context) -> Violation | None:
        """The violation of :meth:`measures`, its detail naming the colliding pairs of links deepest
        first (:meth:`~forte.model.self_collision.ArmGeometry.link_contacts`, at most
        :data:`NAMED_PAIRS`), each with its deepest penetration and where; ``worst``: the deepest (m)."""
        found = super().check(ctx)
        geometry = arm_geometry(ctx.robot)
        if found is None or geometry is None:
            return found
        s, deepest = ctx.samples, {}
        for i in np.flatnonzero([c is not None for c in geometry.contacts(s.q[:, N_BASE:])]):
            for c in geometry.link_contacts(s.q[i, N_BASE:]):
                key = frozenset((c.first, c.second))
                if key not in deepest or c.depth > deepest[key][0].depth:
                    deepest[key] = (c, int(i))
        ranked = sorted(deepest.values(), key=lambda ci: -ci[0].depth)
        named = "; ".join(f"{c.first} with {c.second} {1e3 * c.depth:.3g} mm deep at t = {s.t[i]:.3g} s"
                          f"{where_on_path(s, i)}" for c, i in ranked[:NAMED_PAIRS])
        more = f" (+{len(ranked) - NAMED_PAIRS} more pairs)" if len(ranked) > NAMED_PAIRS else ""
        worst = ranked[0][0].depth if ranked else found.worst
        detail = f"{found.detail.split(';')[0]}: {named}{more}" if ranked else found.detail.split(";")[0]
        return found._replace(detail=detail, worst=worst, limit=0.0, units="m")


def scene_distances(ctx: Context) -> Clearances | None:
    """The exact clearance at every sample (``None`` without bodies and floor: nothing to compute)."""
    if not ctx.scene.solid:
        return None
    return ctx.distances if ctx.distances is not None else clearances(ctx.robot, ctx.scene, ctx.samples.q)


#: The fixed base's executor margin (m); a robot's own: :func:`~forte.planning.verdict.margin.execution_margin`.
EXECUTION_MARGIN = execution_margin("fixed")


@dataclass(frozen=True)
class Clearance(Requirement):
    """Every robot part at least the kept clearance (m,
    :func:`~forte.planning.verdict.margin.kept_clearance`: ``ctx.clearance``, at least the
    executor's margin of the robot's base kind) from every scene body and from the floor (the arm's
    links and the payload; the parts rigid with the base rest on it), at every sample (signed distance
    on coal's exact geometry, :mod:`forte.model.clearance`); the violation names the closest pair
    (``payload vs floor``) and its time. A world without bodies and floor is not checked."""

    name: ClassVar[str] = "clearance"

    def measures(self, ctx: Context) -> list[Measure]:
        found = scene_distances(ctx)
        if found is None:
            return []
        return [Measure(-found.distance, -kept_clearance(ctx.clearance, found.distance, ctx.robot.base), "m",
                        "the robot comes closer to the scene than the clearance (-distance > -clearance)")]

    def check(self, ctx: Context) -> Violation | None:
        found = scene_distances(ctx)
        if found is None:
            return None
        kept = kept_clearance(ctx.clearance, found.distance, ctx.robot.base)
        s, bad = ctx.samples, found.distance < kept
        if not np.any(bad):
            return None
        worst = found.closest()
        at_waypoints = tuple(int(k) for k in np.flatnonzero(bad[s.waypoint]))
        first = float(s.t[np.flatnonzero(bad)[0]])
        where = (f"at {len(at_waypoints)} of {len(s.waypoint)} waypoints" if at_waypoints
                 else "between waypoints only")
        margin = margin_note(ctx.clearance, kept, ctx.robot.base)
        detail = (f"{found.robot[worst]} vs {found.body[worst]} {found.distance[worst]:.3g} m < "
                  f"{kept:g} m{margin} at t = {s.t[worst]:.3g} s (below the clearance {where}, "
                  f"first at t = {first:.3g} s)")
        return Violation(self.name, detail, float(found.distance[worst]), kept, "m",
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
        if status in ("Maximum_CpuTime_Exceeded", "Maximum_WallTime_Exceeded"):
            cpu = float(ctx.solver.get("time_budget_s", PLAN_SOLVE_CPU_S))
            bound = (f"{cpu:g} s of CPU time in all, solver.time_budget_s" if "Cpu" in status
                     else f"{cpu * WALL_PER_CPU:g} s of wall time in all, {WALL_PER_CPU:g} x solver.time_budget_s")
            why += f" (a plan's solves have {bound}: a solve that long does not converge; the plan is the last iterate)"
        detail = f"{why}; constraint violation {violation:.3g} (accepted up to {accepted:g})"
        if "failed_rows" in ctx.solver:  # what the last iterate could not meet (forte.planning.scene.diagnosis)
            detail += "; " + ctx.solver["failed_rows"]["sentence"]
        return Violation(self.name, detail, violation, accepted, "", (), None)


#: The requirements every plan is judged on, in the order their failures are reported (a plan
#: that runs into the scene is reported for that first: one line names the pair).
REQUIREMENTS: tuple[Requirement, ...] = (
    Solver(), Clearance(), Capacity(), TorqueWithForce(), Tipover(), JointPositions(), JointVelocities(),
    JointAccelerations(), BaseMode(), Tracking(), TiltLimit(), SelfCollision(),
)

__all__ = ["CONVERGED", "FIXED_BASE_TOL", "LATERAL_SPEED_TOL", "REQUIREMENTS", "SPLINE_LATERAL_SPEED_TOL",
           "BaseMode", "Capacity", "Clearance", "Context", "JointAccelerations", "JointPositions", "JointVelocities",
           "Measure", "Requirement", "SelfCollision", "Solver", "TiltLimit", "Tipover", "TorqueWithForce", "Tracking",
           "Violation",
           "exceeded", "orientation_errors", "scene_distances"]
