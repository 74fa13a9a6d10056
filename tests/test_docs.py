"""The API reference builds from the docstrings with warnings as errors (MkDocs + mkdocstrings)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_docs_build_strictly(tmp_path):
    command = [sys.executable, "-m", "mkdocs", "build", "--strict", "-q", "-d", str(tmp_path / "site")]
    proc = subprocess.run(command, cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    api = (tmp_path / "site" / "api" / "planning" / "index.html").read_text()
    for name in ("register_method", "register_term", "TrajectoryOptimizer", "Replanner"):
        assert name in api
    assert "tutorial.py" in (tmp_path / "site" / "tutorial" / "index.html").read_text() or \
        "register_term" in (tmp_path / "site" / "tutorial" / "index.html").read_text()
