"""The plan directory's format: its file names, plan.json's version and statuses, metrics.csv's
columns (what each file holds: :mod:`forte.io.plandir`; the writer :mod:`forte.io.plan_writer`
and the reader :mod:`forte.io.plan_reader` share these)."""

from __future__ import annotations

TRAJECTORY_FILE = "trajectory.csv"
LAST_ITERATE_FILE = "last_iterate.csv"
METRICS_FILE = "metrics.csv"
PLAN_FILE = "plan.json"
#: Top-level record of a directory of several plans (``forte compare``).
COMPARISON_FILE = "comparison.json"
#: Version of the plan.json schema; 1 is the unversioned layout of forte 0.1 (still read).
#: 3: ``status`` is the verdict's label (``feasible | infeasible | solver-failed``; 2 wrote
#: ``success | failure`` for the solver alone) and ``verdict`` records every failed requirement.
#: 4: the robot's URDF is stored beside plan.json (``robot.urdf_file``, ``robot.urdf_sha256``) and
#: ``robot.urdf`` is ``erd:<path>`` for example-robot-data's (3 wrote an absolute path; still read).
FORMAT_VERSION = 4
#: ``status`` values of a directory that holds an executable plan (``success``: format 1-2).
GOOD_STATUSES = ("feasible", "success")
METRIC_COLUMNS = ("t", "fx", "fy", "fz", "radius", "d", "directional_capacity", "capacity_margin",
                  "inscribed_radius", "manipulability", "max_torque_ratio", "max_torque_ratio_with_force",
                  "clearance")
#: The columns of metrics.csv before the scene (no ``clearance``), still read.
LEGACY_METRIC_COLUMNS = METRIC_COLUMNS[:-1]
#: The columns added after :data:`METRIC_COLUMNS` when the task needs a moment (N m, world frame).
MOMENT_COLUMNS = ("mx", "my", "mz")
#: The column added last when the robot states its base support (m, :mod:`forte.model.stability`).
STABILITY_COLUMNS = ("tipover_margin",)

__all__ = ["COMPARISON_FILE", "FORMAT_VERSION", "GOOD_STATUSES", "LAST_ITERATE_FILE", "LEGACY_METRIC_COLUMNS",
           "METRICS_FILE", "METRIC_COLUMNS", "MOMENT_COLUMNS", "PLAN_FILE", "STABILITY_COLUMNS", "TRAJECTORY_FILE"]
