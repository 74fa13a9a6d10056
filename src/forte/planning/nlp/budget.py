"""The budget of a plan's work: :data:`~forte.settings.PLAN_SOLVE_CPU_S` of CPU time and
:data:`~forte.settings.PLAN_SOLVE_WALL_S` of wall-clock time (``solver.time_budget_s``, wall
:data:`~forte.settings.WALL_PER_CPU` times it).

:func:`solve_budget` opens a :class:`Budget` (process CPU time, :func:`time.process_time`, user
and system, and wall time, :func:`time.monotonic`) that everything inside spends from: the initial
guess (IK along the path: seconds on a raw URDF), the problems' builds, IPOPT, the verdicts, the
rows' setup. Two rules make it hold for the whole plan:

- every IPOPT problem built while it is open gets ``max_cpu_time`` and ``max_wall_time`` = what is
  left of each when the problem is built (:func:`time_left`: the time already spent outside IPOPT
  counted, at least :data:`MIN_SOLVE_CPU_S`);
- no new work starts once less than :data:`MIN_SOLVE_CPU_S` is left: a re-solve, a refinement or
  slower round, another clearance round or another start asks :func:`spent_before` first, which
  records what it skipped, and the plan keeps what it has.

What runs past the budget: the rest of the IPOPT iteration under way when it ends (IPOPT checks
its limits between iterations; an iteration is milliseconds on an ordinary problem, but one of the
raw TIAGo's self-collision re-solve, started from a problem IPOPT had already found infeasible,
took 82-94 s of CPU: that re-solve is no longer started, see
:func:`~forte.planning.rounds.apart`), :data:`MIN_SOLVE_CPU_S` for a solve started with less left,
the initial guess's IK (not interruptible: ~7 s on the raw TIAGo), and the plan's closing work: the verdict of the plan
kept and the metrics (0.2 s and 0.01 s of CPU on a 41-sample TIAGo plan); a goal task's route
judged as the plan, on more waypoints and slower (verdicts, no solve: up to 4, and 3 x 4 more,
:func:`~forte.planning.rounds.slower_route`), which keeps a feasible plan when its NLP runs
out. IPOPT's own clock counts user time only (a few % less than process time).
:meth:`Budget.record` is the plan's ``solver.budget``: used against the budget, and what was not
started. A budget opened inside an open one is the outer one: a plan's rounds share
the plan's.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from typing import Any

from forte.settings import PLAN_SOLVE_CPU_S, PLAN_SOLVE_WALL_S, WALL_PER_CPU

#: The least CPU time (s) a problem built after the budget is spent is given.
MIN_SOLVE_CPU_S = 1.0


class Budget:
    """``cpu_s`` seconds of process CPU time and ``wall_s`` of wall time from when it is opened;
    what was skipped once it was spent, and the plan's work done once (:meth:`once`)."""

    def __init__(self, cpu_s: float, wall_s: float) -> None:
        self.cpu_s, self.wall_s = float(cpu_s), float(wall_s)
        self.cpu0, self.wall0 = time.process_time(), time.monotonic()
        self.skipped: list[str] = []
        self._once: dict[Any, tuple[Any, Any]] = {}

    def used(self) -> tuple[float, float]:
        """CPU and wall seconds spent since it was opened."""
        return time.process_time() - self.cpu0, time.monotonic() - self.wall0

    def left(self) -> tuple[float, float]:
        """CPU and wall seconds left (negative once overrun)."""
        cpu, wall = self.used()
        return self.cpu_s - cpu, self.wall_s - wall

    def spent(self) -> str | None:
        """``"cpu"`` or ``"wall"`` when less than :data:`MIN_SOLVE_CPU_S` is left of that part (a
        solve built then would get that least and overrun it), else ``None``."""
        cpu, wall = self.left()
        return "cpu" if cpu < MIN_SOLVE_CPU_S else "wall" if wall < MIN_SOLVE_CPU_S else None

    def once(self, key: Any, owner: Any, make: Callable[[], Any]) -> Any:
        """``make()`` the first time for ``(key, owner)`` (``owner`` compared by identity, kept
        alive), its result after: what a plan's re-solves would otherwise redo (its initial guess)."""
        found = self._once.get((key, id(owner)))
        if found is None or found[0] is not owner:
            found = self._once[(key, id(owner))] = (owner, make())
        return found[1]

    def record(self) -> dict[str, Any]:
        """The facts of a plan's ``solver.budget``: the budget, what was used (s), whether it ran
        out (``spent``: ``cpu``, ``wall`` or ``None``) and by how much it was overrun, what was
        skipped for it."""
        cpu, wall = self.used()
        return {"cpu_s": self.cpu_s, "wall_s": self.wall_s, "cpu_used_s": round(cpu, 3),
                "wall_used_s": round(wall, 3), "spent": self.spent(),
                "cpu_over_s": round(max(cpu - self.cpu_s, 0.0), 3),
                "wall_over_s": round(max(wall - self.wall_s, 0.0), 3), "skipped": list(self.skipped)}


#: The open budget (``None``: none open).
_OPEN: ContextVar[Budget | None] = ContextVar("forte_solve_budget", default=None)


@contextmanager
def solve_budget(seconds: float = PLAN_SOLVE_CPU_S, wall: float = PLAN_SOLVE_WALL_S) -> Iterator[Budget]:
    """Bound the work inside to ``seconds`` of CPU time and ``wall`` seconds of wall time in all;
    yields the open budget (the outer one when one is open already)."""
    outer = _OPEN.get()
    if outer is not None:
        yield outer
        return
    token = _OPEN.set(budget := Budget(seconds, wall))
    try:
        yield budget
    finally:
        _OPEN.reset(token)


def open_budget() -> Budget | None:
    """The open budget, ``None`` when none is open."""
    return _OPEN.get()


def budget_of(options: Any) -> tuple[float, float]:
    """The CPU and wall seconds of a plan with solver ``options`` (``time_budget_s``, else
    :data:`~forte.settings.PLAN_SOLVE_CPU_S`; the wall bound :data:`~forte.settings.WALL_PER_CPU` times it)."""
    cpu = float(options.time_budget_s or PLAN_SOLVE_CPU_S)
    return cpu, cpu * WALL_PER_CPU


def time_left() -> tuple[float, float] | None:
    """What is left of the open budget, CPU and wall (s, each at least :data:`MIN_SOLVE_CPU_S`),
    ``None`` when none is open."""
    budget = _OPEN.get()
    if budget is None:
        return None
    cpu, wall = budget.left()
    return max(cpu, MIN_SOLVE_CPU_S), max(wall, MIN_SOLVE_CPU_S)


def spent_before(what: str) -> bool:
    """Whether the open budget is spent, so that ``what`` (e.g. ``"self-collision re-solve"``)
    does not start; recorded in the budget's ``skipped`` (``"<what>: not started"``) when so.
    ``False`` when none is open."""
    budget = _OPEN.get()
    if budget is None or budget.spent() is None:
        return False
    budget.skipped.append(f"{what}: not started")
    return True


def once(key: Any, owner: Any, make: Callable[[], Any]) -> Any:
    """:meth:`Budget.once` of the open budget; ``make()`` when none is open."""
    budget = _OPEN.get()
    return make() if budget is None else budget.once(key, owner, make)


def ipopt_budget() -> dict[str, float]:
    """IPOPT's options for what is left of the open budget (none when none is open)."""
    left = time_left()
    return {} if left is None else {"ipopt.max_cpu_time": left[0], "ipopt.max_wall_time": left[1]}
