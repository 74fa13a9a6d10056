"""The verdict of a plan: can it be executed?

A plan is judged after the solve, on exact quantities (never the optimizer's smooth surrogates),
at every waypoint and on a dense grid between them (:mod:`forte.planning.verdict.motion_samples`), against
every requirement of :data:`forte.planning.verdict.requirements.REQUIREMENTS`:

- ``feasible``: every requirement holds;
- ``infeasible``: the solver converged (or the plan was not optimized) but some requirement fails;
- ``solver-failed``: the solver did not converge (the last iterate is kept for inspection).

Every entry point reads the same verdict: ``forte plan`` (exit 0 only when feasible),
``forte compare``, sweeps, the experiments, ``forte simulate`` and :func:`forte.plan`.

When the capacity or torque requirement fails, :func:`fixed_motion_bound` says what would work: the
largest payload mass the same motion carries (bisection on the verdict's mass-dependent
requirements, the force recomputed from the task for every mass); :mod:`forte.planning.bounds`
re-plans for every mass.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np

from forte.force.taskforce import TaskForce
from forte.model.clearance import clearances
from forte.model.robot import MobileManipulator
from forte.model.scene import Scene
from forte.planning.tasks.scene_section import DEFAULT_CLEARANCE
from forte.planning.verdict.margin import kept_clearance
from forte.planning.verdict.motion_samples import (
    SAMPLES_PER_INTERVAL,
    MotionSamples,
    force_at,
    sample_motion,
    with_angular,
)
from forte.planning.verdict.requirements import (
    REQUIREMENTS,
    Capacity,
    Context,
    JointAccelerations,
    JointVelocities,
    Requirement,
    Violation,
    scene_distances,
)
from forte.settings import KinematicLimits
from forte.validation import FloatArray

#: The verdict labels.
FEASIBLE, INFEASIBLE, SOLVER_FAILED = "feasible", "infeasible", "solver-failed"
VERDICTS: tuple[str, ...] = (FEASIBLE, INFEASIBLE, SOLVER_FAILED)


class Verdict(NamedTuple):
    """Whether a plan can be executed, and every requirement it fails.

    Attributes:
        label: ``feasible``, ``infeasible`` or ``solver-failed``.
        violations: the failed requirements, in the order of ``checked``.
        checked: the names of the requirements judged.
        samples_per_interval: density of the grid between waypoints.
        payload_bound: what would work when the capacity or torque requirement fails
            (``asked_kg``, ``fixed_motion_kg``: :func:`fixed_motion_bound`), else ``None``.
        clearance: with a scene, the closest approach over every sample (:func:`clearance_summary`:
            the distance, the pair, its time, the witness points); ``None`` without a scene.
            plan.json keeps it as its own ``clearance`` block, not inside ``verdict``.
    """

    label: str
    violations: tuple[Violation, ...]
    checked: tuple[str, ...]
    samples_per_interval: int
    payload_bound: dict[str, Any] | None = None
    clearance: dict[str, Any] | None = None

    @property
    def feasible(self) -> bool:
        return self.label == FEASIBLE

    @property
    def failed(self) -> tuple[str, ...]:
        return tuple(v.requirement for v in self.violations)

    def reason(self) -> str:
        """One line: ``feasible``, or the first failed requirement and its detail."""
        if not self.violations:
            return FEASIBLE
        first = self.violations[0]
        more = f" (+{len(self.violations) - 1} more: {', '.join(self.failed[1:])})" if len(self.violations) > 1 else ""
        return f"{self.label}: {first.requirement}: {first.detail}{more}"

    def brief(self) -> str:
        """The failed requirements with their worst values, e.g. ``capacity (17.8 N short), torque
        (1.05 x limit)``; empty when feasible."""
        def one(v: Violation) -> str:
            if v.requirement == "solver":
                return "solver (" + v.detail.split(";")[0].removeprefix("IPOPT stopped with ") + ")"
            if v.requirement == "self_collision":
                return "self-collision"
            short = " short" if v.units == "N" else ""
            return f"{v.requirement} ({v.worst:.3g} {v.units}{short})".replace(" )", ")")
        return ", ".join(one(v) for v in self.violations)

    def remedies(self) -> list[str]:
        """What would fix the plan, where the verdict can tell: a slower motion for a velocity
        (``x`` times the limit: ``x`` times slower, a velocity scales as 1 / duration) or an
        acceleration (``sqrt(x)`` times slower: 1 / duration^2) that exceeds its limit; the
        payload's fix is its bound (:attr:`payload_bound`)."""
        out = []
        for v in self.violations:
            slower = {"velocity": v.worst, "acceleration": np.sqrt(max(v.worst, 0.0))}.get(v.requirement)
            if slower is not None and v.first_time is not None:
                out.append(f"the motion where {v.requirement} fails (first at t = {v.first_time:.3g} s) at least "
                           f"{slower:.4g} x slower, e.g. that segment {slower:.4g} x longer")
        return out

    def to_json(self) -> dict[str, Any]:
        return {"label": self.label, "failed": [v.to_json() for v in self.violations], "checked": list(self.checked),
                "samples_per_interval": self.samples_per_interval, "payload_bound": self.payload_bound,
                "remedies": self.remedies()}

    @classmethod
    def from_json(cls, doc: dict[str, Any]) -> Verdict:
        violations = tuple(Violation(v["requirement"], v["detail"], v["worst"], v["limit"], v["units"],
                                     tuple(v["waypoints"]), v["first_time"]) for v in doc.get("failed", ()))
        return cls(doc["label"], violations, tuple(doc.get("checked", ())),
                   int(doc.get("samples_per_interval", SAMPLES_PER_INTERVAL)), doc.get("payload_bound"))


def _label(violations: tuple[Violation, ...]) -> str:
    if any(v.requirement == "solver" for v in violations):
        return SOLVER_FAILED
    return INFEASIBLE if violations else FEASIBLE


def context(robot: MobileManipulator, samples: MotionSamples, force: TaskForce, alpha: float,
            targets_at: Callable[[FloatArray], FloatArray] | None, limits: KinematicLimits | None,
            solver: dict[str, Any], optimized: bool, scene: Scene | None = None,
            clearance: float = DEFAULT_CLEARANCE, goal: Any = None, keep_level: Any = None) -> Context:
    """The :class:`~forte.planning.verdict.requirements.Context` of a sampled plan (the exact
    clearance at every sample computed once here when ``scene`` has bodies or a floor; ``None``:
    no world to keep clear of, not even a floor)."""
    vel, acc = (limits or KinematicLimits()).resolve(robot)
    targets = None if targets_at is None else np.asarray(targets_at(samples.t), dtype=float)
    scene = Scene((), None) if scene is None else scene
    distances = clearances(robot, scene, samples.q) if scene.solid else None
    if force.has_moment:  # the wrench requirement needs the angular Jacobians too
        samples = with_angular(robot, samples)
    return Context(robot, samples, force_at(force, samples.t), float(alpha), targets, vel, acc, solver, optimized,
                   scene, float(clearance), distances, goal, keep_level)


def clearance_summary(ctx: Context) -> dict[str, Any] | None:
    """The closest approach of the robot to the scene over every sample: ``min_m`` (signed, m),
    the pair (``robot`` part, scene ``body``), its time ``t`` and the ``waypoint`` at or before it, the
    witness points (world frame), the ``required_m`` clearance and the number of ``samples``;
    ``None`` for an empty scene."""
    found = scene_distances(ctx)
    if found is None:
        return None
    i, s = found.closest(), ctx.samples
    return {"min_m": float(found.distance[i]), "robot": found.robot[i], "body": found.body[i],
            "t": float(s.t[i]), "waypoint": s.segment_of(i),
            "required_m": kept_clearance(ctx.clearance, found.distance, ctx.robot.base),
            "witness_robot": found.witness_robot[i].tolist(), "witness_body": found.witness_body[i].tolist(),
            "samples": len(s.t)}


def judge_context(ctx: Context, requirements: tuple[Requirement, ...] = REQUIREMENTS,
                  per_interval: int = SAMPLES_PER_INTERVAL) -> Verdict:
    """Judge a prepared context on ``requirements``."""
    found = tuple(v for v in (req.check(ctx) for req in requirements) if v is not None)
    return Verdict(_label(found), found, tuple(r.name for r in requirements), per_interval,
                   clearance=clearance_summary(ctx))


def judge(robot: MobileManipulator, t: Any, q: Any, force: TaskForce, alpha: float, *,
          targets_at: Callable[[FloatArray], FloatArray] | None = None, limits: KinematicLimits | None = None,
          solver: dict[str, Any] | None = None, optimized: bool = False,
          per_interval: int = SAMPLES_PER_INTERVAL, scene: Scene | None = None,
          clearance: float = DEFAULT_CLEARANCE) -> Verdict:
    """The verdict of the plan ``(t, q)`` for the task force ``force`` (see the module docstring).

    Args:
        targets_at: the task's end-effector poses as a function of time (tracking is judged
            against it; ``None``: not judged).
        limits: the kinematic limits (velocity, acceleration); default :class:`KinematicLimits`.
        solver: the solver's facts (``status``, ``constraint_violation``) of an optimized plan.
        scene, clearance: the bodies around the robot and its floor, and the distance (m) to keep
            from them (``scene`` ``None``: none, not even a floor).
    """
    samples = sample_motion(robot, t, q, per_interval)
    ctx = context(robot, samples, force, alpha, targets_at, limits, solver or {}, optimized, scene, clearance)
    return judge_context(ctx, REQUIREMENTS, per_interval)


#: Mass resolution (kg) of the payload bounds.
MASS_RESOLUTION = 0.01
#: The payload mass tried for "no payload" (a payload mass must be > 0).
MIN_MASS = 1e-6


def largest_mass(holds: Callable[[float], bool], upper: float, resolution: float = MASS_RESOLUTION) -> float | None:
    """The largest mass in ``[0, upper]`` for which ``holds`` is true (``upper`` itself when it
    holds there), by bisection to ``resolution`` (``None`` when it fails even without payload).
    ``holds`` must be monotone: true up to some mass, false beyond (the force grows linearly with
    the mass; a re-planned bound assumes the planner keeps that order)."""
    if holds(float(upper)):
        return float(upper)
    if not holds(0.0):
        return None
    low, high = 0.0, float(upper)
    while high - low > resolution:
        mid = 0.5 * (low + high)
        low, high = (mid, high) if holds(mid) else (low, mid)
    return low


def fixed_motion_bound(ctx: Context, force_of: Callable[[float], TaskForce], upper: float) -> float | None:
    """The largest payload mass the plan's own motion carries: bisection on the capacity and torque
    requirements with the task force of each mass (everything else does not depend on the mass)."""
    mass_reqs = tuple(r for r in REQUIREMENTS if r.mass_dependent)

    def holds(mass: float) -> bool:
        trial = ctx._replace(force=force_at(force_of(mass), ctx.samples.t))
        return all(r.check(trial) is None for r in mass_reqs)

    return largest_mass(holds, upper)


def exit_code(plans: Any, allow_infeasible: bool = False) -> int:
    """The exit status of a run that produced ``plans``: 0 when every plan is feasible (or
    ``allow_infeasible``, for exploration), else 1."""
    return 0 if allow_infeasible or all(p.feasible for p in plans) else 1


def _task_targets(task: Any) -> Callable[[FloatArray], FloatArray] | None:
    """The task's end-effector poses as a function of time: its path, or its waypoint poses held."""
    if task.targets_at is not None and task.mode == "trajectory":
        return task.targets_at
    if task.n == 1:
        return lambda ts: np.repeat(task.targets[:1], len(ts), axis=0)
    return None


def capacity_shortfall(task: Any, q: Any, force: TaskForce, per_interval: int = SAMPLES_PER_INTERVAL) -> FloatArray:
    """Per waypoint: the worst capacity shortfall (N, ``max(-d, |f| + r - capacity, 0)``) on the
    samples of the intervals next to it (what a radius at that waypoint must cover)."""
    samples = sample_motion(task.robot, task.t, q, per_interval, task.start_motion)
    ctx = context(task.robot, samples, force, task.settings.alpha, None, task.limits, {}, False)
    minus_d, short = (m.value for m in Capacity().measures(ctx))
    worst = np.maximum(np.maximum(minus_d, short), 0.0)
    out = np.zeros(task.n)
    for i in np.flatnonzero(worst > 0):
        k = samples.segment_of(int(i))
        out[k] = max(out[k], worst[i])
        if k + 1 < task.n and samples.t[i] > task.t[k]:
            out[k + 1] = max(out[k + 1], worst[i])
    return out


def limit_ratios(task: Any, q: Any, per_interval: int = SAMPLES_PER_INTERVAL) -> tuple[FloatArray, FloatArray]:
    """The worst ``|dq_i| / v_max,i`` per whole-body coordinate and ``|ddq_i| / a_max,i`` per arm
    joint over the plan's samples (the task's limits)."""
    samples = sample_motion(task.robot, task.t, q, per_interval, task.start_motion)
    vel, acc = task.limits.resolve(task.robot)
    return JointVelocities.ratios(samples, vel), JointAccelerations.ratios(samples, acc)


def judge_plan(task: Any, q: Any, force: TaskForce, solver: dict[str, Any] | None = None,
               per_interval: int = SAMPLES_PER_INTERVAL) -> Verdict:
    """The verdict of configurations ``q`` planned for ``task`` (``solver``: the facts of an
    optimized plan, ``None`` for one that was not optimized), with the payload bound when a
    mass-dependent requirement (capacity, torque, tipover) fails, the force comes from a payload
    mass and the solver did not fail (its rows do not depend on the mass, so the payload is not
    what stopped it). The bound's record: ``asked_kg``, ``fixed_motion_kg``
    (:func:`fixed_motion_bound`), ``also_failed`` (the failed requirements no mass changes) and,
    when the motion fails even with no payload, ``unloaded_failed`` (which requirements then)."""
    samples = sample_motion(task.robot, task.t, q, per_interval, task.start_motion)
    ctx = context(task.robot, samples, force, task.settings.alpha, _task_targets(task), task.limits,
                  solver or {}, solver is not None, task.scene, task.clearance, getattr(task, "goal", None),
                  getattr(task, "keep_level", None))
    verdict = judge_context(ctx, REQUIREMENTS, per_interval)
    mass, by_mass = task.payload.mass, {r.name for r in REQUIREMENTS if r.mass_dependent}
    # a solver failure is not the payload's: no row of the NLP depends on the mass
    if mass is None or verdict.label == SOLVER_FAILED or not set(verdict.failed) & by_mass:
        return verdict

    def force_of(m: float) -> TaskForce:
        return task.force(mass=max(m, MIN_MASS))

    bound = fixed_motion_bound(ctx, force_of, mass)
    record = {"asked_kg": float(mass), "fixed_motion_kg": bound,
              "also_failed": [name for name in verdict.failed if name not in by_mass]}
    if bound is None:  # what the motion still fails with no payload at all
        unloaded = ctx._replace(force=force_at(force_of(0.0), ctx.samples.t))
        record["unloaded_failed"] = [r.name for r in REQUIREMENTS if r.mass_dependent and r.check(unloaded)]
    return verdict._replace(payload_bound=record)


def with_load_line(verdict: Verdict, waypoint: int, key: str, load_of: Any) -> Verdict:
    """``verdict`` with its first capacity failure at ``waypoint`` followed by what a posture held
    there can carry: ``load_of()`` (called only when there is such a failure) gives an object
    with ``line()`` and ``to_json()``, or ``None`` (then ``verdict`` as it is);
    ``payload_bound[key]`` records it (:mod:`~forte.planning.verdict.start_load`,
    :mod:`~forte.planning.verdict.goal_load`)."""
    at = [i for i, v in enumerate(verdict.violations) if v.requirement == "capacity" and waypoint in v.waypoints]
    load = load_of() if at else None
    if load is None:
        return verdict
    violations = list(verdict.violations)
    violations[at[0]] = violations[at[0]]._replace(detail=f"{violations[at[0]].detail}; {load.line()}")
    bound = (verdict.payload_bound or {}) | {key: load.to_json()}
    return verdict._replace(violations=tuple(violations), payload_bound=bound)
