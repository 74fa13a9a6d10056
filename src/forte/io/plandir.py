"""Plan directories: the files a plan is stored in, written atomically and read back with precise errors.

A plan directory holds ``trajectory.csv`` (``t, x_b, y_b, yaw, q1..qn`` per waypoint) and
``plan.json`` (robot description, payload, force sequence, method, status, ...).
"""

from __future__ import annotations

import csv
import io
import json
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from forte.exceptions import ForteError, InvalidInputError, TaskFileError
from forte.model.robot import MobileManipulator, robot_from_description
from forte.model.trajectory import trajectory_header
from forte.validation import FloatArray, as_array, as_positive, check_times

TRAJECTORY_FILE = "trajectory.csv"
PLAN_FILE = "plan.json"


@dataclass(frozen=True)
class Plan:
    """The content of a plan directory."""

    robot: MobileManipulator
    t: FloatArray
    q: FloatArray
    mass: float | None
    force_t: FloatArray | None
    force: FloatArray | None
    method: str
    status: str


def atomic_write(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` through a temporary file in the same folder and a rename."""
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w", newline="") as fh:
            fh.write(text)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def write_plan_dir(
    plan_dir: str | Path,
    robot: MobileManipulator,
    t: Any,
    q: Any,
    *,
    mass: float | None = None,
    force: Any = None,
    radius: Any = 10.0,
    method: str = "manual",
    status: str = "success",
    extra: dict[str, Any] | None = None,
) -> Path:
    """Write ``trajectory.csv`` and ``plan.json`` for waypoints ``q`` (N x nq) at times ``t``.

    ``force`` (N x 3, world frame) defaults to ``m (a - g)`` of the end-effector waypoints when
    ``mass`` is given (:func:`forte.force.taskforce.payload_force`), else to zero.
    """
    from forte.force.taskforce import payload_force  # local: keeps this module light to import

    times = check_times(t, "t")
    Q = as_array(q, "q", (times.size, robot.nq))
    if force is None and mass:
        positions = np.array([robot.ee_position(qk) for qk in Q])
        tf = payload_force(times, positions, mass, radius=radius, gravity=robot.gravity)
        f, r = tf.f, tf.r
    else:
        f = np.zeros((times.size, 3)) if force is None else as_array(force, "force", (times.size, 3))
        r = np.broadcast_to(np.asarray(radius, dtype=float), (times.size,))
    out = Path(plan_dir)
    out.mkdir(parents=True, exist_ok=True)
    buf = io.StringIO()
    writer = csv.writer(buf)
    writer.writerow(trajectory_header(robot.n_arm))
    for tk, qk in zip(times, Q, strict=True):
        writer.writerow([repr(float(tk)), *(repr(float(v)) for v in qk)])
    plan: dict[str, Any] = {
        "robot": robot.describe(),
        "payload": {"mass": None if mass is None else float(mass)},
        "force": {"t": times.tolist(), "f": f.tolist(), "r": [float(v) for v in r]},
        "method": method,
        "status": status,
    }
    plan.update(extra or {})
    atomic_write(out / TRAJECTORY_FILE, buf.getvalue())
    atomic_write(out / PLAN_FILE, json.dumps(plan, indent=1) + "\n")
    return out


def read_plan_dir(plan_dir: str | Path) -> Plan:
    """Load and validate a plan directory; errors name the file and the field."""
    root = Path(plan_dir)
    if not root.is_dir():
        raise TaskFileError(f"plan directory {root}: does not exist or is not a directory")
    plan_path = root / PLAN_FILE
    traj_path = root / TRAJECTORY_FILE
    for path in (plan_path, traj_path):
        if not path.is_file():
            raise TaskFileError(f"{path}: file missing (expected the output of 'forte plan')")
    try:
        meta = json.loads(plan_path.read_text())
    except (OSError, json.JSONDecodeError) as exc:
        raise TaskFileError(f"{plan_path}: not valid JSON: {exc}") from exc
    if not isinstance(meta, dict) or not isinstance(meta.get("robot"), dict):
        raise TaskFileError(f"{plan_path}: field 'robot': expected the robot description object")
    try:
        robot = robot_from_description(meta["robot"])
    except ForteError as exc:
        raise TaskFileError(f"{plan_path}: field 'robot': {exc}") from exc
    payload = meta.get("payload") or {}
    mass = payload.get("mass") if isinstance(payload, dict) else None
    if mass is not None:
        try:
            mass = as_positive(mass, "payload.mass", allow_zero=True)
        except InvalidInputError as exc:
            raise TaskFileError(f"{plan_path}: field {exc}") from exc
    force_t = force = None
    fmeta = meta.get("force")
    if fmeta is not None:
        try:
            force_t = check_times(fmeta["t"], "force.t")
            force = as_array(fmeta["f"], "force.f", (force_t.size, 3))
        except (KeyError, TypeError) as exc:
            raise TaskFileError(f"{plan_path}: field 'force': expected {{'t': [...], 'f': [...]}}") from exc
        except InvalidInputError as exc:
            raise TaskFileError(f"{plan_path}: field {exc}") from exc
    t, q = _read_trajectory(traj_path, robot)
    return Plan(robot, t, q, mass, force_t, force, str(meta.get("method", "unknown")),
                str(meta.get("status", "unknown")))


def _read_trajectory(path: Path, robot: MobileManipulator) -> tuple[FloatArray, FloatArray]:
    expected = trajectory_header(robot.n_arm)
    try:
        rows = list(csv.reader(path.read_text().splitlines()))
    except (OSError, csv.Error, UnicodeDecodeError) as exc:
        raise TaskFileError(f"{path}: cannot read: {exc}") from exc
    if not rows:
        raise TaskFileError(f"{path}: empty file (expected header {','.join(expected)})")
    header = [h.strip() for h in rows[0]]
    if header != expected:
        raise TaskFileError(
            f"{path}: header: expected {len(expected)} columns {','.join(expected)}, "
            f"got {len(header)}: {','.join(header)}"
        )
    body = [r for r in rows[1:] if any(c.strip() for c in r)]
    if not body:
        raise TaskFileError(f"{path}: no waypoint rows after the header")
    data = np.empty((len(body), len(expected)))
    for i, row in enumerate(body):
        line = i + 2
        if len(row) != len(expected):
            raise TaskFileError(f"{path}: line {line}: expected {len(expected)} values, got {len(row)}")
        for j, cell in enumerate(row):
            try:
                data[i, j] = float(cell)
            except ValueError:
                raise TaskFileError(
                    f"{path}: line {line}, column '{expected[j]}': expected a number, got {cell!r}"
                ) from None
            if not np.isfinite(data[i, j]):
                raise TaskFileError(f"{path}: line {line}, column '{expected[j]}': not finite ({cell})")
    try:
        t = check_times(data[:, 0], "t")
    except InvalidInputError as exc:
        raise TaskFileError(f"{path}: column {exc}") from exc
    return t, data[:, 1:]
