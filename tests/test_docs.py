"""The API reference builds from the docstrings with warnings as errors (MkDocs + mkdocstrings)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_docs_build_strictly(tmp_path):
    # no -q: mkdocs' --quiet raises its logger to ERROR, so warnings are never logged, never
    # counted, and --strict passes with any number of them
    command = [sys.executable, "-m", "mkdocs", "build", "--strict", "-d", str(tmp_path / "site")]
    proc = subprocess.run(command, cwd=ROOT, capture_output=True, text=True, timeout=300)
    output = proc.stdout + proc.stderr
    assert proc.returncode == 0, output
    warnings = [line for line in output.splitlines() if line.startswith(("WARNING", "ERROR"))]
    assert not warnings, "\n".join(warnings)
    api = (tmp_path / "site" / "api" / "planning" / "index.html").read_text()
    for name in ("register_method", "register_term", "TrajectoryOptimizer", "Replanner"):
        assert name in api
    assert "tutorial.py" in (tmp_path / "site" / "tutorial" / "index.html").read_text() or \
        "register_term" in (tmp_path / "site" / "tutorial" / "index.html").read_text()
