"""Running a sweep: skip the finished cells, compute the others in parallel, rebuild the table.

:func:`run_sweep` is what ``forte sweep`` calls. The driver alone writes to the output
directory (:class:`~forte.experiments.sweep.store.SweepDir`); workers only return results, so a
sweep runs the same on a local pool and on a Ray cluster whose nodes share no file system.
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, NamedTuple

from forte import progress
from forte.exceptions import ForteError
from forte.experiments.sweep.cell import CellResult
from forte.experiments.sweep.executors import Execute, backend, default_workers
from forte.experiments.sweep.figures import write_figures
from forte.experiments.sweep.spec import Cell, PlanGroup, SweepSpec, plan_groups, read_sweep
from forte.experiments.sweep.stops import held_stops
from forte.experiments.sweep.store import SweepDir
from forte.experiments.sweep.table import write_table
from forte.io.outputs import output_lock
from forte.io.records import package_versions

Log = Callable[[str], None]


def quiet(_: str) -> None:
    """Default logger: say nothing."""


class SweepResult(NamedTuple):
    """What a call of :func:`run_sweep` did."""

    out: Path
    cells: int  # in the grid
    finished: int  # with a result now
    computed: int  # by this call
    skipped: int  # finished by earlier runs
    errors: int  # rows with a plan or simulation error
    status: str  # "complete" or "partial"
    files: tuple[str, ...]  # table and figure files, relative to ``out``


def default_out(spec: SweepSpec) -> Path:
    """``runs/sweeps/NAME``."""
    return Path("runs") / "sweeps" / spec.name


def pending_groups(groups: list[PlanGroup], finished: set[str]) -> list[PlanGroup]:
    """The groups with unfinished cells, each reduced to those cells (a plan is redone if any is missing)."""
    out = []
    for g in groups:
        cells = tuple(c for c in g.cells if c.id not in finished)
        if cells:
            out.append(g._replace(cells=cells))
    return out


class _Counter:
    """Counts, elapsed time and ETA for the progress line."""

    def __init__(self, total: int, skipped: int, log: Log) -> None:
        self.total, self.done, self.computed, self.log = total, skipped, 0, log
        self.start = time.perf_counter()

    def stored(self) -> None:
        """One more cell stored (for the progress line; the records count the cell files)."""
        self.done += 1
        self.computed += 1

    def line(self, group: PlanGroup, results: list[CellResult]) -> str:
        elapsed = time.perf_counter() - self.start
        eta = elapsed / self.computed * (self.total - self.done)
        row = results[0].row
        mass = "" if group.mass is None else f" {group.mass:g} kg"
        sims = [r.row.get("sim_verdict") for r in results if r.row.get("sim_verdict")]
        sim = f"; runs {sum(v == 'success' for v in sims)}/{len(sims)} ok" if sims else ""
        return (f"[{self.done}/{self.total}] {group.cells[0].task} {group.method}{mass}: plan "
                f"{row.get('plan_status')}{sim} (elapsed {elapsed:.0f} s, about {eta:.0f} s left)")


def run_sweep(sweep: str | Path | SweepSpec, out: str | Path | None = None, workers: int | None = None,
              ray: str | None = None, figures: bool = True, log: Log = quiet) -> SweepResult:
    """Run (or resume) the sweep ``sweep`` into ``out`` (default :func:`default_out`).

    Args:
        sweep: a sweep file (:func:`~forte.experiments.sweep.spec.read_sweep`) or its spec.
        out: the output directory: new, empty, or a sweep directory (its finished cells are kept).
        workers: parallel workers (default: the CPUs this process may use); with ``ray`` the
            CPUs of a local Ray instance.
        ray: ``None``: a local process pool; ``"local"``: a local Ray instance (one started by
            the caller with ``ray.init`` is used as it is); else the address of a Ray cluster.
        figures: draw the summary figures.
        log: called with one line per finished plan.

    Errors (one line, before the output directory is touched):
    :class:`~forte.exceptions.TaskFileError` for a bad sweep or task file,
    :class:`~forte.exceptions.OutputError` for an output directory forte may not use or one
    another process is writing, :class:`~forte.exceptions.InvalidInputError` for Ray missing or
    unreachable. While it runs: :class:`~forte.exceptions.ForteError` when a worker process dies
    (the finished cells are kept, the table is rebuilt from them; call again to resume).
    """
    spec = sweep if isinstance(sweep, SweepSpec) else read_sweep(sweep)
    groups = plan_groups(spec)
    cells = [c for g in groups for c in g.cells]
    store = SweepDir(default_out(spec) if out is None else out)
    store.check()
    workers = workers or default_workers()
    with output_lock(store.out, timeout=0):
        store.check()
        finished = set(store.finished(cells))
        todo = pending_groups(groups, finished)
        # start the pool or connect to Ray (or fail: one line) before the directory is created
        with backend(ray, workers) if todo else contextlib.nullcontext(None) as execute:
            run = _Run(store, spec, cells, figures, log)
            return run.compute(todo, len(finished), execute,
                               {"backend": "pool" if ray is None else f"ray:{ray}", "workers": workers,
                                "versions": package_versions()})


class _Run:
    """One run of a sweep in its (locked) directory, which it opens."""

    def __init__(self, store: SweepDir, spec: SweepSpec, cells: list[Cell], figures: bool, log: Log) -> None:
        self.store, self.spec, self.cells, self.figures, self.log = store, spec, cells, figures, log

    def compute(self, todo: list[PlanGroup], skipped: int, execute: Execute | None,
                facts: dict[str, Any]) -> SweepResult:
        """Open the directory and compute ``todo``, storing each cell as it finishes; once opened,
        the table is rebuilt however it ends. A stop (Ctrl-C, SIGTERM) is held while a record is
        written (:func:`~forte.experiments.sweep.stops.held_stops`): it lands between records."""
        store, total = self.store, len(self.cells)
        run, status, error = None, "failed", None
        try:
            with held_stops():  # the marker and the start event; the finally below writes the end
                run = self.start(todo, skipped, facts)
            counter = _Counter(total, skipped, self.log)
            with progress.step(f"sweep {self.spec.name}: {total - skipped} cells to compute"):
                index = {c.id: (c, g) for g in todo for c in g.cells}
                for results in execute(todo) if execute is not None else ():
                    with held_stops():  # a group that reached the driver is stored whole: files, log, count
                        for r in results:
                            store.write_cell(index[r.cell_id][0], r, run)
                            counter.stored()
                    line = counter.line(index[results[0].cell_id][1], results)
                    progress.update(line)
                    self.log(line)
            status = "done"
        except KeyboardInterrupt:
            status = "interrupted"
            raise
        except ForteError as exc:  # a worker died
            error = str(exc)
            raise
        finally:
            if run is not None:  # opened (an error opening it leaves no run to end)
                with held_stops():  # a second stop waits for the final records: table, marker, end event
                    result = self.finish(skipped)
                    store.log({"event": "end", "run": run, "status": result.status if status == "done"
                               else status, "computed": result.computed} | ({"error": error} if error else {}))
        return result

    def start(self, todo: list[PlanGroup], skipped: int, facts: dict[str, Any]) -> int:
        """Create (or re-open) and mark the directory, log the start; returns the run's number."""
        total = len(self.cells)
        self.store.open(self.spec, total)
        run = self.store.next_run()
        self.store.log({"event": "start", "run": run, **facts, "cells": total, "finished_before": skipped,
                        "to_compute": sum(len(g.cells) for g in todo)})
        if skipped:
            self.log(f"{self.spec.name}: {skipped} of {total} cells finished earlier, skipped")
        return run

    def finish(self, skipped: int) -> SweepResult:
        """Rebuild the table (and figures) from the cell files; mark the directory complete or partial.

        Every count comes from this one read of the cell files (the run holds the directory's lock
        and writes only cells not finished before it, so ``computed`` is the rows less ``skipped``).
        A cell whose result reached the driver before a stop is kept and counted everywhere: it is
        a valid result that a resume would only recompute; results still in workers are dropped
        everywhere (workers write nothing, the backend stops them).
        """
        rows_by_id = self.store.finished(self.cells)
        rows = [rows_by_id[c.id] for c in self.cells if c.id in rows_by_id]
        files = write_table(rows, self.store.out)
        if self.figures and rows:
            files += write_figures(rows, self.store.out)
        status = "complete" if len(rows) == len(self.cells) else "partial"
        self.store.write_marker(self.spec, len(self.cells), len(rows), status, files)
        errors = sum(1 for r in rows if r["plan_status"] == "error" or r["sim_verdict"] == "error")
        return SweepResult(self.store.out, len(self.cells), len(rows), len(rows) - skipped, skipped, errors, status,
                           tuple(files))
