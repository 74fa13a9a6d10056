"""The ``forte`` command line.

Each sub-command registers itself with ``register(subparsers)`` and sets ``func`` (``args ->
exit code``) as a parser default.

One contract for every command:

- exit 0: success;
- exit 1: a plan or simulation that ran but failed (its status is in the outputs);
- exit 2: bad input or environment: one line on stderr, ``forte: error: ...``, naming the file,
  field or argument and what was expected (:class:`forte.exceptions.ForteError`, argument errors,
  ``forte`` without a command);
- exit 3: an unexpected exception (a bug): one line pointing to a saved report with the
  traceback (:func:`crash_report`), never a raw traceback on the terminal.

Python warnings are printed as one line each (``forte: warning: ...``).

The command runs BLAS and OpenMP single-threaded (:data:`forte.system.SINGLE_THREAD_ENV`)
unless the environment says otherwise: ``OPENBLAS_NUM_THREADS=4 forte plan ...`` uses four threads.
"""

from __future__ import annotations

import argparse
import importlib
import os
import platform
import re
import sys
import tempfile
import time
import traceback
import warnings
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any, NoReturn

from forte import __version__, progress
from forte.exceptions import ForteError
from forte.system import SINGLE_THREAD_ENV

#: Modules that add sub-commands (each has ``register(subparsers)``).
COMMAND_MODULES: tuple[str, ...] = (
    "forte.cli.demo",
    "forte.cli.plan",
    "forte.cli.estimation",
    "forte.cli.simulate",
    "forte.cli.experiment",
    "forte.cli.sweep",
    "forte.cli.export",
    "forte.cli.view",
    "forte.cli.ros",
    "forte.cli.schema",
    "forte.cli.importer",
)
EXIT_OK, EXIT_FAILED, EXIT_USAGE, EXIT_BUG = 0, 1, 2, 3
#: The environment the command sets where the user has not (:data:`forte.system.SINGLE_THREAD_ENV`).
#: NumPy's, SciPy's and CasADi's OpenBLAS
#: (IPOPT's MUMPS) each start a thread per core that spins on the small matrices of these NLPs.
#: Measured on 2 cores (benchmarks/bench_startup.py): a cold ``forte plan lift.yaml --waypoints
#: 100`` takes the same wall time single-threaded and a third less CPU time; on a loaded machine
#: the threads cost wall time too (N = 400: 8-10 s single-threaded against 9-17 s); only large
#: horizons on an idle machine gain from them (N = 400: 2.8 s instead of 3.6 s of solve with
#: ``OPENBLAS_NUM_THREADS=2``). Single-threaded, the process also may fork its figure drawing
#: (:mod:`forte.io.figure_processes`, :mod:`forte.io.figure_worker`).
THREAD_DEFAULTS = SINGLE_THREAD_ENV


class UsageError(Exception):
    """A command-line argument error (argparse's), reported in one line with exit 2."""


class ArgumentParser(argparse.ArgumentParser):
    """argparse with one-line errors: no usage block, the error and where to look."""

    def error(self, message: str) -> NoReturn:
        raise UsageError(f"{message} (see '{self.prog} --help')")


def build_parser() -> argparse.ArgumentParser:
    parser = ArgumentParser(
        prog="forte",
        description="Plan whole-body trajectories of mobile manipulators with task-sufficient "
        "force capability (FORTE).",
        epilog="Exit codes: 0 success, 1 a plan or simulation that ran but failed, 2 bad input or "
        "environment (one line), 3 an internal error (one line naming the saved report).",
    )
    parser.add_argument("--version", action="version", version=f"forte {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMAND_MODULES:
        try:
            module = importlib.import_module(name)
        except ModuleNotFoundError as exc:
            if exc.name == name:  # that stage is not part of this build
                continue
            raise
        module.register(sub)
    return parser


def one_line(text: str) -> str:
    """``text`` with its line breaks folded (a message must never span lines)."""
    return re.sub(r"\s*[\r\n]+\s*", " ", str(text)).strip()


def _error(text: str) -> None:
    print(f"forte: error: {one_line(text)}", file=sys.stderr, flush=True)


def reports_dir() -> Path:
    """Where crash reports go: ``$FORTE_REPORTS``, else ``~/.cache/forte/reports``."""
    return Path(os.environ.get("FORTE_REPORTS") or Path.home() / ".cache" / "forte" / "reports")


def crash_report(exc: BaseException, argv: Sequence[str]) -> Path | None:
    """Save the traceback of an unexpected exception; returns the file (None if none could be written)."""
    text = (f"forte {__version__}, Python {platform.python_version()}, {platform.platform()}\n"
            f"time: {time.strftime('%Y-%m-%d %H:%M:%S')}\ncommand: forte {' '.join(map(str, argv))}\n\n"
            + "".join(traceback.format_exception(exc)))
    name = f"crash-{time.strftime('%Y%m%d-%H%M%S')}-{os.getpid()}.txt"
    for folder in (reports_dir(), Path(tempfile.gettempdir())):
        try:
            folder.mkdir(parents=True, exist_ok=True)
            path = folder / name
            path.write_text(text, encoding="utf-8")
            return path
        except OSError:
            continue
    return None


@contextmanager
def _one_line_warnings() -> Iterator[None]:
    def show(message: Any, category: type, filename: str, lineno: int, file: Any = None, line: Any = None) -> None:
        print(f"forte: warning: {category.__name__}: {one_line(str(message))}", file=sys.stderr)

    with warnings.catch_warnings():
        warnings.showwarning = show
        yield


def thread_defaults() -> None:
    """Apply :data:`THREAD_DEFAULTS` where the environment leaves them unset, before the
    libraries that read them are loaded (later they would only reach child processes)."""
    if "numpy" in sys.modules or "casadi" in sys.modules:
        return
    for name, value in THREAD_DEFAULTS.items():
        os.environ.setdefault(name, value)


def main(argv: Sequence[str] | None = None) -> int:
    thread_defaults()
    argv = list(sys.argv[1:] if argv is None else argv)
    with _one_line_warnings():
        try:
            return _run(argv)
        except UsageError as exc:
            _error(str(exc))
            return EXIT_USAGE
        except ForteError as exc:
            _error(str(exc))
            return EXIT_USAGE
        except SystemExit as exc:  # --help, --version
            return exc.code if isinstance(exc.code, int) else (0 if exc.code is None else EXIT_USAGE)
        except KeyboardInterrupt:
            print("forte: interrupted", file=sys.stderr)
            return 130
        except BrokenPipeError:  # `forte ... | head`: the reader left
            return EXIT_OK
        except Exception as exc:  # noqa: BLE001 - the contract: no raw traceback, a saved report
            report = crash_report(exc, argv)
            where = f"traceback saved to {report}" if report else "no report could be saved"
            print(f"forte: internal error: {type(exc).__name__}: {one_line(str(exc))[:300]} "
                  f"(a bug in forte; {where})", file=sys.stderr, flush=True)
            return EXIT_BUG


def _run(argv: list[str]) -> int:
    parser = build_parser()
    if not argv:
        sys.stderr.write(parser.format_usage())
        raise UsageError("no command given; expected one of the commands above (see 'forte --help')")
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        sys.stderr.write(parser.format_usage())
        raise UsageError("no command given; expected one of the commands above (see 'forte --help')")
    # progress (rich) on standard error when it is a terminal and --quiet is not given
    with progress.activate(progress.for_cli(quiet=bool(getattr(args, "quiet", False)))):
        return int(args.func(args) or 0)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
