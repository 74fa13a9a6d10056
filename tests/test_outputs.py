"""Output directories: never lost, never foreign, crash-safe, serialized, umask-respecting."""

from __future__ import annotations

import json
import os
import stat
from pathlib import Path

import numpy as np
import pytest

import forte.io.outputs as outputs
from forte.cli.main import main
from forte.exceptions import OutputError
from forte.io.outputs import PARTIAL_MARKER, output_lock, recover_output, replace_directory
from forte.io.plandir import read_plan_dir, write_plan_dir

EXAMPLES = Path(__file__).resolve().parents[1] / "examples" / "tasks"
HOLD = ["plan", str(EXAMPLES / "hold.yaml"), "--method", "teaching", "--mass", "1", "--quiet", "--no-figures"]


def _plan(robot, out: Path, value: float = 0.0) -> Path:
    q = np.tile(robot.home(), (3, 1))
    q[:, 0] = value
    return write_plan_dir(out, robot, [0.0, 0.5, 1.0], q, mass=1.0, extra={"value": value})


def test_permissions_follow_the_umask(tmp_path, robot):
    old = os.umask(0o022)
    try:
        out = _plan(robot, tmp_path / "a" / "plan")
    finally:
        os.umask(old)
    assert stat.S_IMODE(out.stat().st_mode) == 0o755
    for f in out.iterdir():
        assert stat.S_IMODE(f.stat().st_mode) == 0o644, f
    assert stat.S_IMODE((tmp_path / "a").stat().st_mode) == 0o755


def test_replacement_leaves_nothing_beside_out(tmp_path, robot):
    out = tmp_path / "plan"
    for v in (1.0, 2.0, 3.0):
        _plan(robot, out, v)
    assert [p.name for p in tmp_path.iterdir()] == ["plan"]
    assert read_plan_dir(out).q[0, 0] == 3.0
    assert not (out / PARTIAL_MARKER).exists()


@pytest.mark.parametrize("exchange", [True, False])
def test_leftovers_of_killed_runs_are_cleaned_but_never_a_users_folder(tmp_path, robot, monkeypatch, exchange):
    if not exchange:  # the documented two-rename fallback
        monkeypatch.setattr(outputs, "_rename_exchange", lambda a, b: False)
    out = _plan(robot, tmp_path / "good", 1.0)
    half = tmp_path / ".good.forte-tmp-abc123"  # a writer killed while building
    half.mkdir()
    (half / PARTIAL_MARKER).touch()
    (half / "metrics.csv").write_text("t\n")
    old = tmp_path / ".good.forte-old-xyz"  # killed while deleting the replaced plan
    _plan(robot, tmp_path / "x", 0.5).rename(old)
    empty = tmp_path / ".good.forte-tmp-empty"  # killed right after mkdtemp
    empty.mkdir()
    users = tmp_path / ".good.forte-tmp-mine"  # same name pattern, but the user's files
    users.mkdir()
    (users / "notes.txt").write_text("mine")
    users_dot = tmp_path / ".good"  # a user's dot-folder
    users_dot.mkdir()
    (users_dot / "a").write_text("mine")
    _plan(robot, out, 2.0)
    assert sorted(p.name for p in tmp_path.iterdir()) == [".good", ".good.forte-tmp-mine", "good"]
    assert (users / "notes.txt").read_text() == "mine" and (users_dot / "a").read_text() == "mine"
    assert read_plan_dir(out).q[0, 0] == 2.0


def test_kill_between_the_two_renames_of_the_fallback_is_recovered(tmp_path, robot):
    out = _plan(robot, tmp_path / "good", 1.0)
    parked = tmp_path / ".good.forte-old-k1ll3d"  # fallback killed after out -> old, before tmp -> out
    os.rename(out, parked)
    (parked / PARTIAL_MARKER).touch()
    with output_lock(out):
        recover_output(out)
    assert read_plan_dir(out).q[0, 0] == 1.0 and [p.name for p in tmp_path.iterdir()] == ["good"]


def test_a_second_writer_waits_then_fails_clearly(tmp_path, monkeypatch, capsys):
    out = tmp_path / "plan"
    monkeypatch.setenv("FORTE_LOCK_TIMEOUT", "0.2")
    import subprocess
    import sys
    import time

    holder = subprocess.Popen([sys.executable, "-c", (
        "import sys, time; from pathlib import Path; from forte.io.plandir import output_lock\n"
        f"with output_lock(Path({str(out)!r})):\n    print('held', flush=True); time.sleep(30)")],
        stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "held"
        start = time.monotonic()
        with pytest.raises(OutputError, match="another forte process is writing it"):
            replace_directory(lambda d: None, out)
        assert time.monotonic() - start < 5
        assert main([*HOLD, "--out", str(out)]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "another forte process" in err
    finally:
        holder.kill()
        holder.wait()
    replace_directory(lambda d: (d / "summary.json").write_text(json.dumps({"generator": "forte"})), out)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["plan"]  # the lock file went with its holder


def test_lock_is_reentrant_and_removed(tmp_path):
    out = tmp_path / "o"
    with output_lock(out), output_lock(out):
        assert (tmp_path / ".o.forte-lock").exists()
    assert not (tmp_path / ".o.forte-lock").exists()


@pytest.mark.parametrize("bad", ["", ".", "..", "/proc/forte-out", "/proc/self/x/y", "afile/sub", "afile"])
def test_unusable_out_is_one_line_before_planning(tmp_path, monkeypatch, capsys, bad):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "afile").write_text("keep")
    assert main([*HOLD, "--out", bad]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("forte: error: --out"), err
    assert (tmp_path / "afile").read_text() == "keep"


def test_build_errors_keep_the_previous_plan(tmp_path, robot):
    out = _plan(robot, tmp_path / "p", 1.0)

    def build(d: Path) -> None:
        (d / "plan.json").write_text("{}")
        raise OSError(28, "No space left on device")

    with pytest.raises(OutputError, match="No space left"):
        replace_directory(build, out)
    assert read_plan_dir(out).q[0, 0] == 1.0 and [p.name for p in tmp_path.iterdir()] == ["p"]
