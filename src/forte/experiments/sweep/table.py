"""The results table of a sweep: its columns, and its CSV (canonical) and Parquet files.

One row per cell (one run of one plan), in grid order (tasks, waypoints, methods, masses, runs).
Every value is deterministic: timings and worker names are kept in the cell files
(``cells/ID.json``, field ``timing``), not here, so the same grid gives the same table on any
backend. Columns:

- ``cell_id``: the cell's stable id (:func:`forte.experiments.sweep.spec.cell_id`);
- ``task``, ``task_file``: the task's name and its file as written in the sweep file;
- ``waypoints``: number of waypoints of the plan; ``method``; ``mass_kg``: the planned payload
  mass (empty: a task with a force profile);
- ``run``: ``plan-only``, ``nominal``, ``mass-error`` or ``no-payload``; ``trial``: 0, or the
  mass-error trial 1..K; ``true_mass_kg``: the payload mass in the simulation;
- ``plan_status`` (the plan's verdict: ``feasible``, ``infeasible``, ``solver-failed``; or
  ``error``), ``verdict_failed`` (the failed requirements), ``solver_status``, and the plan's
  metrics (:func:`forte.experiments.common.metrics`): ``min_d``, ``min_capacity_margin``
  (min capacity − (\\|f\\| + r), N), ``min_capacity_minus_force``, ``mean_capacity``,
  ``min_capacity`` (N), ``mean_manipulability``, ``min_manipulability`` (m³),
  ``max_torque_ratio``, ``max_torque_ratio_with_force``, ``waypoints_with_d_negative``,
  ``first_time_below_force``, ``first_time_below_band`` (s; empty: never);
- ``sim_verdict`` (``success``, ``failure``, ``not simulated``, ``error``; empty for plan-only),
  ``sim_reason``, ``sim_failure_time_s``, ``sim_max_ee_error_m``, ``sim_max_torque_ratio``;
- ``error``: the one-line message of a plan or simulation that raised (bad task, infeasible
  pose), else empty.

CSV: floats written with ``repr`` (round-trip exact), empty for a missing value. Parquet (when
``pyarrow`` is installed): the same rows with typed columns.
"""

from __future__ import annotations

import csv
import io
import os
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from forte.io.outputs import atomic_write

#: (name, type) of every column, in order; types: "str", "int", "float".
COLUMNS: tuple[tuple[str, str], ...] = (
    ("cell_id", "str"), ("task", "str"), ("task_file", "str"), ("waypoints", "int"), ("method", "str"),
    ("mass_kg", "float"), ("run", "str"), ("trial", "int"), ("true_mass_kg", "float"),
    ("plan_status", "str"), ("verdict_failed", "str"), ("solver_status", "str"), ("min_d", "float"),
    ("min_capacity_margin", "float"),
    ("min_capacity_minus_force", "float"), ("mean_capacity", "float"), ("min_capacity", "float"),
    ("mean_manipulability", "float"), ("min_manipulability", "float"), ("max_torque_ratio", "float"),
    ("max_torque_ratio_with_force", "float"), ("waypoints_with_d_negative", "int"),
    ("first_time_below_force", "float"), ("first_time_below_band", "float"),
    ("sim_verdict", "str"), ("sim_reason", "str"), ("sim_failure_time_s", "float"),
    ("sim_max_ee_error_m", "float"), ("sim_max_torque_ratio", "float"), ("error", "str"),
)
NAMES: tuple[str, ...] = tuple(name for name, _ in COLUMNS)
CSV_FILE, PARQUET_FILE = "results.csv", "results.parquet"


def normalize(row: dict[str, Any]) -> dict[str, Any]:
    """``row`` with exactly the table's columns, each of its type (missing: None)."""
    out = {}
    for name, kind in COLUMNS:
        value = row.get(name)
        if value is None or value == "":
            out[name] = None
        elif kind == "float":
            out[name] = float(value)
        elif kind == "int":
            out[name] = int(value)
        else:
            out[name] = str(value)
    return out


def _text(value: Any) -> str:
    if value is None:
        return ""
    return repr(value) if isinstance(value, float) else str(value)


def csv_text(rows: Sequence[dict[str, Any]]) -> str:
    """The CSV of ``rows`` (header first)."""
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(NAMES)
    for row in rows:
        r = normalize(row)
        writer.writerow([_text(r[n]) for n in NAMES])
    return buf.getvalue()


def read_csv(path: str | Path) -> list[dict[str, Any]]:
    """The rows of a sweep's ``results.csv``, typed like :func:`normalize`."""
    with Path(path).open(newline="", encoding="utf-8") as fh:
        return [normalize(r) for r in csv.DictReader(fh)]


def parquet_available() -> bool:
    try:
        import pyarrow  # noqa: F401
    except ImportError:
        return False
    return True


def write_table(rows: Sequence[dict[str, Any]], directory: Path, parquet: bool = True) -> list[str]:
    """Write ``results.csv`` (and ``results.parquet`` when pyarrow is installed) atomically.

    Returns the file names written. A Parquet file left from an earlier run is removed when it
    cannot be rewritten, so the two never disagree.
    """
    atomic_write(directory / CSV_FILE, csv_text(rows))
    names = [CSV_FILE]
    target = directory / PARQUET_FILE
    if parquet and parquet_available():
        _write_parquet(rows, target)
        names.append(PARQUET_FILE)
    else:
        target.unlink(missing_ok=True)
    return names


def _write_parquet(rows: Sequence[dict[str, Any]], target: Path) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    types = {"str": pa.string(), "int": pa.int64(), "float": pa.float64()}
    schema = pa.schema([(name, types[kind]) for name, kind in COLUMNS])
    table = pa.Table.from_pylist([normalize(r) for r in rows], schema=schema)
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    os.close(fd)
    try:
        mask = os.umask(0)
        os.umask(mask)
        os.chmod(tmp, 0o666 & ~mask)  # as a plain open would (mkstemp gives 0o600)
        pq.write_table(table, tmp)
        os.replace(tmp, target)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
