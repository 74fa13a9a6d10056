"""``forte schema``: the task file's JSON Schema (or, with ``--markdown``, its reference page)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "schema", help="print the task file's JSON Schema (editors validate task files with it)",
        description="Print the JSON Schema (draft 2020-12) of a task file, generated from forte's description of "
        "every task-file field; with --markdown, the task-file reference page (docs/task-files.md) instead. "
        "In an editor with the YAML language server, a task file's first line "
        "'# yaml-language-server: $schema=PATH/task.schema.json' checks it as you type.")
    p.add_argument("--out", type=Path, metavar="FILE",
                   help="write to FILE instead of printing (a new file, or one 'forte schema' wrote)")
    p.add_argument("--markdown", action="store_true", help="the reference page (Markdown tables) instead")
    p.set_defaults(func=run_schema)


def run_schema(args: argparse.Namespace) -> int:
    from forte.io.task_schema import check_schema_out, json_schema, markdown, write

    if args.out is not None:
        check_schema_out(args.out)  # before the registry is loaded: a bad path is one line at once
    text = markdown() if args.markdown else json.dumps(json_schema(), indent=2) + "\n"
    if args.out is None:
        sys.stdout.write(text)
        return 0
    write(args.out, text)
    print(f"wrote {args.out}", file=sys.stderr)
    return 0
