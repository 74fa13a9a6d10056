"""Outputs forte writes: recognised, never replaced when foreign, swapped in atomically, locked.

A directory forte writes (a plan, a comparison, an experiment) carries ``"generator": "forte"``
in its ``plan.json``, ``comparison.json`` or ``summary.json`` (:func:`is_forte_output`); an
existing output is replaced only then (or when empty): anything else (a user's folder, a plain
file) is refused with :class:`~forte.exceptions.OutputError` before any work starts
(:func:`check_output`). A new directory is built in a hidden sibling and swapped in atomically
(``renameat2(RENAME_EXCHANGE)``), writers of one output are serialized by a lock
(:func:`output_lock`), and leftovers of killed writers are cleaned by the next one
(:func:`replace_directory`).
"""

from __future__ import annotations

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
from pathlib import Path
from typing import Any

from forte.exceptions import OutputError

#: The field every output forte writes carries, and the files that carry it.
GENERATOR = "forte"
MARKER_FILES = ("plan.json", "comparison.json", "summary.json", "sim.json", "sweep.json")


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


def is_forte_output(path: Path) -> bool:
    """True when ``path`` is a directory forte wrote (a plan, a comparison, an experiment)."""
    for name in MARKER_FILES:
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


