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
"""

from __future__ import annotations

import csv
import json
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np

from forte.exceptions import InvalidInputError, TaskFileError
from forte.force.contact import Contact, contact_from_dict, contact_to_dict
from forte.force.payload import Payload
from forte.force.taskforce import TaskForce, payload_force
from forte.io.outputs import (
    GENERATOR,
    atomic_write,
    output_lock,
    replace_directory,
)
from forte.io.records import jsonable, package_versions
from forte.io.robot_file import store_robot, stored_description
from forte.model.robot import MobileManipulator, robot_from_description
from forte.model.scene import DEFAULT_FLOOR, Scene, scene_from_json
from forte.model.trajectory import trajectory_header
from forte.planning.planner import Plan
from forte.planning.tasks.posture import start_posture
from forte.planning.tasks.weights_section import settings_record, weights_record
from forte.planning.verdict.verdict import Verdict, judge
from forte.settings import CapabilityParameters
from forte.validation import (
    MAX_DURATION_S,
    MAX_FILE_BYTES,
    MAX_WAYPOINTS,
    FloatArray,
    as_array,
    as_positive,
    check_times,
)

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


# -- writing ----------------------------------------------------------------------------------
def write_csv(path: Path, header: list[str], rows: np.ndarray) -> None:
    """A CSV of floats written with full precision (``repr``)."""
    with path.open("w", newline="", encoding="utf-8") as fh:
        writer = csv.writer(fh)
        writer.writerow(header)
        for row in rows:
            writer.writerow([repr(float(v)) for v in row])


def holds_success(directory: Path) -> bool:
    """True when ``directory`` holds a feasible plan (or a successful one of format 1-2)."""
    try:
        return json.loads((directory / PLAN_FILE).read_text()).get("status") in GOOD_STATUSES
    except (OSError, ValueError, AttributeError):
        return False


def write_plan(plan: Plan, out: Path, figures: bool = True) -> Path:
    """Write a plan directory atomically; returns where it went (``out`` or ``out.failed``).

    A plan that is not feasible (infeasible, or a failed solve) never replaces a directory that
    holds a feasible one: it goes to ``DIR.failed``.
    """
    out = Path(out)
    with output_lock(out):
        target = out.with_name(out.name + ".failed") if not plan.feasible and holds_success(out) else out
        replace_directory(lambda d: fill_plan_dir(plan, d, figures), target)
    return target


def fill_plan_dir(plan: Plan, directory: Path, figures: bool = True) -> None:
    """Write the files of ``plan`` into the (new, empty) ``directory``."""
    name = TRAJECTORY_FILE if plan.solved else LAST_ITERATE_FILE
    write_csv(directory / name, trajectory_header(plan.robot.n_arm), np.column_stack([plan.t, plan.q]))
    if plan.metrics:
        columns = METRIC_COLUMNS + tuple(c for c in MOMENT_COLUMNS + STABILITY_COLUMNS if c in plan.metrics)
        write_csv(directory / METRICS_FILE, list(columns), np.column_stack([plan.metrics[c] for c in columns]))
    doc = plan_document(plan)
    doc["robot"] = store_robot(plan.robot, directory)
    atomic_write(directory / PLAN_FILE, json.dumps(doc, indent=2) + "\n")
    if figures and plan.metrics:
        from forte.io.figure_worker import draw_plan_figures  # matplotlib only when figures are drawn

        draw_plan_figures(plan, directory)


def write_plan_dir(plan_dir: str | Path, robot: MobileManipulator, t: Any, q: Any, *, mass: float | None = None,
                   force: Any = None, radius: Any = 10.0, method: str = "manual", status: str = "success",
                   extra: dict[str, Any] | None = None, scene: Scene | None = None) -> Path:
    """Write a plan directory for waypoints ``q`` (N x nq) at times ``t`` given by hand (among
    the bodies of ``scene``, recorded in plan.json).

    ``force`` (N x 3, world frame) defaults to ``(m + m_tool) (a - g)`` of the end-effector
    waypoints (``m_tool``: the robot's ``tool_force_mass``) when ``mass`` is given
    (:func:`forte.force.taskforce.payload_force`), else to zero. The plan is judged like a
    planned one (:func:`forte.planning.verdict.verdict.judge`, the default ``alpha`` and kinematic
    limits), except tracking: there is no task path to follow.
    """
    times = check_times(t, "t")
    Q = as_array(q, "q", (times.size, robot.nq))
    if force is None and mass:
        positions = np.array([robot.ee_position(qk) for qk in Q])
        # the required force carries the robot's own end-effector load too, as a planned task's does
        tf = payload_force(times, positions, mass + robot.tool_force_mass, radius=radius, gravity=robot.gravity)
    else:
        f = np.zeros((times.size, 3)) if force is None else as_array(force, "force", (times.size, 3))
        tf = TaskForce(times, f, np.array(np.broadcast_to(np.asarray(radius, dtype=float), (times.size,))))
    payload = Payload(mass=float(mass), source="given") if mass else Payload(source="none")
    scene = Scene() if scene is None else scene  # the floor at least: every world has one
    verdict = judge(robot, times, Q, tf, CapabilityParameters().alpha, scene=scene)
    plan = Plan(method=method, robot=robot, t=times, q=Q, force=tf, payload=payload,
                solved=status == "success", status=status, solver=dict(extra or {}), verdict=verdict,
                scene=scene)
    replace_directory(lambda d: fill_plan_dir(plan, d, figures=False), Path(plan_dir))
    return Path(plan_dir)


# -- plan.json --------------------------------------------------------------------------------
def plan_summary(plan: Plan) -> dict[str, float]:
    """The quantities the paper discusses, for one plan."""
    m = plan.metrics
    return {
        "min_d": float(np.min(m["d"])),
        "min_capacity_margin": float(np.min(m["capacity_margin"])),
        "mean_manipulability": float(np.mean(m["manipulability"])),
        "min_manipulability": float(np.min(m["manipulability"])),
        "max_torque_ratio": float(np.max(m["max_torque_ratio"])),
        "max_torque_ratio_with_force": float(np.max(m["max_torque_ratio_with_force"])),
        "waypoints_with_d_negative": int(np.sum(m["d"] < 0)),
    }


def plan_document(plan: Plan) -> dict[str, Any]:
    """Everything ``plan.json`` records (schema version :data:`FORMAT_VERSION`)."""
    task = plan.task
    doc: dict[str, Any] = {"generator": GENERATOR, "format_version": FORMAT_VERSION}
    if task is not None:
        doc["task"] = {"name": task.name, "file": str(task.source) if task.source else None, "mode": task.mode,
                       "waypoints": task.n, "duration_s": float(task.t[-1] - task.t[0]), "definition": task.raw}
    doc |= {"method": plan.method, "status": plan.label, "solver_status": plan.status, "solver": plan.solver}
    if plan.verdict is not None:
        doc["verdict"] = plan.verdict.to_json()
    if task is not None:
        doc |= {"weights": weights_record(task.weights, task.settings), "term_settings": settings_record(task.settings),
                "solver_options": asdict(task.solver),
                "kinematic_limits": asdict(task.limits)}
    doc |= {"robot": plan.robot.describe(), "payload": plan.payload.to_dict()}
    if plan.scene:
        doc["scene"] = plan.scene.describe()
    doc["floor"] = plan.scene.floor  # the floor's height (m), None: no floor (forte simulate builds it)
    if plan.verdict is not None and plan.verdict.clearance is not None:
        doc["clearance"] = plan.verdict.clearance  # the closest approach over the judged samples
    if plan.contact is not None:  # a contact task (forte.force.contact): forte simulate builds the object
        doc["contact"] = contact_to_dict(plan.contact)
    if plan.force is not None:
        given = task is not None and task.force_profile is not None
        # the task's force_model (paper | authors) or contact kind; None for a given profile or a plan made by hand
        model = plan.contact.kind if plan.contact is not None else getattr(task, "force_model", None)
        doc["force"] = {"t": plan.force.t, "f": plan.force.f, "r": plan.force.r, "given_profile": given,
                        "model": None if task is None or given else model}
        if plan.force.has_moment:  # the wrench requirement: moment (N m), r_m = lever r, scale L (m)
            doc["force"] |= {"m": plan.force.m, "lever_m": plan.force.lever, "moment_scale": plan.force.moment_scale}
    if task is not None:
        doc["q_init"] = task.q_init
        doc["controller"] = task.controller
        if (posture := start_posture(task)) is not None:  # poor (near a limit, singular, self-colliding) or not
            doc["start_posture"] = posture.to_json()
    if plan.metrics:
        from forte.planning.verdict.sanity import negative_margins

        doc["summary"] = plan_summary(plan)
        doc["capacity"] = negative_margins(plan.metrics)  # where the force ball leaves the RFP (d < 0)
    doc["versions"] = package_versions()
    return jsonable(doc)


# -- reading ----------------------------------------------------------------------------------
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
