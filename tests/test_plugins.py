"""Third-party methods and cost terms through the ``forte.plugins`` entry-point group: a package
made here (a real ``.dist-info`` with ``entry_points.txt`` on the path, discovered by
``importlib.metadata`` as pip-installed packages are) adds a term and a method, and they appear in
``forte plan --method``'s choices, plan, and reach ``forte compare``; a broken plugin is one
notice and forte goes on."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
FORTE = str(Path(sys.executable).parent / "forte")

PLUGIN = '''
from dataclasses import dataclass
from typing import ClassVar

import casadi as ca

from forte.planning.terms.costs import CostTerm, register_term
from forte.planning.methods.catalog import Method, MethodStyle, register_method


@dataclass(frozen=True)
class ArmAcceleration(CostTerm):
    """1/2 ||q_a,k - 2 q_a,k-1 + q_a,k-2||^2 / dt^4: a third party's smoothness term."""

    name: ClassVar[str] = "arm_acceleration_demo"

    def stage(self, s):
        i = slice(3, s.robot.nq)
        return 0.5 * ca.sumsqr(s.q0[i] - 2 * s.q1[i] + s.q2[i]) / s.dt0**4


def register():
    register_term(ArmAcceleration)
    register_method(Method("smooth-demo", "manipulability plus a third party's arm acceleration term",
                           terms=("manipulability", "joint_limits", "arm_acceleration_demo"),
                           weights={"arm_acceleration_demo": 1e-4},
                           style=MethodStyle("tab:pink", "smooth (plugin)"), source="tests/test_plugins.py"))
'''


def _install(site: Path, name: str, module: str, target: str) -> None:
    """A minimal installed distribution: the module and its dist-info with the entry point."""
    (site / f"{module}.py").write_text(PLUGIN if target.endswith(":register") and "broken" not in name else
                                       "def register():\n    raise RuntimeError('this plugin is broken')\n")
    info = site / f"{name.replace('-', '_')}-0.1.dist-info"  # as pip names it (the name normalized)
    info.mkdir()
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {name}\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(f"[forte.plugins]\n{name} = {target}\n")


def _run(args: list[str], site: Path, cwd: Path) -> subprocess.CompletedProcess:
    env = os.environ | {"PYTHONPATH": os.pathsep.join([str(site), os.environ.get("PYTHONPATH", "")])}
    return subprocess.run([FORTE, *args], cwd=cwd, env=env, capture_output=True, text=True, check=False)


@pytest.fixture()
def site(tmp_path: Path) -> Path:
    folder = tmp_path / "site"
    folder.mkdir()
    _install(folder, "forte-smooth-demo", "forte_smooth_demo", "forte_smooth_demo:register")
    return folder


def test_a_plugin_method_appears_on_the_command_line_and_plans(site, tmp_path):
    help_text = _run(["plan", "--help"], site, tmp_path).stdout
    assert "smooth-demo" in help_text
    out = tmp_path / "plan"
    proc = _run(["plan", str(ROOT / "examples" / "tasks" / "lift.yaml"), "--method", "smooth-demo",
                 "--out", str(out), "--no-figures", "--waypoints", "21", "--allow-infeasible"], site, tmp_path)
    assert proc.returncode == 0, proc.stderr
    doc = json.loads((out / "plan.json").read_text())
    assert doc["method"] == "smooth-demo"
    assert "arm_acceleration_demo" in doc["solver"]["cost_terms"]  # the plugin's own term was optimized
    assert doc["solver"]["term_weights"]["arm_acceleration_demo"] == pytest.approx(1e-4)


def test_without_the_plugin_the_method_is_unknown(tmp_path):
    empty = tmp_path / "empty"
    empty.mkdir()
    proc = _run(["plan", str(ROOT / "examples" / "tasks" / "lift.yaml"), "--method", "smooth-demo"], empty, tmp_path)
    assert proc.returncode == 2 and "smooth-demo" in proc.stderr


def test_a_broken_plugin_is_one_notice_and_forte_goes_on(site, tmp_path):
    _install(site, "forte-broken-demo", "forte_broken_demo", "forte_broken_demo:register")
    proc = _run(["plan", "--help"], site, tmp_path)
    assert proc.returncode == 0
    notice = "plugin 'forte-broken-demo' (forte_broken_demo:register) skipped: RuntimeError: this plugin is broken"
    assert notice in proc.stderr
    assert "smooth-demo" in proc.stdout  # the good plugin still loads
