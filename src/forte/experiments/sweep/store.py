"""A sweep's output directory: created and marked by forte, appended to by every resumed run.

Layout of ``OUT``::

    sweep.json          marker (generator: forte, kind: sweep), the spec, counts and status
    sweep.log           one JSON line per event: a run starts, a cell finishes, a run ends
    cells/ID.json       one file per finished cell: its key, its row and its timing
    results.csv         the table (canonical), rebuilt from cells/ at the end of every run
    results.parquet     the same table (when pyarrow is installed)
    figures/*.png       summary figures

A cell file is written through a temporary file and a rename when the cell finishes, so a kill
loses at most the cells that were running. On the next run a cell counts as finished when its
file parses, is forte's, and its stored key hashes to its id; every other cell is computed.
Only a new path, an empty directory or a directory holding ``sweep.json`` is accepted: never a
directory forte did not create, nor another kind of forte output. A new directory gets its
``sweep.json`` (written through a temporary file and a rename) before anything else, so a kill
while it is being created leaves it empty or marked. A directory holding nothing but an empty
``cells/`` (what earlier versions, which made it first, could leave) and temporary files of
``sweep.json`` is a start killed before its marker: it is accepted too.
"""

from __future__ import annotations

import json
import os
import re
import time
from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from forte.exceptions import OutputError
from forte.experiments.sweep.spec import CELL_FORMAT, Cell, SweepSpec, cell_id
from forte.experiments.sweep.table import NAMES, normalize
from forte.io.outputs import GENERATOR, MAX_JSON_BYTES, atomic_write, check_output
from forte.io.records import jsonable, package_versions

if TYPE_CHECKING:
    from forte.experiments.sweep.cell import CellResult

SWEEP_FILE, LOG_FILE, CELLS_DIR = "sweep.json", "sweep.log", "cells"
KIND = "sweep"
_LEFTOVER = re.compile(r"^\.[0-9a-f]{16}\.json\..+\.tmp$")  # atomic_write's temporary files
_MARKER_LEFTOVER = re.compile(r"^\.sweep\.json\..+\.tmp$")


def _read_json(path: Path) -> Any:
    try:
        if path.stat().st_size > MAX_JSON_BYTES:
            return None
        return json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError, RecursionError):
        return None


def is_sweep_dir(path: Path) -> bool:
    """True when ``path`` holds forte's ``sweep.json``."""
    doc = _read_json(Path(path) / SWEEP_FILE)
    return isinstance(doc, dict) and doc.get("generator") == GENERATOR and doc.get("kind") == KIND


class SweepDir:
    """The output directory of a sweep (see the module docstring)."""

    def __init__(self, out: str | Path, option: str = "--out") -> None:
        self.out, self.option = Path(out), option
        self.cells = self.out / CELLS_DIR

    def _killed_at_start(self) -> bool:
        """True for a directory holding only what a sweep killed before its marker leaves (see the module docstring)."""
        try:
            if self.out.is_symlink() or not self.out.is_dir():
                return False
            entries = list(self.out.iterdir())
            return bool(entries) and all(
                (p.name == CELLS_DIR and not p.is_symlink() and p.is_dir() and not any(p.iterdir()))
                or (_MARKER_LEFTOVER.match(p.name) is not None and not p.is_symlink() and p.is_file())
                for p in entries)
        except OSError:
            return False

    def check(self) -> None:
        """Refuse a path that is not new, empty or a sweep directory (:class:`OutputError`, one line)."""
        if self._killed_at_start():
            if not os.access(self.out, os.W_OK | os.X_OK):
                raise OutputError(f"{self.option} {self.out}: is not a writable directory")
            return
        check_output(self.out, self.option)
        if self.out.is_dir() and any(self.out.iterdir()) and not is_sweep_dir(self.out):
            raise OutputError(f"{self.option} {self.out}: holds files that are not a forte sweep (no forte "
                              f"{SWEEP_FILE}); choose a new directory for the sweep")

    def open(self, spec: SweepSpec, total: int) -> None:
        """Create (or re-open) the directory and mark it; call with the output lock held.

        The marker comes first (a kill leaves no unmarked directory with files in it), then ``cells/``.
        """
        try:
            self.out.mkdir(parents=True, exist_ok=True)
            self.write_marker(spec, total, finished=0, status="running")
            self.cells.mkdir(exist_ok=True)
            for folder, pattern in ((self.cells, _LEFTOVER), (self.out, _MARKER_LEFTOVER)):
                for leftover in folder.iterdir():  # temporary files of a killed writer
                    if pattern.match(leftover.name) and leftover.is_file() and not leftover.is_symlink():
                        leftover.unlink(missing_ok=True)
        except OSError as exc:
            raise OutputError(f"{self.option} {self.out}: cannot write there ({exc.strerror or exc})") from None

    def write_marker(self, spec: SweepSpec, total: int, finished: int, status: str,
                     files: Iterable[str] = ()) -> None:
        doc = {"generator": GENERATOR, "kind": KIND, "format_version": CELL_FORMAT, "name": spec.name,
               "spec": spec.describe(), "cells": total, "finished": finished, "status": status,
               "files": list(files), "updated": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "versions": package_versions()}
        atomic_write(self.out / SWEEP_FILE, json.dumps(jsonable(doc), indent=1) + "\n")

    # -- cells ----------------------------------------------------------------------------------
    def cell_path(self, cid: str) -> Path:
        return self.cells / f"{cid}.json"

    def read_cell(self, cell: Cell) -> dict[str, Any] | None:
        """The stored row of ``cell``, or None when its file is missing or not a valid result of it."""
        doc = _read_json(self.cell_path(cell.id))
        if not (isinstance(doc, dict) and doc.get("generator") == GENERATOR and doc.get("cell_id") == cell.id):
            return None
        key, row = doc.get("key"), doc.get("row")
        try:
            if cell_id(key) != cell.id or not isinstance(row, dict) or set(row) != set(NAMES):
                return None
        except (TypeError, ValueError):
            return None
        return row

    def finished(self, cells: Iterable[Cell]) -> dict[str, dict[str, Any]]:
        """Rows of the ``cells`` that have a valid result file, by cell id."""
        out = {}
        for cell in cells:
            row = self.read_cell(cell)
            if row is not None:
                out[cell.id] = row
        return out

    def write_cell(self, cell: Cell, result: CellResult, run: int) -> None:
        """Store a finished cell (atomically), then log it."""
        doc = {"generator": GENERATOR, "cell_id": cell.id, "key": cell.key, "row": normalize(result.row),
               "timing": result.timing, "run": run, "finished": time.strftime("%Y-%m-%dT%H:%M:%S%z")}
        atomic_write(self.cell_path(cell.id), json.dumps(jsonable(doc), indent=1) + "\n")
        self.log({"event": "cell", "run": run, "cell_id": cell.id})

    # -- the log ----------------------------------------------------------------------------------
    def log(self, event: dict[str, Any]) -> None:
        """Append one JSON line to ``sweep.log`` (one ``write`` on an ``O_APPEND`` file)."""
        line = json.dumps({"time": round(time.time(), 3), **event}) + "\n"
        fd = os.open(self.out / LOG_FILE, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o666)
        try:
            os.write(fd, line.encode())
        finally:
            os.close(fd)

    def events(self) -> list[dict[str, Any]]:
        """The events of ``sweep.log`` (a line cut by a kill is skipped)."""
        try:
            lines = (self.out / LOG_FILE).read_text(encoding="utf-8").splitlines()
        except OSError:
            return []
        out = []
        for line in lines:
            try:
                event = json.loads(line)
            except ValueError:
                continue
            if isinstance(event, dict):
                out.append(event)
        return out

    def next_run(self) -> int:
        """The number of the run about to start (1 for a new directory)."""
        return 1 + sum(1 for e in self.events() if e.get("event") == "start")
