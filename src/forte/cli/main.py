"""The ``forte`` command line.

Each sub-command registers itself with ``register(subparsers)`` and sets ``func`` (``args ->
exit code``) as a parser default. Errors raised on purpose (:class:`forte.exceptions.ForteError`)
are printed as one line, ``forte: error: ...``, with exit code 2.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence

from forte import __version__, progress
from forte.exceptions import ForteError

#: Modules that add sub-commands (each has ``register(subparsers)``).
COMMAND_MODULES: tuple[str, ...] = (
    "forte.cli.demo",
    "forte.cli.plan",
    "forte.cli.estimation",
    "forte.cli.simulate",
    "forte.cli.experiment",
    "forte.cli.export",
    "forte.cli.view",
)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="forte",
        description="Plan whole-body trajectories of mobile manipulators with task-sufficient "
        "force capability (FORTE).",
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


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 1
    try:  # progress (rich) on standard error when it is a terminal and --quiet is not given
        with progress.activate(progress.for_cli(quiet=bool(getattr(args, "quiet", False)))):
            return int(args.func(args) or 0)
    except ForteError as exc:
        print(f"forte: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:  # pragma: no cover
        print("forte: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
