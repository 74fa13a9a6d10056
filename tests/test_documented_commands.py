"""Every command the README and the docs show works as written.

Each ```bash / ```sh / ```console block of README.md and docs/**/*.md is a recipe. Its lines
(backslash continuations joined, ``$ `` prompts of console blocks removed) run one after the
other, each in its own ``bash`` with ``set -e -o pipefail``, in a fresh directory laid out like
the repository root (copies of ``examples/``, ``docs/``, ``benchmarks/``): a block must work when
pasted on its own into a fresh clone, and nothing it writes lands in the repository.

Expected exit code: 0, unless the line's comment says otherwise, in words a reader understands
too: ``forte simulate runs/x --true-mass 2.7   # exits 1: joint 2 saturates``.

Not run (each listed as a skipped test item with its reason, never silently): the parts of a
line in :data:`NOT_RUN` (environment set-up, CI's own lint and test steps, commands that need a
service the test machine lacks), split at ``&&``.

Small N: the default run (``pytest -q``, ~2.5 min on 2 cores) applies :data:`REDUCED`, the one
list of changes to documented commands, and leaves the blocks of :data:`FULL_ONLY` out, each with
its reason; ``pytest -m docs_full`` runs every block exactly as written (~15 min; deselected by
default like the fuzz suite).
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCUMENTS = ["README.md", *sorted(str(p.relative_to(ROOT)) for p in (ROOT / "docs").rglob("*.md"))]
SHELLS = ("bash", "sh", "shell", "console")
#: Copied into each block's working directory (the repository root, as a reader has it).
TREE = ("examples", "docs", "benchmarks")
#: Per documented line; the whole experiments' loop, as written, takes minutes.
TIMEOUT_S = 1800

#: Parts of documented lines that are not run: (regex on the part, reason).
NOT_RUN: list[tuple[str, str]] = [
    (r"python3? -m venv \S+", "environment set-up, done before the tests run"),
    (r"(\.|source) \S*\.venv/bin/activate", "environment set-up, done before the tests run"),
    (r"pip install .*", "environment set-up, done before the tests run"),
    (r"ruff check .*", "CI's own lint step, .ci/run"),
    (r"pytest( .*)?", "CI's own test step, .ci/run: the suite cannot run itself"),
    (r"forte sweep \S+ --ray auto", "needs a Ray cluster already running on this node: ray start --head"),
]

#: The default run's changes to documented commands, in one place: (documented text, text
#: appended after it, reason). ``pytest -m docs_full`` runs the commands as written.
REDUCED: list[tuple[str, str, str]] = [
    ("forte experiment hold --weights authors-hold-as-run --out runs/experiments/hold-as-run",
     "--trials 1 --no-weight-sweep", "~1 min with 3 trials and the weight sweep"),
    ("forte experiment lift --torque-limits urdf --out runs/experiments/lift-urdf-limits",
     "--trials 1 --no-weight-sweep",
     "3 trials and the weight sweep, with the hold below ~3.4 min of the suite on 2 cores; "
     "test_experiments.py runs the URDF limits' hold too"),
    ("forte experiment hold --torque-limits urdf --out runs/experiments/hold-urdf-limits",
     "--trials 1 --no-weight-sweep",
     "3 trials and the weight sweep; one trial here"),
    ("forte experiment wrench --out runs/experiments/wrench", "--offsets 0.2",
     "18 plans and 36 MuJoCo runs, ~1.2 min on 2 cores; the 0.2 m offset here (test_wrench_experiment.py runs it too)"),
    ("forte experiment base --out runs/experiments/base", "--quick",
     "19 plans and floor-base runs, 61 s on 2 cores; each task's heaviest payload, one base-mode task here (23 s)"),
    ("forte sweep examples/sweeps/lift.yaml --workers 8", "--dry-run",
     "50 cells, ~80 s on 2 cores; the demo sweep of the same page computes its grid"),
    ("forte sweep examples/sweeps/mass-scan.yaml --ray", "--dry-run",
     "72 cells, ~95 s on 2 cores; Ray itself is tested in test_sweep.py"),
    ("python benchmarks/verdict_vs_mujoco.py", "--tasks hold --masses 2.7 --workers 1",
     "78 plans and runs, ~2.5 min on 2 cores; one case of the table here"),
    ("python benchmarks/scene_vs_mujoco.py", "--tasks around-the-crate --methods forte quintic --workers 1",
     "42 plans and runs, ~2 min on 2 cores; four rows of the table here"),
    ("python benchmarks/feasibility_matrix.py --quick --out runs/feasibility-quick", "--robots ur5 ur5-urdf",
     "20 plans and runs, ~1 min on 2 cores; a preset and its raw URDF here"),
    ("python benchmarks/feasibility_matrix.py --samples 21 --out runs/feasibility-n21",
     "--robots ur5 ur5-urdf --kinds forward --sizes 0.1 --payloads 0.5",
     "360 plans and runs, ~6 min on 2 cores; one task on a preset and its raw URDF here"),
    ("python benchmarks/feasibility_matrix.py --samples 41 --out runs/feasibility-n41",
     "--robots ur5 ur5-urdf --kinds forward --sizes 0.1 --payloads 0.5",
     "360 plans and runs, ~10 min on 2 cores; one task on a preset and its raw URDF here"),
]

#: Blocks the default run leaves to ``-m docs_full``: (document, text of one of its commands, reason).
FULL_ONLY: list[tuple[str, str, str]] = [
    ("docs/experiments/README.md", "for e in continuous lift hold replan; do forte experiment",
     "regenerates the four experiments as published: ~8 min on 2 cores; test_experiments.py runs each "
     "small, and the hold-as-run block of the same page runs here with one trial"),
]

EXPECTED = re.compile(r"#\s*exits\s+(\d+)\b")


@dataclass
class Block:
    document: str
    line: int  # of the opening fence, 1-based
    commands: list[tuple[str, int]] = field(default_factory=list)  # (command, expected exit code)
    not_run: list[tuple[str, str]] = field(default_factory=list)  # (part, reason)

    @property
    def id(self) -> str:
        return f"{self.document}:{self.line}"


def _logical_lines(lines: list[str], console: bool) -> list[str]:
    out: list[str] = []
    pending = ""
    for raw in lines:
        text = raw.rstrip()
        if console:
            if not (pending or text.startswith("$ ")):
                continue  # output shown in a console block
            text = text[2:] if not pending else text
        if pending:
            text = text.lstrip()
        if text.endswith("\\"):
            pending += text[:-1].rstrip() + " "
            continue
        out.append((pending + text).strip())
        pending = ""
    return [line for line in out if line and not line.startswith("#")]


def _split_and(line: str) -> list[str]:
    """``a && b && c`` -> its parts (no documented line has ``&&`` inside quotes)."""
    return [part.strip() for part in line.split("&&")]


def _not_run_reason(part: str) -> str | None:
    code = part.split(" #")[0].strip()
    for pattern, reason in NOT_RUN:
        if re.fullmatch(pattern, code):
            return reason
    return None


def parse(document: str) -> list[Block]:
    """The shell blocks of ``document`` with their commands, expected exit codes and parts not run."""
    lines = (ROOT / document).read_text(encoding="utf-8").splitlines()
    blocks: list[Block] = []
    i = 0
    while i < len(lines):
        m = re.fullmatch(r"\s*```\s*(\w*)\s*", lines[i])
        if not m:
            i += 1
            continue
        end = next(j for j in range(i + 1, len(lines)) if lines[j].strip().startswith("```"))
        if m.group(1) in SHELLS:
            block = Block(document, i + 1)
            for line in _logical_lines(lines[i + 1:end], console=m.group(1) == "console"):
                expected = EXPECTED.search(line)
                run = []
                for part in _split_and(line):
                    reason = _not_run_reason(part)
                    if reason:
                        block.not_run.append((part.split(" #")[0].strip(), reason))
                    else:
                        run.append(part)
                if run:
                    block.commands.append((" && ".join(run), int(expected.group(1)) if expected else 0))
            blocks.append(block)
        i = end + 1
    return blocks


BLOCKS = [block for document in DOCUMENTS for block in parse(document)]


def reduced(command: str) -> str:
    for text, extra, _ in REDUCED:
        command = command.replace(text, f"{text} {extra}")
    return command


def _full_only(block: Block) -> str | None:
    for document, text, reason in FULL_ONLY:
        if block.document == document and any(text in c for c, _ in block.commands):
            return reason
    return None


def _params(full: bool) -> list:
    params = []
    for b in BLOCKS:
        if not b.commands:
            continue
        reason = _full_only(b)
        marks = [pytest.mark.docs_full] if full else \
            [pytest.mark.skip(reason=f"{b.id} runs with -m docs_full only: {reason}")] if reason else []
        params.append(pytest.param(b, id=b.id, marks=marks))
    return params


def _workdir(tmp_path: Path) -> Path:
    for name in TREE:
        shutil.copytree(ROOT / name, tmp_path / name, ignore=shutil.ignore_patterns("__pycache__"))
    return tmp_path


def _env(tmp_path: Path) -> dict[str, str]:
    bindir = Path(sys.executable).parent  # the environment the tests run in: its forte, its python
    env = {**os.environ, "PATH": f"{bindir}{os.pathsep}{os.environ.get('PATH', '')}", "MPLBACKEND": "Agg",
           "FORTE_REPORTS": str(tmp_path / "reports")}
    env.pop("PYTHONPATH", None)
    return env


def _run_block(block: Block, tmp_path: Path, full: bool) -> None:
    cwd = _workdir(tmp_path / "root")
    env = _env(tmp_path)
    for command, expected in block.commands:
        line = command if full else reduced(command)
        proc = subprocess.run(["bash", "-c", f"set -e -o pipefail\n{line}"], cwd=cwd, env=env, text=True,
                              stdout=subprocess.PIPE, stderr=subprocess.STDOUT, timeout=TIMEOUT_S)
        assert proc.returncode == expected, (
            f"{block.id}: `{line}` exited {proc.returncode}, the document says {expected} "
            f"(annotate '# exits N: why' if intended)\n{proc.stdout[-4000:]}")


@pytest.mark.parametrize("block", _params(full=False))
def test_documented_block(block: Block, tmp_path: Path) -> None:
    _run_block(block, tmp_path, full=False)


@pytest.mark.parametrize("block", _params(full=True))
def test_documented_block_as_written(block: Block, tmp_path: Path) -> None:
    _run_block(block, tmp_path, full=True)


@pytest.mark.parametrize("block", [pytest.param(b, id=b.id) for b in BLOCKS if b.not_run])
def test_documented_lines_not_run(block: Block) -> None:
    pytest.skip(f"{block.id} not run: " + "; ".join(f"`{part}` ({reason})" for part, reason in block.not_run))


def test_the_lists_match_the_documents() -> None:
    """Every documented shell block is found, and every entry of REDUCED and NOT_RUN is used."""
    documented = [c for b in BLOCKS for c, _ in b.commands]
    assert {b.document for b in BLOCKS} >= {"README.md", "docs/index.md", "docs/sweeps.md"}
    for text, _, _ in REDUCED:
        assert any(text in c for c in documented), f"REDUCED: '{text}' is no longer documented"
    for document, text, _ in FULL_ONLY:
        assert any(b.document == document and _full_only(b) for b in BLOCKS), \
            f"FULL_ONLY: '{text}' is no longer documented in {document}"
    parts = [p for b in BLOCKS for p, _ in b.not_run]
    for pattern, _ in NOT_RUN:
        assert any(re.fullmatch(pattern, p) for p in parts), f"NOT_RUN: '{pattern}' matches no documented line"


def test_parser_reads_annotations_continuations_and_prompts(tmp_path: Path, monkeypatch) -> None:
    doc = tmp_path / "d.md"
    doc.write_text("text\n```bash\n# a comment\npython3 -m venv .venv && . .venv/bin/activate && forte demo\n"
                   "forte plan x \\\n  --out y   # exits 1: infeasible\n```\n```console\n$ forte demo\noutput\n```\n"
                   "```yaml\nforte: no\n```\n")
    monkeypatch.setattr(sys.modules[__name__], "ROOT", tmp_path)
    blocks = parse("d.md")
    assert [b.line for b in blocks] == [2, 8]
    assert blocks[0].commands == [("forte demo", 0), ("forte plan x --out y   # exits 1: infeasible", 1)]
    assert [p for p, _ in blocks[0].not_run] == ["python3 -m venv .venv", ". .venv/bin/activate"]
    assert blocks[1].commands == [("forte demo", 0)]
