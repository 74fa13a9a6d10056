"""forte sweep: grid and cell ids, the worker against direct planning/simulation, pool vs Ray,
resume after SIGKILL, safe output handling and one-line errors."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import yaml

from forte.cli.main import main
from forte.experiments.sweep.cell import run_group
from forte.experiments.sweep.run import run_sweep
from forte.experiments.sweep.spec import plan_groups, read_sweep, trial_mass
from forte.experiments.sweep.store import SweepDir
from forte.experiments.sweep.table import CSV_FILE, NAMES, PARQUET_FILE, read_csv

ROOT = Path(__file__).resolve().parents[1]
TASKS = ROOT / "examples" / "tasks"
SRC = str(ROOT / "src")


def short_lift(folder: Path) -> Path:
    """The taught lift in 5 s on 11 waypoints (its plans and simulations take a fraction of a second)."""
    data = yaml.safe_load((TASKS / "lift.yaml").read_text())
    data["name"] = "short-lift"
    for knot, t in zip(data["path"]["configurations"], (0.0, 2.5, 5.0), strict=True):
        knot["t"] = t
    data["path"]["samples"] = 11
    path = folder / "short-lift.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def write_sweep(folder: Path, **fields) -> Path:
    """A sweep file: the short lift and the hold task, 2 methods x 2 masses, short simulations."""
    doc = {"name": "tiny", "tasks": ["short-lift.yaml", str(TASKS / "hold.yaml")],
           "methods": ["forte", "manipulability"], "masses": [0.35, 2.7],
           "simulation": {"hold": 0.2, "trials": 1, "seed": 3, "unloaded": True, "stop_on_failure": True}}
    doc.update(fields)
    short_lift(folder)
    path = folder / "sweep.yaml"
    path.write_text(yaml.safe_dump(doc))
    return path


@pytest.fixture(scope="module")
def pool_run(tmp_path_factory):
    """One uninterrupted sweep of the tiny grid on a local pool of 2 workers."""
    folder = tmp_path_factory.mktemp("pool")
    sweep = write_sweep(folder)
    result = run_sweep(sweep, folder / "out", workers=2)
    return sweep, folder / "out", result


# -- the grid ----------------------------------------------------------------------------------
def test_grid_cells_and_stable_ids(tmp_path):
    groups = plan_groups(read_sweep(write_sweep(tmp_path)))
    cells = [c for g in groups for c in g.cells]
    assert len(groups) == 2 * 2 * 2 and len(cells) == 8 * 3  # nominal, 1 mass-error trial, no payload
    assert len({c.id for c in cells}) == len(cells)
    assert [c.id for c in cells] == [c.id for g in plan_groups(read_sweep(tmp_path / "sweep.yaml")) for c in g.cells]
    # the hold task ignores waypoints; each plan has the three runs
    assert {(c.run, c.trial) for c in cells} == {("nominal", 0), ("mass-error", 1), ("no-payload", 0)}
    assert all(c.true_mass == 0.0 for c in cells if c.run == "no-payload")
    by_key = {(c.task, c.method, c.mass, c.run, c.trial): c for c in cells}

    # a new seed changes only the mass-error cells; more trials keep the earlier ones
    sim = {"hold": 0.2, "trials": 2, "seed": 4, "unloaded": True, "stop_on_failure": True}
    other = [c for g in plan_groups(read_sweep(write_sweep(tmp_path, simulation=sim))) for c in g.cells]
    for c in other:
        old = by_key.get((c.task, c.method, c.mass, c.run, c.trial))
        if c.run == "mass-error":
            assert old is None or old.id != c.id
        else:
            assert old is not None and old.id == c.id
    sim["seed"] = 3
    more = {c.id for g in plan_groups(read_sweep(write_sweep(tmp_path, simulation=sim))) for c in g.cells}
    assert {c.id for c in cells} < more

    # a changed hold time changes every simulated cell
    sim |= {"trials": 1, "hold": 0.3}
    assert not {c.id for c in cells} & {c.id for g in plan_groups(read_sweep(write_sweep(tmp_path, simulation=sim)))
                                        for c in g.cells}


def test_an_edited_urdf_changes_the_cell_ids(tmp_path):
    """The task file is the same bytes; the URDF it points to changes: every id changes."""
    from forte.model.robot import default_robot

    urdf = tmp_path / "arm.urdf"
    urdf.write_bytes(default_robot().urdf_path.read_bytes())
    data = yaml.safe_load((TASKS / "hold.yaml").read_text())
    data["robot"] = {"urdf": "arm.urdf", "ee_frame": "panda_hand"}
    (tmp_path / "custom-hold.yaml").write_text(yaml.safe_dump(data))
    sweep = write_sweep(tmp_path, tasks=["custom-hold.yaml"])

    def ids() -> list[str]:
        return [c.id for g in plan_groups(read_sweep(sweep)) for c in g.cells]

    before = ids()
    assert ids() == before  # unchanged files: the same ids
    text = urdf.read_text()
    assert '<mass value="0.629769"/>' in text
    urdf.write_text(text.replace('<mass value="0.629769"/>', '<mass value="0.7"/>', 1))
    after = ids()
    assert len(after) == len(before) and not set(after) & set(before)
    assert all(c.key["robot"] for g in plan_groups(read_sweep(sweep)) for c in g.cells)


def test_rows_of_a_plan_that_raised_carry_the_task_waypoints(tmp_path):
    """A raised plan's rows get the task's waypoint count, as rows of plans that ran do (the
    figures group rows by task and waypoints)."""
    from forte.planning.tasks.tasks import load_task

    start = [0, 0, 0, 0.0, -0.785398, 0.0, -2.356194, 0.0, 1.570796, 0.785398]
    up = {"name": "reach-up", "mode": "trajectory", "initial_configuration": start, "payload": {"mass": 1.0},
          "path": {"kind": "waypoints", "relative": True, "samples": 5,
                   "waypoints": [{"t": 0.0, "position": [0, 0, 0]}, {"t": 2.0, "position": [0, 0, 3.0]}]}}
    hold = {"name": "hold-up", "mode": "hold", "initial_configuration": start, "payload": {"mass": 1.0},
            "pose": {"position": [0, 0, 3.0], "relative": True}}
    for name, doc in (("up.yaml", up), ("hold-up.yaml", hold)):
        (tmp_path / name).write_text(yaml.safe_dump(doc))
    sweep = write_sweep(tmp_path, tasks=["up.yaml", "hold-up.yaml"], methods=["forte"], masses=[1.0],
                        simulation=False)
    groups = plan_groups(read_sweep(sweep))
    ns = {}
    for g in groups:
        rows = [r.row for r in run_group(g)]
        assert {r["plan_status"] for r in rows} == {"error"} and "unreachable" in rows[0]["error"]
        ns[rows[0]["task"]] = {r["waypoints"] for r in rows}
    assert ns == {"reach-up": {load_task(tmp_path / "up.yaml").n}, "hold-up": {1}}
    assert load_task(tmp_path / "up.yaml").n == 5


def test_rows_carry_the_same_waypoints_whether_planned_or_not(pool_run):
    """Every row of a task has that task's waypoint count (the hold task: 1)."""
    _, out, _ = pool_run
    by_task: dict[str, set] = {}
    for r in read_csv(out / CSV_FILE):
        by_task.setdefault(r["task"], set()).add(r["waypoints"])
    assert by_task == {"short-lift": {11}, "hold": {1}}


def test_methods_all_and_waypoint_axis(tmp_path):
    from forte.planning.planner import methods_for
    from forte.planning.tasks.tasks import load_task

    spec = read_sweep(write_sweep(tmp_path, methods="all", waypoints=[5, 9], simulation=False))
    groups = plan_groups(spec)
    lift, hold = (load_task(p) for p in (tmp_path / "short-lift.yaml", TASKS / "hold.yaml"))
    assert [(g.waypoints, g.method) for g in groups if "short-lift" in g.task_path] == [
        (n, m) for n in (5, 9) for m in methods_for(lift) for _ in (0.35, 2.7)]
    assert [g.method for g in groups if "hold" in g.task_path] == [m for m in methods_for(hold) for _ in (0.35, 2.7)]
    assert all(g.waypoints is None for g in groups if "hold" in g.task_path)  # waypoints: trajectory tasks only
    assert {c.run for g in groups for c in g.cells} == {"plan-only"}


def test_trial_masses_are_shared_bounded_and_seeded(tmp_path):
    spec = read_sweep(write_sweep(tmp_path, simulation={"trials": 20, "seed": 1, "mass_error": 0.1}))
    cells = [c for g in plan_groups(spec) for c in g.cells if c.run == "mass-error"]
    by_trial: dict[tuple[float, int], set[float]] = {}
    for c in cells:
        by_trial.setdefault((c.mass, c.trial), set()).add(c.true_mass)
        assert abs(c.true_mass / c.mass - 1.0) <= 0.1
    assert all(len(v) == 1 for v in by_trial.values())  # every task and method sees the same draw
    draws = np.array([next(iter(v)) / m - 1.0 for (m, _), v in by_trial.items()])
    assert draws.std() > 0.02 and len(set(draws.round(12))) == len(draws)  # random, not one value
    assert trial_mass(2.7, 1, replace(spec.simulation, seed=2)) != trial_mass(2.7, 1, spec.simulation)


def test_worker_matches_direct_planning_and_simulation(tmp_path):
    """run_group's rows against plan() + evaluate metrics and simulate_plan() called here."""
    import forte
    from forte.io.plandir import write_plan

    spec = read_sweep(write_sweep(tmp_path))
    group = next(g for g in plan_groups(spec) if g.mass == 2.7 and g.method == "forte" and g.waypoints is None
                 and "short-lift" in g.task_path)
    rows = {r.row["run"]: r.row for r in run_group(group)}
    task = forte.load_task(tmp_path / "short-lift.yaml", mass=2.7)
    res = forte.plan(task, "forte")
    m = res.metrics
    assert rows["nominal"]["min_d"] == pytest.approx(float(np.min(m["d"])), rel=1e-9)
    assert rows["nominal"]["mean_manipulability"] == pytest.approx(float(np.mean(m["manipulability"])), rel=1e-9)
    cap = m["directional_capacity"] - (res.force.magnitude + res.force.r)
    assert rows["nominal"]["min_capacity_margin"] == pytest.approx(float(np.min(cap)), rel=1e-9)
    plan_dir = write_plan(res, tmp_path / "plan", figures=False)
    for run, mass in (("nominal", 2.7), ("mass-error", rows["mass-error"]["true_mass_kg"]), ("no-payload", 0.0)):
        sim = forte.simulate(plan_dir, mass, hold=0.2, write=False, stop_on_failure=True)
        assert rows[run]["sim_verdict"] == ("success" if sim.success else "failure"), run
        assert rows[run]["sim_failure_time_s"] == sim.failure_time, run


# -- the sweep ---------------------------------------------------------------------------------
def test_pool_sweep_writes_table_parquet_and_figures(pool_run):
    sweep, out, result = pool_run
    assert result.status == "complete" and result.cells == result.finished == result.computed == 24
    rows = read_csv(out / CSV_FILE)
    assert [r["cell_id"] for r in rows] == [c.id for g in plan_groups(read_sweep(sweep)) for c in g.cells]
    assert {r["plan_status"] for r in rows} <= {"feasible", "infeasible"} and not any(r["error"] for r in rows)
    assert {r["sim_verdict"] for r in rows} <= {"success", "failure"}
    assert {r["task"] for r in rows} == {"short-lift", "hold"}
    import pyarrow.parquet as pq

    assert pq.read_table(out / PARQUET_FILE).to_pylist() == rows
    assert sorted(p.name for p in (out / "figures").iterdir()) == ["hold.png", "short-lift.png"]
    doc = json.loads((out / "sweep.json").read_text())
    assert doc["generator"] == "forte" and doc["status"] == "complete" and doc["finished"] == 24
    # nothing to do the second time: every cell is skipped, the table is the same
    before = (out / CSV_FILE).read_bytes()
    again = run_sweep(sweep, out, workers=2)
    assert (again.computed, again.skipped) == (0, 24) and (out / CSV_FILE).read_bytes() == before


@pytest.mark.slow
def test_ray_gives_the_same_table_as_the_pool(pool_run, tmp_path, capsys):
    """forte sweep --ray --workers 2: a local Ray instance, ray.init(address="local", num_cpus=2)."""
    ray = pytest.importorskip("ray")
    sweep, out, _ = pool_run
    assert main(["sweep", str(sweep), "--out", str(tmp_path / "ray"), "--ray", "--workers", "2"]) == 0
    assert "complete: 24/24 cells (24 computed now" in capsys.readouterr().out
    assert not ray.is_initialized()  # the instance it started is shut down
    assert (tmp_path / "ray" / CSV_FILE).read_bytes() == (out / CSV_FILE).read_bytes()
    workers = {json.loads(p.read_text())["timing"]["worker"] for p in (tmp_path / "ray" / "cells").iterdir()}
    pool_workers = {json.loads(p.read_text())["timing"]["worker"] for p in (out / "cells").iterdir()}
    assert not workers & pool_workers  # computed again, by Ray's workers
    start = next(e for e in SweepDir(tmp_path / "ray").events() if e["event"] == "start")
    assert start["backend"] == "ray:local"


def _descendants(pid: int) -> set[int]:
    """Every process below ``pid`` (Ray's workers are children of its raylet, not of the driver)."""
    found, todo = set(), [pid]
    while todo:
        for child in _children(todo.pop()) - found:
            found.add(child)
            todo.append(child)
    return found


@pytest.mark.slow
def test_a_ray_worker_that_dies_is_one_line_error(tmp_path, monkeypatch):
    """SIGKILL to the Ray worker running a group, with no retries left: the one-line error of a
    dead worker (``forte sweep`` exits 2 on it and resumes later, as with the pool)."""
    pytest.importorskip("ray")
    import threading

    from forte.exceptions import ForteError
    from forte.experiments.sweep import executors

    monkeypatch.setattr(executors, "RAY_TASK_RETRIES", 0)  # read when the remote function is made
    groups = plan_groups(read_sweep(write_sweep(tmp_path)))
    killed: list[int] = []

    def kill_the_worker() -> None:
        deadline = time.monotonic() + 120
        while not killed and time.monotonic() < deadline:
            busy = [p for p in _descendants(os.getpid()) if _cmdline(p).startswith("ray::run_group")]
            if busy:
                os.kill(busy[0], signal.SIGKILL)
                killed.append(busy[0])
            time.sleep(0.02)

    killer = threading.Thread(target=kill_the_worker, daemon=True)
    done = []
    with pytest.raises(ForteError) as err, executors.ray_session("local", 1):  # signals: main thread
        killer.start()
        done.extend(executors.ray_results(groups))
    killer.join(timeout=10)
    assert killed and not done
    message = str(err.value)
    assert message.startswith("a sweep worker died (") and "\n" not in message and "run the same command" in message
    assert message.startswith("a sweep worker died (WorkerCrashedError: "), message


@pytest.mark.slow
def test_leaving_early_cancels_the_tasks_only_in_the_caller_s_session(tmp_path, monkeypatch):
    """In forte's own session ray.shutdown() stops the tasks left (no force-cancel before it, which
    races Ray's bookkeeping); in a session the caller started and keeps, the tasks left are cancelled."""
    ray = pytest.importorskip("ray")
    import contextlib

    from forte.experiments.sweep import executors

    groups = plan_groups(read_sweep(write_sweep(tmp_path)))
    assert len(groups) > 1
    cancelled: list = []
    monkeypatch.setattr(ray, "cancel", lambda ref, **kwargs: cancelled.append(ref))

    def first_then_leave() -> None:
        with executors.backend("local", 1) as execute, contextlib.closing(execute(groups)) as results:
            assert next(results)

    first_then_leave()  # forte's own local instance
    assert cancelled == [] and not ray.is_initialized()
    ray.init(address="local", num_cpus=1, include_dashboard=False, log_to_driver=False, logging_level="ERROR")
    try:
        first_then_leave()  # the caller's session, left running
        assert len(cancelled) == len(groups) - 1 and ray.is_initialized()
    finally:
        ray.shutdown()


def _children(pid: int) -> set[int]:
    try:
        text = Path(f"/proc/{pid}/task/{pid}/children").read_text()
    except OSError:
        return set()
    return {int(p) for p in text.split()}


def _cmdline(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")[:120]
    except OSError:
        return ""


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().split(")")[-1].split()[0]
    except OSError:
        return False
    return state != "Z"


def _start(sweep: Path, out: Path, workers: int, *extra: str) -> tuple[subprocess.Popen, set[int]]:
    """Run ``forte sweep`` in a subprocess until its first cell is stored; returns the process and
    the pids of its children seen until then."""
    env = {**os.environ, "PYTHONPATH": SRC + os.pathsep + os.environ.get("PYTHONPATH", "")}
    proc = subprocess.Popen([sys.executable, "-m", "forte.cli", "sweep", str(sweep), "--out", str(out),
                             "--workers", str(workers), "--no-figures", "--quiet", *extra], env=env,
                            stderr=subprocess.PIPE)
    cells, deadline, workers_seen = out / "cells", time.monotonic() + 180, set()
    while time.monotonic() < deadline and not (cells.is_dir() and any(p.suffix == ".json" for p in cells.iterdir())):
        workers_seen |= _children(proc.pid)
        assert proc.poll() is None, proc.stderr.read().decode()
        time.sleep(0.02)
    return proc, workers_seen | _children(proc.pid)


def _start_and_stop(sweep: Path, out: Path, sig: int, workers: int, *extra: str) -> tuple[int, set[int]]:
    """Run ``forte sweep`` in a subprocess, send ``sig`` once its first cell is stored; returns its
    exit status and the pids of its children (the pool's workers, or Ray's processes)."""
    proc, workers_seen = _start(sweep, out, workers, *extra)
    os.kill(proc.pid, sig)
    code = proc.wait()
    err = proc.stderr.read().decode(errors="replace")
    proc.stderr.close()
    deadline = time.monotonic() + 10  # orphaned workers notice that the driver is gone and exit
    while time.monotonic() < deadline and any(_alive(p) for p in workers_seen):
        time.sleep(0.1)
    left = {p: _cmdline(p) for p in workers_seen if _alive(p)}
    assert workers_seen and not left, (left, err)
    assert code == (130 if sig == signal.SIGTERM else -sig), err
    return code, workers_seen


@pytest.mark.slow
@pytest.mark.parametrize("backend", [(), ("--ray",)], ids=["pool", "ray"])
def test_sigterm_stops_with_a_partial_table(pool_run, tmp_path, backend):
    """With --ray too: ray.init installs its own SIGTERM handler (sys.exit(15)); forte keeps its own."""
    if backend:
        pytest.importorskip("ray")
    sweep, _, _ = pool_run
    out = tmp_path / "stopped"
    assert _start_and_stop(sweep, out, signal.SIGTERM, 2, *backend)[0] == 130
    doc = json.loads((out / "sweep.json").read_text())
    finished = len(list((out / "cells").glob("*.json")))
    assert doc["status"] == "partial" and doc["finished"] == finished and 0 < finished < 24
    assert len(read_csv(out / CSV_FILE)) == finished
    assert SweepDir(out).events()[-1] | {"time": 0} == {"time": 0, "event": "end", "run": 1, "status": "interrupted",
                                                        "computed": finished}


def _pool_workers(pid: int) -> list[int]:
    """The children of ``pid`` that are spawned pool workers (not multiprocessing's resource tracker)."""
    return [child for child in _children(pid) if "spawn_main" in _cmdline(child)]


@pytest.mark.slow
def test_a_worker_that_dies_is_one_line_and_the_sweep_resumes(pool_run, tmp_path):
    """SIGKILL to the pool's worker (as the out-of-memory killer does): exit 2, one line, a partial
    table of the cells finished before; the same command then completes the grid."""
    sweep, reference, _ = pool_run
    out = tmp_path / "crashed"
    proc, _ = _start(sweep, out, 1)
    (worker,) = _pool_workers(proc.pid)
    os.kill(worker, signal.SIGKILL)
    code = proc.wait(timeout=60)
    err = proc.stderr.read().decode()
    proc.stderr.close()
    assert code == 2 and err.count("\n") == 1, err
    assert err.startswith(f"forte: error: a sweep worker died (pool worker {worker} killed by SIGKILL"), err
    assert "run the same command to resume" in err
    doc = json.loads((out / "sweep.json").read_text())
    finished = len(list((out / "cells").glob("*.json")))
    assert doc["status"] == "partial" and doc["finished"] == finished and 0 < finished < 24
    assert len(read_csv(out / CSV_FILE)) == finished
    end = SweepDir(out).events()[-1]
    assert (end["event"], end["status"], end["computed"]) == ("end", "failed", finished)
    assert "a sweep worker died" in end["error"]
    result = run_sweep(sweep, out, workers=2)
    assert (result.status, result.skipped, result.computed) == ("complete", finished, 24 - finished)
    assert (out / CSV_FILE).read_bytes() == (reference / CSV_FILE).read_bytes()


@pytest.mark.slow
def test_resume_after_sigkill_skips_finished_cells(pool_run, tmp_path):
    sweep, reference, _ = pool_run
    out = tmp_path / "killed"
    _start_and_stop(sweep, out, signal.SIGKILL, workers=1)
    cells = out / "cells"
    first = {p.name: (p.read_bytes(), p.stat().st_mtime_ns) for p in cells.glob("*.json")}
    assert 0 < len(first) < 24, "the sweep must be killed part-way"
    assert json.loads((out / "sweep.json").read_text())["status"] == "running"  # killed: never marked done

    result = run_sweep(sweep, out, workers=2)
    assert (result.status, result.skipped, result.computed) == ("complete", len(first), 24 - len(first))
    for name, (data, mtime) in first.items():  # finished cells were not recomputed nor rewritten
        assert (cells / name).read_bytes() == data and (cells / name).stat().st_mtime_ns == mtime
    events = SweepDir(out).events()
    starts = [e for e in events if e["event"] == "start"]
    assert [e["run"] for e in starts] == [1, 2] and starts[1]["finished_before"] == len(first)
    second = {e["cell_id"] for e in events if e["event"] == "cell" and e["run"] == 2}
    assert second.isdisjoint(Path(n).stem for n in first) and len(second) == 24 - len(first)
    assert (out / CSV_FILE).read_bytes() == (reference / CSV_FILE).read_bytes()


def test_a_grown_grid_computes_only_its_new_cells(tmp_path):
    sweep = write_sweep(tmp_path, tasks=[str(TASKS / "hold.yaml")], masses=[0.35], simulation=False)
    out = tmp_path / "out"
    assert run_sweep(sweep, out, workers=1, figures=False).computed == 2  # plan-only: forte, manipulability
    first = {p.name: p.stat().st_mtime_ns for p in (out / "cells").iterdir()}
    sweep = write_sweep(tmp_path, tasks=[str(TASKS / "hold.yaml")], masses=[0.35, 2.7], simulation=False)
    result = run_sweep(sweep, out, workers=1, figures=False)
    assert (result.skipped, result.computed, result.cells) == (2, 2, 4)
    assert all((out / "cells" / n).stat().st_mtime_ns == t for n, t in first.items())
    rows = read_csv(out / CSV_FILE)
    assert [r["mass_kg"] for r in rows] == [0.35, 2.7, 0.35, 2.7] and {r["run"] for r in rows} == {"plan-only"}
    assert all(r["sim_verdict"] is None for r in rows) and list(rows[0]) == list(NAMES)


def test_the_marker_is_written_before_anything_else(tmp_path, monkeypatch):
    """open() writes sweep.json into the new directory before creating cells/: a kill in between
    leaves an empty or a marked directory, never an unmarked one with files in it."""
    import forte.experiments.sweep.store as store_module

    seen = []
    real = store_module.atomic_write

    def recording(path, text):  # the real write, noting what the directory held at that moment
        seen.append((path.name, sorted(p.name for p in path.parent.iterdir())))
        real(path, text)

    monkeypatch.setattr(store_module, "atomic_write", recording)
    spec = read_sweep(write_sweep(tmp_path, tasks=[str(TASKS / "hold.yaml")], masses=[0.35], simulation=False))
    out = SweepDir(tmp_path / "new" / "out")
    out.check()
    out.open(spec, 2)
    assert seen[0][0] == "sweep.json" and not any(not n.startswith(".sweep.json.") for n in seen[0][1])
    assert sorted(p.name for p in out.out.iterdir()) == ["cells", "sweep.json"]


def test_a_directory_left_by_a_kill_at_start_is_resumed(tmp_path, capsys):
    """Only an empty cells/ (forte's old order) and a temporary file of sweep.json: accepted and cleaned;
    anything else beside them is still refused."""
    sweep = write_sweep(tmp_path, tasks=[str(TASKS / "hold.yaml")], masses=[0.35], simulation=False)
    out = tmp_path / "out"
    (out / "cells").mkdir(parents=True)
    (out / ".sweep.json.k2x_9abc.tmp").write_text('{"generator": "fo')
    result = run_sweep(sweep, out, workers=1, figures=False)
    assert result.status == "complete" and result.computed == 2
    assert not (out / ".sweep.json.k2x_9abc.tmp").exists()

    for extra in ("notes.txt", "cells/x.json"):
        other = tmp_path / f"other-{extra.replace('/', '-')}"
        (other / "cells").mkdir(parents=True)
        (other / extra).write_text("keep me")
        code, err = _cli(capsys, sweep, "--out", other)
        assert code == 2 and err.count("\n") == 1 and "forte did not write" in err, err
        assert (other / extra).read_text() == "keep me"
        assert sorted(p.name for p in other.rglob("*")) == sorted({"cells", *Path(extra).parts})


def test_a_corrupted_cell_file_is_recomputed(tmp_path):
    sweep = write_sweep(tmp_path, tasks=[str(TASKS / "hold.yaml")], masses=[0.35], simulation=False)
    out = tmp_path / "out"
    run_sweep(sweep, out, workers=1, figures=False)
    victim = sorted((out / "cells").iterdir())[0]
    doc = json.loads(victim.read_text())
    doc["key"]["mass"] = 9.0  # no longer hashes to the file's id
    victim.write_text(json.dumps(doc))
    result = run_sweep(sweep, out, workers=1, figures=False)
    assert (result.skipped, result.computed) == (1, 1)
    assert json.loads(victim.read_text())["key"]["mass"] == 0.35


# -- the command line ------------------------------------------------------------------------
def _cli(capsys, *args: str) -> tuple[int, str]:
    code = main(["sweep", *map(str, args)])
    return code, capsys.readouterr().err


@pytest.mark.parametrize(("fields", "expected"), [
    ({"colour": 1}, "colour: unknown field"),
    ({"methods": ["forte", "fastest"]}, "methods[1]: expected one of"),
    ({"methods": ["teaching"]}, "methods: 'teaching' does not apply to task short-lift.yaml"),
    ({"masses": [0.35, -1]}, "masses[1]: expected a finite number > 0"),
    ({"masses": []}, "masses: expected a non-empty list"),
    ({"waypoints": 1}, "waypoints: expected an integer from 2 to"),
    ({"tasks": ["nope.yaml"]}, "tasks[0]: "),
    ({"tasks": [str(TASKS / "continuous.yaml")]}, "masses: task "),
    ({"simulation": {"trials": -1}}, "simulation.trials: expected an integer >= 0"),
    ({"simulation": {"mass_error": 1.5}}, "simulation.mass_error: expected a fraction in [0, 1)"),
    ({"simulation": {"holds": 1}}, "simulation.holds: unknown field"),
    ({"name": "../x"}, "name: expected a plain name"),
])
def test_bad_sweep_files_exit_2_with_one_line(tmp_path, capsys, fields, expected):
    sweep = write_sweep(tmp_path, **fields)
    code, err = _cli(capsys, sweep, "--out", tmp_path / "out")
    assert code == 2 and err.count("\n") == 1 and err.startswith("forte: error: ")
    assert str(sweep) in err and expected in err, err
    assert not (tmp_path / "out").exists()


def test_two_tasks_with_one_name_exit_2(tmp_path, capsys):
    short_lift(tmp_path)
    (tmp_path / "copy.yaml").write_text((tmp_path / "short-lift.yaml").read_text())  # name: short-lift too
    sweep = write_sweep(tmp_path, tasks=["short-lift.yaml", "copy.yaml"])
    code, err = _cli(capsys, sweep, "--out", tmp_path / "out")
    assert code == 2 and err.count("\n") == 1 and err.startswith(f"forte: error: {sweep}: tasks: ")
    assert "short-lift.yaml" in err and "copy.yaml" in err and "'short-lift'" in err, err
    assert not (tmp_path / "out").exists()


def test_not_yaml_and_bad_options_exit_2(tmp_path, capsys):
    bad = tmp_path / "bad.yaml"
    bad.write_text("tasks: [a\n")
    code, err = _cli(capsys, bad)
    assert code == 2 and err.count("\n") == 1 and "not valid YAML" in err
    code, err = _cli(capsys, write_sweep(tmp_path), "--workers", "0")
    assert code == 2 and "--workers: expected 1 to" in err


def test_refuses_an_output_forte_did_not_create(tmp_path, capsys):
    sweep = write_sweep(tmp_path)
    foreign = tmp_path / "mine"
    foreign.mkdir()
    (foreign / "notes.txt").write_text("keep me")
    code, err = _cli(capsys, sweep, "--out", foreign)
    assert code == 2 and err.count("\n") == 1 and "forte did not write" in err
    assert [p.name for p in foreign.iterdir()] == ["notes.txt"] and (foreign / "notes.txt").read_text() == "keep me"
    other = tmp_path / "plan"  # another kind of forte output: not a sweep
    other.mkdir()
    (other / "summary.json").write_text(json.dumps({"generator": "forte"}))
    code, err = _cli(capsys, sweep, "--out", other)
    assert code == 2 and "not a forte sweep" in err and [p.name for p in other.iterdir()] == ["summary.json"]


def test_a_sweep_being_written_is_refused(tmp_path, capsys):
    sweep = write_sweep(tmp_path)
    code = (f"import sys, time; from forte.io.outputs import output_lock\n"
            f"with output_lock({str(tmp_path / 'out')!r}):\n    print('held', flush=True); time.sleep(60)")
    env = {**os.environ, "PYTHONPATH": SRC + os.pathsep + os.environ.get("PYTHONPATH", "")}
    holder = subprocess.Popen([sys.executable, "-c", code], env=env, stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "held"
        code, err = _cli(capsys, sweep, "--out", tmp_path / "out", "--workers", "1")
    finally:
        holder.kill()
        holder.wait()
        holder.stdout.close()
    assert code == 2 and err.count("\n") == 1 and "another forte process is writing it" in err


def test_ray_not_installed_is_one_line(tmp_path, capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "ray", None)  # import ray fails as if not installed
    code, err = _cli(capsys, write_sweep(tmp_path), "--out", tmp_path / "out", "--ray")
    assert code == 2 and err.count("\n") == 1 and "--ray: Ray is not installed" in err
    assert not (tmp_path / "out").exists()


def test_dry_run_counts_cells(pool_run, capsys):
    sweep, out, _ = pool_run
    assert main(["sweep", str(sweep), "--out", str(out), "--dry-run"]) == 0
    assert "tiny: 24 cells (8 plans); 24 finished" in capsys.readouterr().out
