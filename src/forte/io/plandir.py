"""Plan directories: the one owner of the files a plan is stored in.

A plan directory holds

- ``trajectory.csv``: ``t, x_b, y_b, yaw, q1..qn`` per waypoint (``last_iterate.csv`` instead
  when the optimization failed, so a failed plan never carries the name of a plan);
- ``metrics.csv``: the columns of :data:`METRIC_COLUMNS`;
- ``plan.json``: :func:`plan_document`, with ``"generator": "forte"`` and
  ``"format_version"`` (:data:`FORMAT_VERSION`);
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
import ctypes
import errno
import json
import os
import shutil
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np

from forte.exceptions import InvalidInputError, OutputError, TaskFileError
from forte.force.payload import Payload
from forte.force.taskforce import TaskForce, payload_force
from forte.model.robot import MobileManipulator, robot_from_description
from forte.model.trajectory import trajectory_header
from forte.planning.planner import Plan
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
FORMAT_VERSION = 2
GENERATOR = "forte"
METRIC_COLUMNS = ("t", "fx", "fy", "fz", "radius", "d", "directional_capacity", "capacity_margin",
                  "inscribed_radius", "manipulability", "max_torque_ratio", "max_torque_ratio_with_force")


# -- writing ----------------------------------------------------------------------------------
def atomic_write(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` through a temporary file in the same folder and a rename.

    The file gets the mode a plain ``open`` would give (``0o666`` less the umask).
    """
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        os.fchmod(fd, 0o666 & ~_umask())
        with os.fdopen(fd, "w", newline="", encoding="utf-8") as fh:
            fh.write(text)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def write_csv(path: Path, header: list[str], rows: np.ndarray) -> None:
    """A CSV of floats written with full precision (``repr``)."""
    with path.open("w", newline="", encoding="utf-8") as fh:
        writer = csv.writer(fh)
        writer.writerow(header)
        for row in rows:
            writer.writerow([repr(float(v)) for v in row])


def is_forte_output(path: Path) -> bool:
    """True when ``path`` is a directory forte wrote (a plan, a comparison, an experiment)."""
    for name in (PLAN_FILE, COMPARISON_FILE, "summary.json", "sim.json"):
        try:
            if (path / name).stat().st_size > MAX_JSON_BYTES:
                continue
            doc = json.loads((path / name).read_text(encoding="utf-8"))
        except (OSError, ValueError, RecursionError):
            continue
        if isinstance(doc, dict) and (doc.get("generator") == GENERATOR or _legacy_plan(doc)):
            return True
    return False


def _legacy_plan(doc: dict[str, Any]) -> bool:
    """plan.json of forte 0.1 (no generator field): package versions name forte."""
    versions = doc.get("versions")
    return isinstance(versions, dict) and "forte" in versions and "method" in doc


def check_output(out: Path, option: str = "--out") -> Path:
    """Refuse an output path forte may not replace; returns it. Checked before any work starts.

    Accepted: a new path (its nearest existing ancestor a writable directory), an empty folder, or a
    folder forte wrote (:func:`is_forte_output`). Refused with :class:`OutputError` (one line):
    ``""``/``"."``, a plain file, a symbolic link, a folder holding anything else, a path under a
    file, an unwritable parent.
    """
    out = Path(out)
    if str(out) in ("", ".", "..") or out.name in ("", ".", ".."):
        raise OutputError(f"{option} {str(out)!r}: expected a new directory name")
    if "\0" in str(out):
        raise OutputError(f"{option} {str(out)!r}: contains a NUL byte")
    try:
        if out.is_symlink() or (out.exists() and not out.is_dir()):
            raise OutputError(f"{option} {out}: exists and is not a directory forte wrote; choose another path")
        if out.is_dir() and any(out.iterdir()) and not is_forte_output(out):
            raise OutputError(f"{option} {out}: exists and holds files forte did not write (no forte plan.json); "
                              "choose another path or empty it yourself")
        parent = out.parent if str(out.parent) else Path(".")
        probe = parent
        while not probe.exists() and not probe.is_symlink() and probe != probe.parent:
            probe = probe.parent
    except OSError as exc:  # a name too long, a parent we may not search, ...
        raise OutputError(f"{option} {out}: cannot be used ({exc.strerror or exc})") from None
    if not probe.is_dir() or not os.access(probe, os.W_OK | os.X_OK):
        raise OutputError(f"{option} {out}: {probe} is not a writable directory")
    return out


# -- crash-safe replacement ---------------------------------------------------------------------
#: Hidden siblings a writer of ``NAME`` creates next to it: ``.NAME.forte-tmp-*`` (the new
#: directory being built), ``.NAME.forte-old-*`` (the directory it replaced, being deleted) and
#: the lock file ``.NAME.forte-lock``. Only directories with these names that also carry
#: :data:`PARTIAL_MARKER`, are a forte output, or are empty are ever deleted as leftovers.
TMP_TAG, OLD_TAG, LOCK_TAG = "forte-tmp-", "forte-old-", "forte-lock"
#: File inside a directory forte is building or deleting (removed before the directory is renamed
#: into place, created before it is deleted): marks it as forte's leftover after a kill.
PARTIAL_MARKER = ".forte-partial"
#: Seconds a writer waits for another writer of the same output (``$FORTE_LOCK_TIMEOUT``).
LOCK_TIMEOUT_S = 600.0
#: plan.json / comparison.json larger than this are not read (a tampered or foreign file).
MAX_JSON_BYTES = 64 * 2**20

_HELD: dict[str, list[int]] = {}  # lock path -> [fd, depth]: a process re-enters its own lock


def _lock_timeout() -> float:
    try:
        return max(0.0, float(os.environ.get("FORTE_LOCK_TIMEOUT", LOCK_TIMEOUT_S)))
    except ValueError:
        return LOCK_TIMEOUT_S


@contextmanager
def output_lock(out: Path, timeout: float | None = None, option: str = "--out") -> Iterator[None]:
    """Hold the lock of output ``out`` (``fcntl.flock`` on ``.NAME.forte-lock`` next to it).

    Writers of one output are serialized: a second one waits up to ``timeout`` seconds
    (default ``$FORTE_LOCK_TIMEOUT`` or 600 s) and then fails with :class:`OutputError`. The
    lock file is removed on release (a waiter that opened the removed file notices and opens
    the new one), so nothing is left next to ``out``. Re-entrant within a process. Where
    ``fcntl`` does not exist (Windows) writers are not serialized.
    """
    out = Path(out)
    path = os.path.abspath(out.parent / f".{out.name}.{LOCK_TAG}")
    if path in _HELD:
        _HELD[path][1] += 1
        try:
            yield
        finally:
            _HELD[path][1] -= 1
        return
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not on Linux/macOS
        yield
        return
    deadline = time.monotonic() + (_lock_timeout() if timeout is None else timeout)
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"{option} {out}: cannot create {out.parent} ({exc.strerror or exc})") from None
    while True:
        try:
            fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o666)
        except OSError as exc:
            raise OutputError(f"{option} {out}: cannot create the lock file {path} ({exc.strerror or exc})") from None
        try:
            while True:
                try:
                    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                    break
                except BlockingIOError:
                    if time.monotonic() > deadline:
                        raise OutputError(f"{option} {out}: another forte process is writing it (lock {path}); "
                                          "gave up waiting, try again when it is done") from None
                    time.sleep(0.02)
            try:
                same = os.path.samestat(os.fstat(fd), os.stat(path))
            except FileNotFoundError:
                same = False
            if same:
                break
        except BaseException:
            os.close(fd)
            raise
        os.close(fd)  # the holder before us removed that file: lock the new one
    _HELD[path] = [fd, 1]
    try:
        yield
    finally:
        del _HELD[path]
        try:
            os.unlink(path)
        except OSError:
            pass
        os.close(fd)


def _rename_exchange(a: Path, b: Path) -> bool:
    """Atomically swap the paths ``a`` and ``b`` (Linux ``renameat2(RENAME_EXCHANGE)``).

    Returns False where the call does not exist or the file system does not support it.
    """
    func = _renameat2()
    if func is None:
        return False
    if func(-100, os.fsencode(a), -100, os.fsencode(b), 2) == 0:  # AT_FDCWD, RENAME_EXCHANGE
        return True
    err = ctypes.get_errno()
    if err in (errno.ENOSYS, errno.EINVAL, errno.ENOTSUP, errno.EOPNOTSUPP, errno.EXDEV, errno.EPERM):
        return False
    raise OSError(err, os.strerror(err), str(b))


_RENAMEAT2: list[Any] = []


def _renameat2() -> Any:
    if not _RENAMEAT2:
        func = None
        if sys.platform.startswith("linux"):
            try:
                libc = ctypes.CDLL(None, use_errno=True)
                func = libc.renameat2
                func.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint]
                func.restype = ctypes.c_int
            except (OSError, AttributeError):
                func = None
        _RENAMEAT2.append(func)
    return _RENAMEAT2[0]


def _siblings(out: Path, tag: str) -> list[Path]:
    prefix = f".{out.name}.{tag}"
    try:
        return sorted(p for p in out.parent.iterdir() if p.name.startswith(prefix) and not p.is_symlink()
                      and p.is_dir())
    except OSError:
        return []


def _is_leftover(path: Path) -> bool:
    """A directory forte left behind (marker, a complete forte output, or empty); never a user's."""
    try:
        return (path / PARTIAL_MARKER).is_file() or is_forte_output(path) or not any(path.iterdir())
    except OSError:
        return False


def _remove_tree(path: Path) -> None:
    """Delete a directory of forte's, keeping its marker until the end (a kill mid-way leaves it
    recognisable)."""
    marker = path / PARTIAL_MARKER
    if not marker.exists():
        marker.touch()
    for child in path.iterdir():
        if child.name == PARTIAL_MARKER:
            continue
        if child.is_dir() and not child.is_symlink():
            shutil.rmtree(child, ignore_errors=True)
        else:
            child.unlink(missing_ok=True)
    marker.unlink(missing_ok=True)
    path.rmdir()


def recover_output(out: Path) -> list[Path]:
    """Clean what killed writers of ``out`` left next to it; call with :func:`output_lock` held.

    When ``out`` is missing and a complete replaced directory survived (``.NAME.forte-old-*``,
    the two-rename fallback killed between its renames), it is put back under ``out`` first.
    Returns the paths removed.
    """
    out = Path(out)
    if not out.exists() and not out.is_symlink():
        for old in reversed(_siblings(out, OLD_TAG)):  # newest name last: mkdtemp names are random, any will do
            if is_forte_output(old):
                (old / PARTIAL_MARKER).unlink(missing_ok=True)
                os.rename(old, out)
                break
    removed = []
    for path in _siblings(out, TMP_TAG) + _siblings(out, OLD_TAG):
        if _is_leftover(path):
            try:
                _remove_tree(path)
                removed.append(path)
            except OSError:
                pass
    return removed


def replace_directory(build: Callable[[Path], None], out: Path, option: str = "--out") -> None:
    """Build a directory with ``build(tmp_path)`` and put it at ``out`` (never over a foreign one).

    Crash-safe at every instant: under the name ``out`` there is always either the previous
    complete directory or the new complete one. The new directory is built in a hidden sibling
    ``.NAME.forte-tmp-*`` (marked by :data:`PARTIAL_MARKER` while incomplete) and swapped in with
    one atomic ``renameat2(RENAME_EXCHANGE)`` (Linux); where that is unavailable, two renames are
    used and a kill between them leaves the previous directory in ``.NAME.forte-old-*``, which the
    next writer of ``out`` puts back (:func:`recover_output`). Writers of one ``out`` are
    serialized by :func:`output_lock`, and leftovers of killed writers are removed first.
    Directories and files follow the umask. ``OSError`` (disk full, permissions) becomes
    :class:`OutputError`.
    """
    out = Path(out)
    with output_lock(out, option=option):
        try:
            recover_output(out)
            out = check_output(out, option)
            tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.{TMP_TAG}", dir=out.parent))
        except OSError as exc:
            raise OutputError(f"{option} {out}: cannot write there ({exc.strerror or exc})") from None
        try:
            (tmp / PARTIAL_MARKER).touch()
            os.chmod(tmp, 0o777 & ~_umask())
            build(tmp)
            (tmp / PARTIAL_MARKER).unlink()
            if out.exists():
                if _rename_exchange(tmp, out):
                    _remove_tree(tmp)  # now the previous directory
                else:
                    old = Path(tempfile.mkdtemp(prefix=f".{out.name}.{OLD_TAG}", dir=out.parent))
                    (out / PARTIAL_MARKER).touch()
                    os.replace(out, old)  # old is empty: replaced
                    os.replace(tmp, out)
                    _remove_tree(old)
            else:
                os.replace(tmp, out)
        except OSError as exc:
            if tmp.exists():
                shutil.rmtree(tmp, ignore_errors=True)
            raise OutputError(f"{option} {out}: cannot write there ({exc.strerror or exc})") from None
        except BaseException:
            if tmp.exists():
                shutil.rmtree(tmp, ignore_errors=True)
            raise


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def holds_success(directory: Path) -> bool:
    """True when ``directory`` holds a successful plan."""
    try:
        return json.loads((directory / PLAN_FILE).read_text()).get("status") == "success"
    except (OSError, ValueError, AttributeError):
        return False


def write_plan(plan: Plan, out: Path, figures: bool = True) -> Path:
    """Write a plan directory atomically; returns where it went (``out`` or ``out.failed``).

    A failed plan never replaces a directory that holds a successful one: it goes to
    ``DIR.failed``.
    """
    out = Path(out)
    with output_lock(out):
        target = out.with_name(out.name + ".failed") if not plan.success and holds_success(out) else out
        replace_directory(lambda d: fill_plan_dir(plan, d, figures), target)
    return target


def fill_plan_dir(plan: Plan, directory: Path, figures: bool = True) -> None:
    """Write the files of ``plan`` into the (new, empty) ``directory``."""
    name = TRAJECTORY_FILE if plan.success else LAST_ITERATE_FILE
    write_csv(directory / name, trajectory_header(plan.robot.n_arm), np.column_stack([plan.t, plan.q]))
    if plan.metrics:
        write_csv(directory / METRICS_FILE, list(METRIC_COLUMNS),
                  np.column_stack([plan.metrics[c] for c in METRIC_COLUMNS]))
    atomic_write(directory / PLAN_FILE, json.dumps(plan_document(plan), indent=2) + "\n")
    if figures and plan.metrics:
        from forte.io.figures import plan_figures  # matplotlib only when figures are drawn

        plan_figures(plan, directory)


def write_plan_dir(plan_dir: str | Path, robot: MobileManipulator, t: Any, q: Any, *, mass: float | None = None,
                   force: Any = None, radius: Any = 10.0, method: str = "manual", status: str = "success",
                   extra: dict[str, Any] | None = None) -> Path:
    """Write a plan directory for waypoints ``q`` (N x nq) at times ``t`` given by hand.

    ``force`` (N x 3, world frame) defaults to ``(m + m_tool) (a - g)`` of the end-effector
    waypoints (``m_tool``: the robot's ``tool_force_mass``) when ``mass`` is given
    (:func:`forte.force.taskforce.payload_force`), else to zero.
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
    plan = Plan(method=method, robot=robot, t=times, q=Q, force=tf, payload=payload,
                success=status == "success", status=status, solver=dict(extra or {}))
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
    from forte.io.reports import jsonable, package_versions

    task = plan.task
    doc: dict[str, Any] = {"generator": GENERATOR, "format_version": FORMAT_VERSION}
    if task is not None:
        doc["task"] = {"name": task.name, "file": str(task.source) if task.source else None, "mode": task.mode,
                       "waypoints": task.n, "duration_s": float(task.t[-1] - task.t[0]), "definition": task.raw}
    doc |= {"method": plan.method, "status": "success" if plan.success else "failure",
            "solver_status": plan.status, "solver": plan.solver}
    if task is not None:
        doc |= {"weights": asdict(task.weights), "solver_options": asdict(task.solver),
                "kinematic_limits": asdict(task.limits)}
    doc |= {"robot": plan.robot.describe(), "payload": plan.payload.to_dict()}
    if plan.force is not None:
        doc["force"] = {"t": plan.force.t, "f": plan.force.f, "r": plan.force.r,
                        "given_profile": task is not None and task.force_profile is not None}
    if task is not None:
        doc["q_init"] = task.q_init
        doc["controller"] = task.controller
    if plan.metrics:
        from forte.planning.sanity import negative_margins

        doc["summary"] = plan_summary(plan)
        doc["capacity"] = negative_margins(plan.metrics)  # where the force ball leaves the RFP (d < 0)
        doc["capacity"]["required"] = bool(getattr(task, "require_capacity", False) or
                                           plan.status == "insufficient_capacity")
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
        robot = robot_from_description(meta["robot"])
    except Exception as exc:  # noqa: BLE001 - any malformed field (Pinocchio raises its own types) is bad input
        raise TaskFileError(f"{plan_path}: field 'robot': expected the description forte wrote, "
                            f"{type(exc).__name__}: {exc}") from None
    payload = _read_payload(plan_path, meta.get("payload"))
    t, q = _read_trajectory(traj_path, robot)
    force = _read_force(plan_path, meta.get("force"))
    if force is not None and force.t.size > MAX_WAYPOINTS:
        raise TaskFileError(f"{plan_path}: field 'force.t': {force.t.size} samples; expected at most {MAX_WAYPOINTS}")
    status = str(meta.get("status", "unknown"))
    return Plan(method=str(meta.get("method", "unknown")), robot=robot, t=t, q=q, force=force, payload=payload,
                success=status == "success", status=status)


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
    """The columns of ``metrics.csv`` (:data:`METRIC_COLUMNS`); empty when the plan has none."""
    path = Path(plan_dir) / METRICS_FILE
    if not path.is_file():
        return {}
    rows = list(csv.reader(path.read_text(encoding="utf-8").splitlines()))
    header = [h.strip() for h in rows[0]] if rows else []
    if header != list(METRIC_COLUMNS):
        raise TaskFileError(f"{path}: header: expected {','.join(METRIC_COLUMNS)}, got {','.join(header)}")
    body = [r for r in rows[1:] if any(c.strip() for c in r)]
    try:  # d may be +-inf (vacuous or empty RFP rows): no finiteness check here
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
    return Payload(mass=mass, source=str(payload.get("source", "given"))) if mass > 0 else Payload(source="none")


def _read_force(plan_path: Path, fmeta: Any) -> TaskForce | None:
    if fmeta is None:
        return None
    try:
        t = check_times(fmeta["t"], "force.t")
        f = as_array(fmeta["f"], "force.f", (t.size, 3))
        r = fmeta.get("r", np.zeros(t.size))
        return TaskForce(t, f, as_array(r, "force.r", (t.size,)))
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
