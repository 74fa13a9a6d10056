"""The paper's experiments (Sections 5.2, 5.3 and 5.4), re-run on our model.

Each ``run_*`` function plans the task with every compared method, simulates the plans where it
applies, draws the paper's figures (png, pdf or svg) and writes ``summary.json`` and
``summary.md`` to its output directory: per-method tables, a "paper claim vs our result" table
with a cause for every claim that is not reproduced, and our own observations as notes. The
directory is built in a temporary sibling and renamed into place, so an interrupted run never
leaves a half-written result.

* :func:`run_continuous` (:mod:`.continuous`): Section 5.2, a time-varying task force.
* :func:`run_lift` (:mod:`.lift`): Section 5.3, lifting 0.33 L and 2.7 L payloads.
* :func:`run_hold` (:mod:`.hold`): Section 5.4, holding one pose with both payloads.
* :func:`run_replan` (:mod:`.replan`) and :func:`run_mpc` (:mod:`.mpc`): the paper's future work,
  online re-planning at 10 Hz and forte as a 100 Hz model-predictive controller.
* :func:`run_wrench` (:mod:`.wrench`): beyond the paper (issue 25), offset payloads planned on
  the wrench against the force-only metric and the baselines, with the tip-over margin.
* :func:`run_contact` (:mod:`.contact`): beyond the paper (issue 25), the contact-rich tasks (push a
  box, open a drawer, carry with a partner) planned by forte and the baselines, run with the contact.
* :func:`run_base` (:mod:`.base`): beyond the paper (issue 39), the verdict's tip-over requirement
  against MuJoCo's base on the floor, light and heavy bases, with and without the tip-over term.
* :func:`run_sweep` (:mod:`.sweep`): any grid of tasks x methods x masses x simulated trials, on
  a process pool or Ray, resumable (``forte sweep``).

Planning is deterministic, so "trials" repeat only what is random: the simulated execution with a
payload mass off by a seeded, uniformly drawn error of up to +-10 % (lift, hold), and, for the
continuous task whose force is given directly, the planning itself. How a claim is judged (every
trial must agree, paper claims only, a cause for each miss) is documented in :mod:`.common`.

The runners are imported lazily: ``import forte.experiments`` does not load the planner or MuJoCo.
"""

from __future__ import annotations

from importlib import import_module
from typing import Any

__all__ = ["run_base", "run_contact", "run_continuous", "run_hold", "run_lift", "run_mpc", "run_replan", "run_sweep",
           "run_wrench"]

_RUNNERS = {"run_base": "base", "run_continuous": "continuous", "run_lift": "lift", "run_hold": "hold",
            "run_replan": "replan", "run_mpc": "mpc", "run_sweep": "sweep", "run_wrench": "wrench",
            "run_contact": "contact"}


def __getattr__(name: str) -> Any:
    if name in _RUNNERS:
        return getattr(import_module(f"{__name__}.{_RUNNERS[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
