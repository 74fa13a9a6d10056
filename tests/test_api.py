"""The public API: ``import forte`` exposes what a user needs; every docstring example runs."""

from __future__ import annotations

import doctest
import importlib
from pathlib import Path

import pytest

import forte

ROOT = Path(__file__).resolve().parents[1]
DOCUMENTED = ("load_task", "plan", "compare", "default_robot", "residual_force_polytope", "capability_margin",
              "simulate", "estimate_payload")


def test_every_public_name_resolves():
    for name in forte.__all__:
        assert getattr(forte, name) is not None, name
    with pytest.raises(AttributeError):
        forte.no_such_name  # noqa: B018


@pytest.mark.parametrize("name", DOCUMENTED)
def test_docstring_examples_run(name, monkeypatch):
    monkeypatch.chdir(ROOT)  # the examples read examples/tasks/*.yaml
    obj = getattr(forte, name)
    tests = doctest.DocTestFinder().find(obj, name, globs={})
    assert tests and any(t.examples for t in tests), f"{name} has no docstring example"
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS)
    for test in tests:
        runner.run(test)
    assert runner.summarize(verbose=False).failed == 0


def test_package_docstring_example_runs(monkeypatch):
    monkeypatch.chdir(ROOT)
    assert doctest.testmod(forte).failed == 0


def test_import_is_lazy():
    """``import forte`` does not load the solver stack (the CLI's start-up time depends on it)."""
    import subprocess
    import sys

    code = "import sys, forte; print(any(m.startswith(('casadi', 'mujoco', 'matplotlib')) for m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "False"


def test_no_docstring_cites_files_outside_the_repository():
    for path in (ROOT / "src" / "forte").rglob("*.py"):
        text = path.read_text()
        assert "shared/" not in text and "NOTES.md" not in text and "AUTHORS_SETUP" not in text, path


def test_stage_packages_import_only_downwards():
    """The folder tree is the data flow: a stage never imports a later one."""
    order = ["model", "force", "capability", "planning", "io", "execution", "experiments", "cli"]
    for rank, stage in enumerate(order):
        for path in (ROOT / "src" / "forte" / stage).rglob("*.py"):
            text = path.read_text()
            for later in order[rank + 1:]:
                assert f"from forte.{later}" not in text and f"import forte.{later}" not in text, (path, later)
    importlib.import_module("forte.cli")
