"""Plan directories: the one owner of the files a plan is stored in.

A plan directory holds

- ``trajectory.csv``: ``t, x_b, y_b, yaw, q1..qn`` per waypoint (``last_iterate.csv`` instead
  when the optimization failed, so a failed plan never carries the name of a plan);
- ``metrics.csv``: the columns of :data:`METRIC_COLUMNS` (``clearance``: the robot's exact
  distance to the scene, m; ``inf`` without a scene; a file of :data:`LEGACY_METRIC_COLUMNS`, written
  before the scene, is still read, without that column), then :data:`MOMENT_COLUMNS` when the task
  needs a moment;
- ``plan.json``: :func:`plan_document`, with ``"generator": "forte"`` and
  ``"format_version"`` (:data:`FORMAT_VERSION`);
- ``robot.urdf``: the robot's URDF as planned, named and hashed in plan.json's ``robot`` block, so
  the directory reads the same wherever it is moved (:mod:`forte.io.robot_file`);
- figures (PNG), when asked for.

:func:`write_plan` is the only writer and :func:`read_plan_dir` the only reader. Writing goes to a
temporary sibling that is renamed into place, so a crash never leaves a half-written directory;
an existing ``--out`` is replaced only when forte wrote it (:func:`is_forte_output`): anything
else (a user's folder, a plain file) is refused with :class:`~forte.exceptions.OutputError`.
Replacement is atomic (``renameat2(RENAME_EXCHANGE)``), writers of one output are serialized by a
lock, and leftovers of killed writers are cleaned by the next one (:func:`replace_directory`).

This module is the import path of all of it; the parts live in :mod:`forte.io.plan_format` (file
names, format version, columns), :mod:`forte.io.plan_writer` and :mod:`forte.io.plan_reader`.
"""

from __future__ import annotations

# kept importable here, as before the split (tests import output_lock from this module)
from forte.io.outputs import GENERATOR as GENERATOR
from forte.io.outputs import atomic_write as atomic_write
from forte.io.outputs import output_lock as output_lock
from forte.io.outputs import replace_directory as replace_directory
from forte.io.plan_format import (
    COMPARISON_FILE,
    FORMAT_VERSION,
    GOOD_STATUSES,
    LAST_ITERATE_FILE,
    LEGACY_METRIC_COLUMNS,
    METRIC_COLUMNS,
    METRICS_FILE,
    MOMENT_COLUMNS,
    PLAN_FILE,
    STABILITY_COLUMNS,
    TRAJECTORY_FILE,
)
from forte.io.plan_reader import read_controller, read_metrics, read_plan_dir
from forte.io.plan_writer import (
    fill_plan_dir,
    holds_success,
    plan_document,
    plan_summary,
    write_csv,
    write_plan,
    write_plan_dir,
)

__all__ = ["COMPARISON_FILE", "FORMAT_VERSION", "GOOD_STATUSES", "LAST_ITERATE_FILE", "LEGACY_METRIC_COLUMNS",
           "METRICS_FILE", "METRIC_COLUMNS", "MOMENT_COLUMNS", "PLAN_FILE", "STABILITY_COLUMNS", "TRAJECTORY_FILE",
           "fill_plan_dir", "holds_success", "plan_document", "plan_summary", "read_controller", "read_metrics",
           "read_plan_dir", "write_csv", "write_plan", "write_plan_dir"]
