"""Figures: every format, method colours from the registry, the force ball's slice, grouped hold bars."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from forte.exceptions import InvalidInputError
from forte.io.figures import (
    figure_format,
    plan_figures,
    plot_comparison,
    pyplot,
    slice_polygon,
    style,
)
from forte.planning.methods.catalog import METHODS
from forte.planning.planner import plan
from forte.planning.tasks.tasks import load_task

LIFT = Path(__file__).resolve().parents[1] / "examples" / "tasks" / "lift.yaml"


@pytest.fixture(scope="module")
def quintic():
    return plan(load_task(LIFT, waypoints=8), "quintic")


@pytest.mark.parametrize("fmt", ["png", "pdf", "svg"])
def test_plan_figures_in_each_format(quintic, tmp_path: Path, fmt: str) -> None:
    with figure_format(fmt):
        plan_figures(quintic, tmp_path)
    names = sorted(p.name for p in tmp_path.iterdir())
    assert names == sorted(f"{s}.{fmt}" for s in ("capacity", "manipulability", "rfp_worst", "ellipsoid"))
    head = (tmp_path / f"capacity.{fmt}").read_bytes()[:8]
    assert head.startswith({"png": b"\x89PNG", "pdf": b"%PDF", "svg": b"<?xml"}[fmt])


def test_unknown_format_is_refused() -> None:
    with pytest.raises(InvalidInputError, match="--format: expected one of png, pdf, svg"), figure_format("jpg"):
        pass


def test_colours_come_from_the_registry() -> None:
    for name, method in METHODS.items():
        assert style(name) == (method.style.color, method.style.label)


def test_slice_of_a_box() -> None:
    A = np.vstack([np.eye(3), -np.eye(3)])
    b = np.array([1.0, 2.0, 3.0, 1.0, 2.0, 3.0])
    poly = slice_polygon(A, b, np.zeros(3), np.array([1.0, 0, 0]), np.array([0, 0, 1.0]))
    assert sorted(map(tuple, np.round(poly, 9))) == [(-1, -3), (-1, 3), (1, -3), (1, 3)]


def test_hold_comparison_has_no_joining_lines(quintic, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    task = load_task(Path(__file__).resolve().parents[1] / "examples" / "tasks" / "hold.yaml")
    results = [plan(task, "teaching")]
    results.append(results[0])
    plt = pyplot()
    figures = []
    monkeypatch.setattr(plt, "close", figures.append)
    plot_comparison(results, tmp_path / "comparison.png")
    (fig,) = figures
    for ax in fig.axes:
        for line in ax.get_lines():  # only horizontal reference lines, no line through categories
            assert np.ptp(np.asarray(line.get_ydata(), dtype=float)) == 0


SPLIT = """
import os, sys
from pathlib import Path
from forte.io.figure_processes import can_fork, run_split
out, parent = Path(sys.argv[1]), os.getpid()

def mark(name, fail_in_child=False):
    def call():
        if fail_in_child and os.getpid() != parent:
            raise RuntimeError("fails in the child only")
        (out / name).write_text(str(os.getpid()))
    return call

def boom():
    raise ValueError("bad figure")

groups = {"ok": [[mark("a")], [mark("b"), mark("c")]], "child-fails": [[mark("a")], [mark("b", True)]],
          "error": [[mark("a")], [boom]]}[sys.argv[2]]
try:
    run_split(groups, fork=True)
except ValueError as exc:
    print("raised", exc)
print("parent", parent, "fork", can_fork())
"""


def _split(tmp_path: Path, case: str) -> tuple[dict[str, int], str]:
    """Run ``run_split`` in a fresh process (single-threaded BLAS: no other thread, so it can fork)."""
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", PYTHONPATH=str(Path(__file__).resolve().parents[1] / "src"))
    out = subprocess.run([sys.executable, "-c", SPLIT, str(tmp_path), case], env=env, capture_output=True,
                         text=True, check=True).stdout
    return {p.name: int(p.read_text()) for p in tmp_path.iterdir()}, out


def test_run_split_runs_the_other_groups_in_a_child(tmp_path: Path) -> None:
    pids, out = _split(tmp_path, "ok")
    parent, forked = int(out.split()[-3]), out.split()[-1] == "True"
    assert pids["a"] == parent and pids["b"] == pids["c"]
    assert (pids["b"] != parent) == forked
    if sys.platform.startswith("linux") and len(os.sched_getaffinity(0)) > 1:
        assert forked  # nothing else runs in that process: it forks


def test_a_group_that_fails_in_the_child_runs_again_here(tmp_path: Path) -> None:
    pids, out = _split(tmp_path, "child-fails")
    assert pids["b"] == int(out.split()[-3])


def test_an_error_of_a_group_is_raised_here(tmp_path: Path) -> None:
    pids, out = _split(tmp_path, "error")
    assert "raised bad figure" in out and pids["a"] == int(out.split()[-3])


WORKER = """
import os, sys
from pathlib import Path
from forte.io import figures
from forte.io.figure_processes import can_fork
from forte.io.figure_worker import FigureWorker, draw_plan_figures, figure_worker
from forte.io.figures import figure_format
from forte.model.robot import default_robot
from forte.planning.planner import plan
from forte.planning.tasks.tasks import load_task

out, case, parent = Path(sys.argv[1]), sys.argv[2], os.getpid()
quintic = plan(load_task(sys.argv[3], waypoints=8), "quintic")
print("fork", can_fork())
answers = []  # what FigureWorker.draw returned: True only when the worker said it drew the files
draw = FigureWorker.draw
FigureWorker.draw = lambda self, *args: answers.append(draw(self, *args)) or answers[-1]
if case == "worker-fails":  # the worker's drawing fails (in the child only): this process draws
    plan_figures = figures.plan_figures
    def failing(*args):
        if os.getpid() != parent:
            raise RuntimeError("fails in the worker")
        plan_figures(*args)
    figures.plan_figures = failing
robot = default_robot(torque_limits=[1.0] * 7) if case == "other-robot" else quintic.robot
with figure_worker(robot, fork=True) as worker:
    pid = worker.pid if worker else None
    if case != "unused":
        with figure_format("svg"):
            draw_plan_figures(quintic, out)
        print("worker drew", answers == [True])
        print("asked", bool(answers), "used", worker is not None and worker.used)
print("reaped", pid is None or not os.path.exists(f"/proc/{pid}") or open(f"/proc/{pid}/stat").read().split()[2] == "Z")
"""


@pytest.mark.parametrize("case", ["ok", "other-robot", "unused", "worker-fails"])
def test_the_figure_worker_draws_the_plan_or_leaves_it_here(tmp_path: Path, case: str) -> None:
    """A worker forked before the plan draws its figures (same files as drawn here); for another
    robot's plan it steps aside; unused, it is stopped; when its drawing fails, they are drawn
    here; it is always reaped."""
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", PYTHONPATH=str(Path(__file__).resolve().parents[1] / "src"))
    out = subprocess.run([sys.executable, "-c", WORKER, str(tmp_path), case, str(LIFT)], env=env,
                         capture_output=True, text=True, check=True, timeout=300).stdout
    forked = "fork True" in out
    assert "reaped True" in out
    names = sorted(p.name for p in tmp_path.iterdir())
    if case == "unused":
        assert names == []
    else:
        assert names == sorted(f"{s}.svg" for s in ("capacity", "manipulability", "rfp_worst", "ellipsoid"))
        assert ("worker drew True" in out) == (forked and case == "ok")
        if forked and case == "worker-fails":  # asked and used, yet it did not draw
            assert "asked True used True" in out


@pytest.mark.parametrize(("load", "idle"), [(0.3, True), (1.4, True), (1.6, False), (4.0, False)])
def test_processes_only_with_an_idle_core(monkeypatch: pytest.MonkeyPatch, load: float, idle: bool) -> None:
    from forte.io import figure_processes

    monkeypatch.setattr(figure_processes, "cpu_count", lambda: 2)
    monkeypatch.setattr(figure_processes.os, "getloadavg", lambda: (load, 0.0, 0.0))
    assert figure_processes.idle_core() is idle


def _open_fds() -> int:
    return len(os.listdir("/proc/self/fd"))


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="/proc and fork: Linux")
def test_no_process_to_be_had_draws_here(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, quintic) -> None:
    """``fork`` failing (EAGAIN; a real failure cannot be provoked safely, so os.fork raises):
    run_split runs every group here, no worker starts, its pipes are closed, the figures are
    drawn here."""
    import errno

    from forte.io import figure_processes, figure_worker

    def no_fork() -> int:
        raise BlockingIOError(errno.EAGAIN, "Resource temporarily unavailable")

    monkeypatch.setattr(figure_processes, "can_fork", lambda: True)  # threads or not: nothing forks
    monkeypatch.setattr(figure_processes.os, "fork", no_fork)
    ran: list[tuple[str, int]] = []
    groups = [[lambda: ran.append(("a", os.getpid()))], [lambda: ran.append(("b", os.getpid())),
                                                         lambda: ran.append(("c", os.getpid()))]]
    figure_processes.run_split(groups, fork=True)
    assert ran == [("a", os.getpid()), ("b", os.getpid()), ("c", os.getpid())]
    before = _open_fds()
    assert figure_worker.FigureWorker(quintic.robot).pid == -1
    assert _open_fds() == before  # its pipes were closed
    with figure_worker.figure_worker(quintic.robot, fork=True) as worker:
        assert worker is None and figure_worker.take_worker() is None
        with figure_format("svg"):
            figure_worker.draw_plan_figures(quintic, tmp_path)
    assert _open_fds() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        f"{s}.svg" for s in ("capacity", "manipulability", "rfp_worst", "ellipsoid"))
