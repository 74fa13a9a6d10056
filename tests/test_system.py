"""forte.system: the CPUs this process may use, and the one-thread environment."""

from __future__ import annotations

import ast
import os
from pathlib import Path

import pytest

from forte import system

SYSTEM = Path(__file__).resolve().parents[1] / "src" / "forte" / "system.py"


@pytest.mark.skipif(not hasattr(os, "sched_getaffinity"), reason="no affinity mask on this OS")
def test_cpu_count_is_the_affinity_mask():
    assert system.cpu_count() == len(os.sched_getaffinity(0))


def test_cpu_count_follows_a_narrower_mask(monkeypatch: pytest.MonkeyPatch):
    monkeypatch.setattr(system.os, "sched_getaffinity", lambda pid: {3}, raising=False)
    monkeypatch.setattr(system.os, "cpu_count", lambda: 64)
    assert system.cpu_count() == 1


def test_cpu_count_without_a_mask_is_the_machines(monkeypatch: pytest.MonkeyPatch):
    monkeypatch.delattr(system.os, "sched_getaffinity", raising=False)
    monkeypatch.setattr(system.os, "cpu_count", lambda: 6)
    assert system.cpu_count() == 6
    monkeypatch.setattr(system.os, "cpu_count", lambda: None)  # undeterminable
    assert system.cpu_count() == 1


def test_one_thread_per_library():
    assert system.SINGLE_THREAD_ENV == {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}


def test_system_imports_nothing_of_forte():
    """The lowest level: every stage may import it, so it imports none."""
    for node in ast.walk(ast.parse(SYSTEM.read_text())):
        names = [a.name for a in node.names] if isinstance(node, ast.Import) else (
            [node.module or ""] if isinstance(node, ast.ImportFrom) else [])
        assert not any(n == "forte" or n.startswith("forte.") for n in names), names
