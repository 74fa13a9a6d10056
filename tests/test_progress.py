"""Progress: captured from a real plan (forced on), silent by default, under --quiet and off a terminal."""

from __future__ import annotations

import io
import re
from pathlib import Path

import pytest

from forte import progress
from forte.cli.main import main
from forte.planning.nlp.optimizer import TrajectoryOptimizer
from forte.planning.planner import plan
from forte.planning.tasks.tasks import load_task

LIFT = Path(__file__).resolve().parents[1] / "examples" / "tasks" / "lift.yaml"
ANSI = re.compile(r"\x1b\[[0-9;?]*[A-Za-z]")


def _reporter() -> tuple[progress.Reporter, io.StringIO]:
    buf = io.StringIO()
    return progress.Reporter(buf, force_terminal=True, width=160), buf


def test_plan_reports_ipopt_iterations() -> None:
    reporter, buf = _reporter()
    task = load_task(LIFT, waypoints=12)
    with progress.activate(reporter):
        res = plan(task, "forte")
    out = ANSI.sub("", buf.getvalue())
    assert res.solved
    assert "done: solving with IPOPT (forte, N = 12)" in out
    first = re.search(r"IPOPT iteration 0: objective ([-0-9.e+]+), constraint violation ([0-9.e+-]+)", out)
    assert first is not None, out
    assert float(first.group(2)) >= 0.0
    # the current iterate's exact capability margin, which ends at the plan's own min d
    margins = [float(v) for v in re.findall(r"min d (-?[0-9.]+) N", out)]
    assert margins and abs(margins[-1] - float(res.metrics["d"].min())) < 0.01


def test_step_shows_expected_time_and_leaves_one_line() -> None:
    reporter, buf = _reporter()
    with progress.activate(reporter), progress.step("compiling the forte kernels", expected_s=10):
        progress.update("halfway")
    out = ANSI.sub("", buf.getvalue())
    assert "compiling the forte kernels (0 s of about 10 s)" in out
    assert re.search(r"done: compiling the forte kernels \(\d+\.\d s\)", out)
    with pytest.raises(RuntimeError), progress.activate(reporter), progress.step("failing"):
        raise RuntimeError("boom")
    assert "stopped: failing" in ANSI.sub("", buf.getvalue())


def test_library_is_silent_by_default(robot) -> None:
    assert progress.active() is None
    opt = TrajectoryOptimizer(robot, 3, "forte")
    assert opt._progress is None  # no iteration callback installed
    with progress.step("nothing"):  # a no-op without a reporter
        progress.update("ignored")


def test_cli_progress_off_when_quiet_or_not_a_terminal(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    class Tty(io.StringIO):
        def isatty(self) -> bool:
            return True

    assert progress.for_cli(quiet=True, file=Tty()) is None
    assert progress.for_cli(quiet=False, file=io.StringIO()) is None
    assert isinstance(progress.for_cli(quiet=False, file=Tty()), progress.Reporter)
    assert main(["plan", str(LIFT), "--waypoints", "8", "--no-figures", "--out", str(tmp_path / "p"),
                 "--allow-infeasible", "--no-bound"]) == 0
    err = capsys.readouterr().err
    assert "IPOPT iteration" not in err and "done:" not in err  # captured stderr is not a terminal
