"""Model-predictive control: re-solve the remaining motion at a fixed rate from the measured state.

An :class:`MpcLoop` is an after-step hook of :func:`~forte.execution.run.run_simulation`, like
:class:`~forte.execution.closed_loop.ReplanLoop` (whose identification, added payload and splice
it shares: :class:`~forte.execution.closed_loop.PayloadLoop`). It ticks every ``1 / rate_hz`` s
of simulated time (100 Hz: every 10th 1 ms control step) and at each tick

1. takes the newest payload mass: the online identifier's estimate (updated every control step),
   or an *asynchronous* estimate that has arrived (a VLM answer coming late):
   ``MpcOptions.estimates`` delivers ``(t, kg)`` at the first tick at or after ``t``,
   ``MpcOptions.source(t)`` is polled every tick (e.g. it drains a :class:`queue.Queue` that
   another thread fills) and returns kilograms or ``None``. An asynchronous estimate replaces the
   identifier's and seeds it: identification goes on from it (``identify=False``: the loop hears
   only the asynchronous estimates);
2. solves when the plan in force is stale: when the simulated time has passed a waypoint of the
   task's grid (lift: 0.25 s) that the planner's horizon has not reached, the horizon shifts
   there with the *measured* configuration as its first waypoint, moving as the controller's
   reference moves there (``MpcOptions.start``; :meth:`~forte.planning.online.replan.Replanner.shift`,
   :mod:`forte.planning.nlp.history`); otherwise, when the mass differs from the
   plan in force's by ``max(threshold m, 3 sigma, min_change)`` or more, or the planner holds a
   solution that was not published, the current horizon is re-solved
   (:meth:`~forte.planning.online.replan.Replanner.replan`); otherwise nothing. Every solve goes through
   :meth:`MpcLoop._solve_tick`;
3. publishes a solve that converged within its deadline (``deadline_s``, default
   ``1 / rate_hz``; measured: the wall-clock latency of the re-plan call, its metrics and verdict
   excluded)
   by splicing it into the controller's reference from the horizon's first waypoint on (one
   that is not feasible as ``MpcOptions.on_infeasible`` says). A
   solve that does not converge is never published (the plan in force stays; counted as
   *failed*; no solve is tried again before the next waypoint unless the mass departs from the
   failed one). A solve over its deadline is a
   *miss*: with ``on_miss="drop"`` the plan in force stays and the next tick solves again from
   the planner's newest point; with ``on_miss="delay"`` it is published at the first tick at
   which simulated time has caught up with the solve's wall time, and no solve starts
   meanwhile (a solver thread beside a real-time controller).

Simulated time stands still while the planner solves; the wall-clock time of every solve is
measured (on a shared machine it varies from run to run). The log has one entry per tick: time,
mass estimate, the mass of the plan in force, ``min_d`` (the smallest margin ``d`` of the plan in
force over its waypoints after the tick, at the mass it was planned for, with the derivatives of
the executed waypoint sequence: the waypoints in force before the splice, then the new plan's;
with the default ``start`` these are the new plan's own metrics), the solve's kind and time, whether it
missed its deadline and whether a plan was published.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from forte.exceptions import InvalidInputError
from forte.execution.closed_loop import MIN_PAYLOAD, PayloadLoop, replanner_of_plan
from forte.execution.control import Reference
from forte.execution.model import SimModel
from forte.execution.mpc_options import MPC_SOLVERS, ON_MISS, START_MOTIONS, MpcOptions, is_finite_number
from forte.force.taskforce import TaskForce
from forte.model.trajectory import motion_at
from forte.planning.online.realtime import RealTimeIteration
from forte.planning.online.replan import ReplanResult
from forte.planning.planner import evaluate
from forte.validation import FloatArray

#: Simulated-time tolerance of "at or after" (s): tick times are sums of 1 ms steps.
TIME_EPS = 1e-9


class _RealTimePlan(NamedTuple):
    """A published real-time step in the shape :meth:`MpcLoop._publish` reads (``result.plan``)."""

    step: Any

    @property
    def plan(self) -> Any:
        return self.step  # .q and .force, as a Plan has them


class Pending(NamedTuple):
    """A converged solve waiting for publication: when, from which waypoint, for which mass."""

    ready_t: float
    start: int
    mass: float
    result: ReplanResult


@dataclass
class MpcLoop(PayloadLoop):
    """The after-step hook of an MPC run (see the module docstring)."""

    options: MpcOptions = field(default_factory=MpcOptions)
    log: list[dict[str, Any]] = field(default_factory=list)

    def __post_init__(self) -> None:
        super().__post_init__()
        self.every = int(round(1.0 / (self.options.rate_hz * self.sim.timestep)))
        if self.every < 1:
            raise InvalidInputError(f"rate_hz: expected at most the control rate {1 / self.sim.timestep:g} Hz, "
                                    f"got {self.options.rate_hz}")
        task = self.replanner.task
        self.plan_d = evaluate(task.robot, self.plan_q, task.t, self.replanner.force,
                               task.settings.capability_params)["d"]
        self.horizon = 0  # the planner's first waypoint on the task's grid
        self.published = (0, float(task.payload.mass or 0.0))  # first waypoint and mass of the plan in force
        self.mass = self.published[1]  # the newest estimate
        self.queued = list(self.options.estimates)
        self.arrived: list[dict[str, float]] = []
        self.pending: Pending | None = None
        self.failed: tuple[int, float] | None = None  # waypoint and mass of the last failed solve
        self.busy_ticks = 0
        self.rti = RealTimeIteration(self.replanner) if self.options.solver == "rti" else None
        self.rti_mass, self.rti_converged = self.published[1], True

    def __call__(self, k: int, q: FloatArray, dq: FloatArray) -> None:
        """After step ``k`` (state ``q, dq`` before it): identify, maybe add mass, tick."""
        t = k * self.sim.timestep
        if self.options.identify:
            self.mass = self._identify(k, q, dq)
        elif k % 100 == 0:
            self.estimates.append((t, self.mass, None))  # the newest asynchronous estimate
        self._maybe_add_mass(t, self.options.add_mass)
        if k % self.every == 0:
            self._tick(k, t, q, dq)

    # -- one tick -----------------------------------------------------------------------
    def _tick(self, k: int, t: float, q: FloatArray, dq: FloatArray) -> None:
        self._receive(t)
        entry: dict[str, Any] = {"t": t, "mass": self.mass, "kind": None, "solve_s": None, "missed": False,
                                 "published": False}
        if self.pending is not None and t >= self.pending.ready_t - TIME_EPS:
            entry["published"] = self._publish(k, self.pending, entry)
            self.pending = None
        if self.pending is not None:
            self.busy_ticks += 1
        else:
            self._maybe_solve(k, t, q, dq, entry)
        entry["planned_mass"] = self.published[1]
        entry["min_d"] = self._remaining_min_d(t)
        self.log.append(entry)

    def _receive(self, t: float) -> None:
        """Apply the asynchronous estimates that have arrived by ``t`` (the newest wins)."""
        arrived = []
        while self.queued and self.queued[0][0] <= t + TIME_EPS:
            arrived.append(self.queued.pop(0))
        polled = self.options.source(t) if self.options.source is not None else None
        if polled is not None:
            arrived.append((t, float(polled)))
        for due, kg in arrived:
            if not (is_finite_number(kg) and kg > 0):
                raise InvalidInputError(f"source: expected a payload mass > 0 kg, got {kg!r} at t = {t:.3f} s")
            self.arrived.append({"t": due, "mass": kg, "applied_t": t})
        if arrived:
            self.mass = arrived[-1][1]
            self.identifier.mass = self.mass + self.tool_mass  # identification goes on from it

    def _maybe_solve(self, k: int, t: float, q: FloatArray, dq: FloatArray, entry: dict[str, Any]) -> None:
        i = int(np.searchsorted(self.plan_t, t + TIME_EPS, side="right")) - 1  # the waypoint just passed
        if i >= self.plan_t.size - 1 or self.stopped_at is not None:
            return  # the motion is over (or stopped): nothing left to solve
        target = self._target_mass()
        if i > self.horizon:
            kind, steps = "shift", i - self.horizon
        elif (self.horizon, target) != self.published or (self.rti is not None and not self.rti_converged):
            kind, steps = "resolve", 0  # (real-time iterations: also until the iterate has converged)
        else:
            return
        state = (q, *self._start_motion(i, q, dq)) if kind == "shift" else None
        if self.rti is not None:
            return self._rti_tick(k, t, state, kind, steps, target, entry)
        if self.failed is not None and self.failed[0] == i and not self._departs(target, self.failed[1]):
            return  # failed at this waypoint for this mass already: the plan in force stays until the next
        result = self._solve_tick(kind, steps, state, target)
        # a rule other than "splice" publishes after the verdict: its time counts then
        ready = result.latency_s + (result.verdict_s if self.options.on_infeasible != "splice" else 0.0)
        missed = ready > self.options.deadline
        entry.update(kind=kind, solve_s=result.latency_s, iterations=result.iterations, missed=missed,
                     solved=result.plan.solved, verdict=result.plan.label)
        if not result.plan.solved:
            self.failed = (i, target)
            return
        self.horizon += steps
        entry.update(failed=list(result.plan.verdict.failed), verdict_s=result.verdict_s)
        done = Pending(t + ready, self.horizon, target, result)
        if not missed:
            entry["published"] = self._publish(k, done, entry)
        elif self.options.on_miss == "delay":
            self.pending = done

    def _start_motion(self, j: int, q: FloatArray, dq: FloatArray) -> tuple[FloatArray, FloatArray | None]:
        """Velocity and acceleration of a horizon shifted to waypoint ``j`` of the grid, starting at
        the measured ``q`` (:class:`MpcOptions`' ``start``)."""
        if self.options.start == "measured":
            return dq, None
        if self.options.start == "rest":
            return np.zeros_like(dq), np.zeros_like(dq)
        # the waypoints the reference passes through up to the splice (the task's plan starts at rest)
        motion = motion_at(np.vstack([self.plan_q[:j], q]), self.plan_t, j)
        return motion.velocity, motion.acceleration

    def _rti_tick(self, k: int, t: float, state: tuple[FloatArray, FloatArray, FloatArray | None] | None,
                  kind: str, steps: int, target: float, entry: dict[str, Any]) -> None:
        """One real-time iteration: the problem moves on (horizon, mass) whether or not the step is
        sound; a sound step within its deadline is published (a late one as ``on_miss`` says)."""
        q_now, v_now, a_now = state if state is not None else (None, None, None)
        step = self.rti.step(mass=None if target == self.rti_mass else target, steps=steps, q_now=q_now,
                             v_now=v_now, a_now=a_now)
        self.horizon += steps
        self.rti_mass, self.rti_converged = target, step.converged
        missed = step.latency_s > self.options.deadline
        entry.update(kind=kind, solve_s=step.latency_s, iterations=0 if step.converged else 1, missed=missed,
                     solved=step.published, verdict="real-time iteration", reason=step.reason or None,
                     kkt_error=step.kkt_error)
        if not step.published:
            return  # unsound (or failed): the plan in force stays, the next tick steps again
        done = Pending(t + step.latency_s, self.horizon, target, _RealTimePlan(step))
        if not missed:
            entry["published"] = self._publish(k, done, entry)
        elif self.options.on_miss == "delay":
            self.pending = done

    def _solve_tick(self, kind: str, steps: int, state: tuple[FloatArray, FloatArray, FloatArray | None] | None,
                    mass: float) -> ReplanResult:
        """The one solver call of a tick: ``"shift"`` the horizon ``steps`` waypoints forward from
        ``state`` (the measured configuration, its velocity and acceleration: :meth:`_start_motion`),
        or ``"resolve"`` the current horizon, for payload ``mass``. A converged result moves the
        planner's warm start (published or not)."""
        if kind == "shift":
            q_now, v_now, a_now = state
            return self.replanner.shift(steps, q_now=q_now, mass=mass, v_now=v_now, a_now=a_now)
        return self.replanner.replan(mass=mass)

    def _target_mass(self) -> float:
        """The mass to solve for: the newest estimate when it departs from the plan in force's."""
        m = max(self.mass, MIN_PAYLOAD)  # a transient estimate below zero means "(almost) nothing"
        return m if self._departs(m, self.published[1]) else self.published[1]

    def _departs(self, m: float, ref: float) -> bool:
        """``m`` differs from ``ref`` by ``max(threshold ref, 3 sigma, min_change)`` or more."""
        sigma = self.identifier.sigma if self.options.identify else 0.0
        return abs(m - ref) >= max(self.options.threshold * ref, 3 * sigma, self.options.min_change)

    def _publish(self, k: int, done: Pending, entry: dict[str, Any]) -> bool:
        """Splice a converged solve (or a sound real-time step) into the reference after step ``k``;
        a converged solve that is not feasible as ``on_infeasible`` says (``entry["applied"]``)."""
        plan = done.result.plan
        if isinstance(done.result, _RealTimePlan):
            self._splice(k, done.start, plan.q, plan.force.f)
            applied = "spliced"
        else:
            applied = self._apply(k, done.start, plan, self.options.on_infeasible)
        entry["applied"] = applied
        if applied == "kept":  # not solved again at this waypoint for this mass
            self.failed = (done.start, done.mass)
            return False
        if applied == "spliced":
            self.plan_d = self._executed_margin(done.start, plan)
        self.published = (done.start, done.mass)
        return True

    def _executed_margin(self, start: int, plan: Any) -> FloatArray:
        """The margins of the waypoints in force (after a splice from ``start``): the past ones as they
        were, the new plan's evaluated after the waypoints before it (the sequence the reference
        follows; the shifted plan's own metrics start from ``MpcOptions.start``'s motion, with the
        default the same)."""
        m = self.plan_t.size - start
        f = np.concatenate([np.repeat(plan.force.f[:1], start, axis=0), plan.force.f[:m]])
        r = np.concatenate([np.repeat(plan.force.r[:1], start), plan.force.r[:m]])
        task = self.replanner.task
        d = evaluate(task.robot, self.plan_q, self.plan_t, TaskForce(self.plan_t, f, r),
                     task.settings.capability_params)["d"]
        return np.concatenate([self.plan_d[:start], d[start:]])

    def _remaining_min_d(self, t: float) -> float:
        """The smallest margin of the plan in force over its waypoints after ``t`` (the last one at the end)."""
        i = min(int(np.searchsorted(self.plan_t, t + TIME_EPS, side="right")), self.plan_t.size - 1)
        return float(np.min(self.plan_d[i:]))

    # -- report -------------------------------------------------------------------------
    def summary(self) -> dict[str, Any]:
        """Tick, solve, miss and failure counts, solve-time statistics, the per-tick log."""
        solves = [e for e in self.log if e["kind"] is not None]
        times = np.array([e["solve_s"] for e in solves])
        stat = (lambda f: float(f(times))) if times.size else (lambda f: None)
        return {
            "rate_hz": self.options.rate_hz, "tick_period_s": self.every * self.sim.timestep,
            "solver": self.options.solver, "backend": "stagewise" if self.rti is not None else self.options.backend,
            "start": self.options.start,
            "deadline_s": self.options.deadline, "on_miss": self.options.on_miss,
            "identify": self.options.identify, "ticks": len(self.log), "solves": len(solves),
            "published": sum(e["published"] for e in self.log), "misses": sum(e["missed"] for e in solves),
            "on_infeasible": self.options.on_infeasible, "stopped_at_waypoint": self.stopped_at,
            "kept": sum(e.get("applied") == "kept" for e in self.log),
            "failed": sum(not e["solved"] for e in solves), "busy_ticks": self.busy_ticks,
            "solve_median_s": stat(np.median), "solve_p95_s": stat(lambda x: np.percentile(x, 95)),
            "solve_max_s": stat(np.max), "min_d": min((e["min_d"] for e in self.log), default=None),
            "async_estimates": self.arrived, "log": self.log, **self._estimate_summary(),
        }


def make_mpc_loop(plan_dir: Path, plan: Any, sim: SimModel, reference: Reference, options: MpcOptions) -> MpcLoop:
    """An :class:`MpcLoop` for the plan in ``plan_dir`` (its method, its task)."""
    backend = "stagewise" if options.solver == "rti" else options.backend
    return MpcLoop(sim, reference, replanner_of_plan(plan_dir, plan, backend), options)


__all__ = ["MPC_SOLVERS", "ON_MISS", "START_MOTIONS", "TIME_EPS", "MpcLoop", "MpcOptions", "Pending", "make_mpc_loop"]
