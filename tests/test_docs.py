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


def _table_rows(text: str, header: str) -> dict[str, list[str]]:
    """The rows of the Markdown table whose header starts with ``header``: first cell -> cells."""
    lines = text.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith(header))
    rows = {}
    for line in lines[start + 2:]:
        if not line.startswith("|"):
            break
        cells = [c.strip() for c in line.strip("|").split("|")]
        rows[cells[0].strip("`")] = cells
    return rows


_REGISTRIES = """
import json
from forte.model.presets import ROBOT_PRESETS
from forte.planning.methods.catalog import METHODS
from forte.planning.terms.costs import COST_TERMS
from forte.planning.verdict.verdict import REQUIREMENTS
print(json.dumps({"terms": {n: [c.kind, [s.name for s in c.settings]] for n, c in COST_TERMS.items()},
                  "methods": list(METHODS), "requirements": [r.name for r in REQUIREMENTS],
                  "presets": list(ROBOT_PRESETS)}))
"""


def test_the_docs_name_what_the_registries_hold():
    """Built-in terms (with their settings), methods, requirements and presets, as the pages list them
    (the registries read in a fresh interpreter: other tests register toy terms and methods)."""
    import json

    out = subprocess.run([sys.executable, "-c", _REGISTRIES], capture_output=True, text=True, check=True, timeout=120)
    built_in = json.loads(out.stdout)
    docs = ROOT / "docs"
    methods_page = (docs / "methods.md").read_text()
    terms = _table_rows(methods_page, "| term |")
    assert set(terms) == set(built_in["terms"])
    for name, (kind, settings) in built_in["terms"].items():
        listed = [s.strip("` ") for s in terms[name][2].split(",")] if terms[name][2] != "-" else []
        assert listed == settings and terms[name][1] == kind, name
    assert set(_table_rows(methods_page, "| method |")) == set(built_in["methods"])
    verdict_page, trouble = (docs / "verdict.md").read_text(), (docs / "troubleshooting.md").read_text()
    for name in built_in["requirements"]:
        assert f"**{name}**" in verdict_page and f"`{name}`" in trouble, name
    robots_page = (docs / "robots.md").read_text()
    assert all(f"`{name}`" in robots_page for name in built_in["presets"])
