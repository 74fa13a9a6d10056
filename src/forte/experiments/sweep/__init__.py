"""Sweeps: a grid of tasks x waypoints x methods x payload masses x simulated runs, run in parallel.

``forte sweep SWEEP.yaml`` (:func:`run_sweep`) computes every cell of the grid that a sweep
file describes (:mod:`.spec`) on a local process pool or a Ray cluster (:mod:`.executors`),
stores each finished cell as it completes and resumes where a killed run stopped
(:mod:`.store`; a Ctrl-C or SIGTERM waits for the record being written, :mod:`.stops`), and
writes one results table (:mod:`.table`) and summary figures (:mod:`.figures`). The worker
function is :func:`.cell.run_group`.
"""

from __future__ import annotations

from importlib import import_module
from typing import Any

__all__ = ["SweepResult", "SweepSpec", "read_sweep", "run_sweep"]

_NAMES = {"run_sweep": "run", "SweepResult": "run", "read_sweep": "spec", "SweepSpec": "spec"}


def __getattr__(name: str) -> Any:
    if name in _NAMES:
        return getattr(import_module(f"{__name__}.{_NAMES[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
