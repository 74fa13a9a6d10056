"""The settings of the MPC loop (:mod:`forte.execution.mpc` says what each does): :class:`MpcOptions`,
checked when made (bad input: one :class:`~forte.exceptions.InvalidInputError` naming the field),
and the choices its fields take."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from forte.exceptions import InvalidInputError
from forte.execution.closed_loop import ON_INFEASIBLE, check_on_infeasible
from forte.settings import SOLVER_BACKENDS

#: What a tick's solve is: one real-time iteration, or a warm re-plan to convergence.
MPC_SOLVERS = ("rti", "converged")
#: How the loop treats a solve that overruns its deadline.
ON_MISS = ("drop", "delay")
#: The motion a shifted horizon starts with (:class:`MpcOptions`' ``start``).
START_MOTIONS = ("reference", "measured", "rest")


@dataclass(frozen=True)
class MpcOptions:
    """Settings of the MPC loop (see the module docstring).

    Attributes:
        rate_hz: tick rate (simulated time), at most the 1 kHz control rate.
        deadline_s: wall-clock budget of a tick's solve (default ``1 / rate_hz``).
        on_miss: ``"drop"`` a solve over its deadline, or publish it ``"delay"``-ed.
        identify: estimate the payload from the joint torques (else: only asynchronous estimates).
        threshold: relative mass change that makes the plan in force stale.
        min_change: absolute mass change (kg) below which it is not.
        add_mass: ``(t, kg)``: the payload gains ``kg`` at time ``t`` (s), or ``None``.
        estimates: asynchronous estimates ``(t, kg)``: ``kg`` arrives at simulated time ``t``.
        source: polled at every tick with the simulated time; returns a new estimate (kg) or ``None``.
        solver: ``"rti"`` (default): one real-time iteration of the stagewise solver per tick
            (:class:`~forte.planning.online.realtime.RealTimeIteration`), also between changes until it
            has converged; ``"converged"``: a warm re-plan to convergence with ``backend``.
        backend: the NLP solver of ``"converged"`` solves (``stagewise`` or ``ipopt``; ``"rti"``
            always uses ``stagewise``).
        start: the motion of a shifted horizon's first waypoint (the measured configuration):
            ``"reference"`` (default), the backward differences of the waypoints the controller's
            reference passes through (the plan in force's two before it, then the measured
            configuration), so the new plan's dynamics are those the spliced reference executes;
            ``"measured"``, the measured velocity (the plan's acceleration there); ``"rest"``, at
            rest (what a shift did before: the ablation).
        on_infeasible: a converged solve whose verdict (``forte plan``'s) is not feasible:
            ``"splice"`` it anyway (default, measured: :mod:`forte.execution.closed_loop`),
            ``"keep"`` the plan in force (not solved again before the next waypoint unless the
            mass departs), or ``"stop"`` at the next waypoint; these two wait for the verdict,
            whose time then counts against the deadline. Real-time iterations have no verdict (a
            step is published when sound: :mod:`forte.planning.online.realtime`).
    """

    rate_hz: float = 100.0
    deadline_s: float | None = None
    on_miss: str = "drop"
    identify: bool = True
    threshold: float = 0.1
    min_change: float = 0.05
    add_mass: tuple[float, float] | None = None
    estimates: tuple[tuple[float, float], ...] = ()
    source: Callable[[float], float | None] | None = None
    solver: str = "rti"
    backend: str = "stagewise"
    start: str = "reference"
    on_infeasible: str = ON_INFEASIBLE[0]

    def __post_init__(self) -> None:
        check_on_infeasible(self.on_infeasible)
        if self.start not in START_MOTIONS:
            raise InvalidInputError(f"start: expected one of {', '.join(START_MOTIONS)}, got {self.start!r}")
        if self.solver not in MPC_SOLVERS:
            raise InvalidInputError(f"solver: expected one of {', '.join(MPC_SOLVERS)}, got {self.solver!r}")
        if self.backend not in SOLVER_BACKENDS:
            raise InvalidInputError(f"backend: expected one of {', '.join(SOLVER_BACKENDS)}, got {self.backend!r}")
        if not (is_finite_number(self.rate_hz) and 0 < self.rate_hz <= 1000):
            raise InvalidInputError(f"rate_hz: expected a rate in (0, 1000] Hz (the control loop runs at 1 kHz), "
                                    f"got {self.rate_hz}")
        if self.deadline_s is not None and not (is_finite_number(self.deadline_s) and self.deadline_s > 0):
            raise InvalidInputError(f"deadline_s: expected a time > 0 s, got {self.deadline_s}")
        if self.on_miss not in ON_MISS:
            raise InvalidInputError(f"on_miss: expected one of {', '.join(ON_MISS)}, got {self.on_miss!r}")
        for name in ("threshold", "min_change"):
            if not (is_finite_number(getattr(self, name)) and getattr(self, name) >= 0):
                raise InvalidInputError(f"{name}: expected a number >= 0, got {getattr(self, name)}")
        if self.add_mass is not None and not _timed_mass(self.add_mass):
            raise InvalidInputError(f"add_mass: expected (t >= 0 s, kg > 0), got {self.add_mass}")
        for item in self.estimates:
            if not _timed_mass(item):
                raise InvalidInputError(f"estimates: expected (t >= 0 s, kg > 0) pairs, got {item!r}")
        if self.source is not None and not callable(self.source):
            raise InvalidInputError(f"source: expected a callable t -> kg or None, got {type(self.source).__name__}")
        object.__setattr__(self, "estimates", tuple(sorted((float(t), float(kg)) for t, kg in self.estimates)))

    @property
    def deadline(self) -> float:
        """The deadline in seconds."""
        return self.deadline_s if self.deadline_s is not None else 1.0 / self.rate_hz


def is_finite_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def _timed_mass(item: Any) -> bool:
    try:
        t, kg = item
    except (TypeError, ValueError):
        return False
    return is_finite_number(t) and is_finite_number(kg) and t >= 0 and kg > 0


__all__ = ["MPC_SOLVERS", "ON_MISS", "START_MOTIONS", "MpcOptions", "is_finite_number"]
