"""Reading a plan directory (:mod:`forte.io.plandir` says what it holds): :func:`read_plan_dir`
loads and validates plan.json, the stored URDF and trajectory.csv into a
:class:`~forte.planning.planner.Plan`; :func:`read_metrics` and :func:`read_controller` read one
file or field each. Every error names the file, the field or line and column, and what was
expected (:class:`~forte.exceptions.TaskFileError`)."""

from __future__ import annotations

import csv
import json
from pathlib import Path
from typing import Any

import numpy as np

from forte.exceptions import InvalidInputError, TaskFileError
from forte.force.contact import Contact, contact_from_dict
from forte.force.payload import Payload
from forte.force.taskforce import TaskForce
from forte.io.plan_format import (
    LEGACY_METRIC_COLUMNS,
    METRIC_COLUMNS,
    METRICS_FILE,
    MOMENT_COLUMNS,
    PLAN_FILE,
    STABILITY_COLUMNS,
    TRAJECTORY_FILE,
)
from forte.io.robot_file import stored_description
from forte.model.robot import MobileManipulator, robot_from_description
from forte.model.scene import DEFAULT_FLOOR, Scene, scene_from_json
from forte.model.trajectory import trajectory_header
from forte.planning.planner import Plan
from forte.planning.verdict.verdict import Verdict
from forte.validation import (
    MAX_DURATION_S,
    MAX_FILE_BYTES,
    MAX_WAYPOINTS,
    FloatArray,
    as_array,
    as_positive,
    check_times,
)


def read_plan_dir(plan_dir: str | Path) -> Plan:
    """Load and validate a plan directory; errors name the file and the field."""
    root = Path(plan_dir)
    if not root.is_dir():
        raise TaskFileError(f"plan directory {root}: does not exist or is not a directory")
    plan_path, traj_path = root / PLAN_FILE, root / TRAJECTORY_FILE
    for path in (plan_path, traj_path):
        if not path.is_file():
            raise TaskFileError(f"{path}: file missing (expected the output of 'forte plan')")
    for path in (plan_path, traj_path):
        size = path.stat().st_size
        if size > MAX_FILE_BYTES:
            raise TaskFileError(f"{path}: {size} bytes; expected at most {MAX_FILE_BYTES} (not a plan of forte's)")
    try:
        meta = json.loads(plan_path.read_text(encoding="utf-8"))
    except UnicodeDecodeError as exc:
        raise TaskFileError(f"{plan_path}: not UTF-8 text (offset {exc.start})") from None
    except (OSError, json.JSONDecodeError) as exc:
        raise TaskFileError(f"{plan_path}: not valid JSON: {exc}") from None
    except RecursionError:
        raise TaskFileError(f"{plan_path}: nested too deeply to be a plan.json") from None
    if not isinstance(meta, dict) or not isinstance(meta.get("robot"), dict):
        raise TaskFileError(f"{plan_path}: field 'robot': expected the robot description object")
    try:
        robot = robot_from_description(stored_description(root, meta["robot"]))
    except TaskFileError:
        raise
    except Exception as exc:  # noqa: BLE001 - any malformed field (Pinocchio raises its own types) is bad input
        raise TaskFileError(f"{plan_path}: field 'robot': expected the description forte wrote, "
                            f"{type(exc).__name__}: {exc}") from None
    payload = _read_payload(plan_path, meta.get("payload"))
    t, q = _read_trajectory(traj_path, robot)
    force = _read_force(plan_path, meta.get("force"))
    if force is not None and force.t.size > MAX_WAYPOINTS:
        raise TaskFileError(f"{plan_path}: field 'force.t': {force.t.size} samples; expected at most {MAX_WAYPOINTS}")
    return Plan(method=str(meta.get("method", "unknown")), robot=robot, t=t, q=q, force=force, payload=payload,
                solved=True, status=str(meta.get("solver_status", meta.get("status", "unknown"))),
                verdict=_read_verdict(plan_path, meta.get("verdict"), meta.get("clearance")),
                scene=_read_scene(plan_path, meta.get("scene"), meta.get("floor", DEFAULT_FLOOR)),
                contact=_read_contact(plan_path, meta.get("contact")))


def _read_contact(plan_path: Path, doc: Any) -> Contact | None:
    if doc is None:
        return None
    try:
        return contact_from_dict(doc)
    except (InvalidInputError, TypeError, ValueError) as exc:
        raise TaskFileError(f"{plan_path}: field {str(exc).partition(': ')[0] or 'contact'}: "
                            f"{str(exc).partition(': ')[2] or exc}") from None


def _read_scene(plan_path: Path, entries: Any, floor: Any) -> Scene:
    """The scene recorded in plan.json (empty when none) and its floor (a plan.json written before
    the floor was recorded: z = 0, where MuJoCo always had it)."""
    try:
        return scene_from_json(entries, floor)
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        field = "floor" if str(exc).startswith("floor:") else "scene"
        raise TaskFileError(f"{plan_path}: field '{field}': expected the {field} forte wrote ({exc})") from None


def _read_verdict(plan_path: Path, doc: Any, clearance: Any = None) -> Verdict | None:
    """The verdict recorded in plan.json (``None`` for a plan of format 1-2, written before verdicts),
    with the ``clearance`` block when there is one."""
    if doc is None:
        return None
    if clearance is not None and not isinstance(clearance, dict):
        raise TaskFileError(f"{plan_path}: field 'clearance': expected the clearance object forte wrote")
    try:
        return Verdict.from_json(doc)._replace(clearance=clearance)
    except (KeyError, TypeError, ValueError, AttributeError):
        raise TaskFileError(f"{plan_path}: field 'verdict': expected the verdict object forte wrote") from None


def read_controller(plan_dir: str | Path) -> dict[str, Any]:
    """The ``controller:`` mapping the plan's task gave (empty: none, or an older plan.json)."""
    path = Path(plan_dir) / PLAN_FILE
    try:
        controller = json.loads(path.read_text(encoding="utf-8")).get("controller") or {}
    except (OSError, UnicodeDecodeError, json.JSONDecodeError, AttributeError) as exc:
        raise TaskFileError(f"{path}: not valid JSON: {exc}") from exc
    if not isinstance(controller, dict):
        raise TaskFileError(f"{path}: field 'controller': expected a mapping, got {type(controller).__name__}")
    return controller


def read_metrics(plan_dir: str | Path) -> dict[str, FloatArray]:
    """The columns of ``metrics.csv`` (:data:`METRIC_COLUMNS`, then :data:`MOMENT_COLUMNS` when the
    task needs a moment and :data:`STABILITY_COLUMNS` when the robot states its base support, or
    the older :data:`LEGACY_METRIC_COLUMNS` without ``clearance``); empty
    when the plan has none."""
    path = Path(plan_dir) / METRICS_FILE
    if not path.is_file():
        return {}
    rows = list(csv.reader(path.read_text(encoding="utf-8").splitlines()))
    header = [h.strip() for h in rows[0]] if rows else []
    tails = ((), MOMENT_COLUMNS, STABILITY_COLUMNS, MOMENT_COLUMNS + STABILITY_COLUMNS)
    if header != list(LEGACY_METRIC_COLUMNS) and header not in [list(METRIC_COLUMNS + tail) for tail in tails]:
        raise TaskFileError(f"{path}: header: expected {','.join(METRIC_COLUMNS)}, got {','.join(header)}")
    body = [r for r in rows[1:] if any(c.strip() for c in r)]
    try:  # d may be +-inf (vacuous or empty RFP rows), clearance inf (no scene): no finiteness check here
        data = np.array([[float(c) for c in r] for r in body], dtype=float).reshape(len(body), len(header))
    except ValueError as exc:
        raise TaskFileError(f"{path}: expected {len(header)} numbers per row: {exc}") from None
    return {name: data[:, i] for i, name in enumerate(header)}


def _read_payload(plan_path: Path, payload: Any) -> Payload:
    mass = payload.get("mass") if isinstance(payload, dict) else None
    if mass is None:
        return Payload(source="none")
    try:
        mass = as_positive(mass, "payload.mass", allow_zero=True)
    except InvalidInputError as exc:
        raise TaskFileError(f"{plan_path}: field {exc}") from exc
    geometry = {k: payload[k] for k in ("com", "inertia") if payload.get(k) is not None}
    if payload.get("moment_scale_given"):
        geometry["moment_scale"] = payload.get("moment_scale")
    try:
        return Payload(mass=mass, source=str(payload.get("source", "given")), **geometry) if mass > 0 \
            else Payload(source="none")
    except InvalidInputError as exc:
        raise TaskFileError(f"{plan_path}: field {exc}") from exc


def _read_force(plan_path: Path, fmeta: Any) -> TaskForce | None:
    if fmeta is None:
        return None
    try:
        t = check_times(fmeta["t"], "force.t")
        f = as_array(fmeta["f"], "force.f", (t.size, 3))
        r = fmeta.get("r", np.zeros(t.size))
        if fmeta.get("m") is None:
            return TaskForce(t, f, as_array(r, "force.r", (t.size,)))
        return TaskForce(t, f, as_array(r, "force.r", (t.size,)), as_array(fmeta["m"], "force.m", (t.size, 3)),
                         float(fmeta.get("lever_m", 0.0)), float(fmeta.get("moment_scale", 0.0)))
    except (KeyError, TypeError, AttributeError, IndexError) as exc:
        raise TaskFileError(f"{plan_path}: field 'force': expected {{'t': [...], 'f': [...], 'r': [...]}}") from exc
    except InvalidInputError as exc:
        raise TaskFileError(f"{plan_path}: field {exc}") from exc


def _read_trajectory(path: Path, robot: MobileManipulator) -> tuple[FloatArray, FloatArray]:
    expected = trajectory_header(robot.n_arm)
    try:
        rows = list(csv.reader(path.read_text(encoding="utf-8").splitlines()))
    except UnicodeDecodeError as exc:
        raise TaskFileError(f"{path}: not UTF-8 text (offset {exc.start})") from None
    except (OSError, csv.Error) as exc:
        raise TaskFileError(f"{path}: cannot read: {exc}") from None
    if not rows:
        raise TaskFileError(f"{path}: empty file (expected header {','.join(expected)})")
    header = [h.strip() for h in rows[0]]
    if header != expected:
        raise TaskFileError(f"{path}: header: expected {len(expected)} columns {','.join(expected)}, "
                            f"got {len(header)}: {','.join(header)}")
    body = [r for r in rows[1:] if any(c.strip() for c in r)]
    if not body:
        raise TaskFileError(f"{path}: no waypoint rows after the header")
    if len(body) > MAX_WAYPOINTS:
        raise TaskFileError(f"{path}: {len(body)} waypoint rows; expected at most {MAX_WAYPOINTS} (forte's bound)")
    data = np.empty((len(body), len(expected)))
    for i, row in enumerate(body):
        if len(row) != len(expected):
            raise TaskFileError(f"{path}: line {i + 2}: expected {len(expected)} values, got {len(row)}")
        data[i] = [_cell(path, i + 2, name, cell) for name, cell in zip(expected, row, strict=True)]
    try:
        t = check_times(data[:, 0], "t")
    except InvalidInputError as exc:
        raise TaskFileError(f"{path}: column {exc}") from exc
    if t[-1] - t[0] > MAX_DURATION_S:
        raise TaskFileError(f"{path}: column t: spans {t[-1] - t[0]:g} s; expected at most {MAX_DURATION_S:g} s")
    return t, data[:, 1:]


def _cell(path: Path, line: int, column: str, cell: str) -> float:
    try:
        value = float(cell)
    except ValueError:
        raise TaskFileError(f"{path}: line {line}, column '{column}': expected a number, got {cell!r}") from None
    if not np.isfinite(value):
        raise TaskFileError(f"{path}: line {line}, column '{column}': not finite ({cell})")
    return value


__all__ = ["read_controller", "read_metrics", "read_plan_dir"]
