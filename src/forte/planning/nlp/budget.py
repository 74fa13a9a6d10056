"""The CPU budget of a plan's NLP solves (:data:`~forte.settings.PLAN_SOLVE_CPU_S`).

:func:`solve_budget` opens a budget (process CPU time, :func:`time.process_time`); every IPOPT
problem built while it is open gets ``max_cpu_time`` = what is left of it when the problem is
built (:func:`cpu_time_left`, at least :data:`MIN_SOLVE_CPU_S`), so the solves of a plan (its
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

from forte.settings import PLAN_SOLVE_CPU_S

#: The process time at which the open budget ends (``None``: none open).
_END: ContextVar[float | None] = ContextVar("forte_solve_budget_end", default=None)
#: The least CPU time (s) a problem built after the budget is spent is given.
MIN_SOLVE_CPU_S = 1.0


@contextmanager
def solve_budget(seconds: float = PLAN_SOLVE_CPU_S) -> Iterator[None]:
    """Bound the NLP solves inside to ``seconds`` of CPU time in all (kept when one is open)."""
    token = _END.set(time.process_time() + seconds) if _END.get() is None else None
    try:
        yield
    finally:
        if token is not None:
            _END.reset(token)


def cpu_time_left() -> float | None:
    """What is left of the open budget (s, at least :data:`MIN_SOLVE_CPU_S`), ``None`` when none is open."""
    end = _END.get()
    return None if end is None else max(end - time.process_time(), MIN_SOLVE_CPU_S)
