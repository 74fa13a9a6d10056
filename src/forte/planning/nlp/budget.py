"""The budget of a plan's NLP solves: :data:`~forte.settings.PLAN_SOLVE_CPU_S` of CPU time and
:data:`~forte.settings.PLAN_SOLVE_WALL_S` of wall-clock time.

:func:`solve_budget` opens a budget (process CPU time, :func:`time.process_time`, and wall time,
:func:`time.monotonic`); every IPOPT problem built while it is open gets ``max_cpu_time`` and
``max_wall_time`` = what is left of each when the problem is built (:func:`time_left`, at least
:data:`MIN_SOLVE_CPU_S`), so the solves of a plan (its
first solve, the clearance and self-collision re-solves, the refinement rounds, each building its
own problem right before solving it) take the budget in all, plus at most
:data:`MIN_SOLVE_CPU_S` for each solve started after it is spent (which then stops at its first
iterations: IPOPT's ``Maximum_CpuTime_Exceeded``, and the round that asked for it keeps the plan it
had). A budget opened inside an open one is the outer one: a plan's rounds share the plan's.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from typing import Any

from forte.settings import PLAN_SOLVE_CPU_S, PLAN_SOLVE_WALL_S, WALL_PER_CPU

#: The process and monotonic times at which the open budget ends (``None``: none open).
_END: ContextVar[tuple[float, float] | None] = ContextVar("forte_solve_budget_end", default=None)
#: The least CPU time (s) a problem built after the budget is spent is given.
MIN_SOLVE_CPU_S = 1.0


@contextmanager
def solve_budget(seconds: float = PLAN_SOLVE_CPU_S, wall: float = PLAN_SOLVE_WALL_S) -> Iterator[None]:
    """Bound the NLP solves inside to ``seconds`` of CPU time and ``wall`` seconds of wall time in
    all (kept when one is open)."""
    ends = (time.process_time() + seconds, time.monotonic() + wall)
    token = _END.set(ends) if _END.get() is None else None
    try:
        yield
    finally:
        if token is not None:
            _END.reset(token)


def budget_of(options: Any) -> tuple[float, float]:
    """The CPU and wall seconds of a plan with solver ``options`` (``time_budget_s``, else
    :data:`~forte.settings.PLAN_SOLVE_CPU_S`; the wall bound :data:`~forte.settings.WALL_PER_CPU` times it)."""
    cpu = float(options.time_budget_s or PLAN_SOLVE_CPU_S)
    return cpu, cpu * WALL_PER_CPU


def time_left() -> tuple[float, float] | None:
    """What is left of the open budget, CPU and wall (s, each at least :data:`MIN_SOLVE_CPU_S`),
    ``None`` when none is open."""
    ends = _END.get()
    if ends is None:
        return None
    return max(ends[0] - time.process_time(), MIN_SOLVE_CPU_S), max(ends[1] - time.monotonic(), MIN_SOLVE_CPU_S)


def ipopt_budget() -> dict[str, float]:
    """IPOPT's options for what is left of the open budget (none when none is open)."""
    left = time_left()
    return {} if left is None else {"ipopt.max_cpu_time": left[0], "ipopt.max_wall_time": left[1]}
