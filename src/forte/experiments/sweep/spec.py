"""Sweep files: the grid they describe, its cells and their stable ids.

A sweep file (YAML) names the axes of a grid; every field is checked here, and an error is one
line naming the file, the field and what was expected::

    name: lift-demo              # optional (default: the file's stem)
    tasks: [../tasks/lift.yaml]  # task files, relative to this file
    waypoints: 15                # optional: int, or a list of ints (an axis); trajectory tasks only
    methods: [forte, quintic]    # method names, or "all" (every method that applies to a task)
    masses: [0.35, 2.7]          # payload masses in kg (an axis); omit: each task file's own
    simulation:                  # omit (or false) to plan only
      hold: 1.0                  # s held after the last waypoint
      trials: 3                  # mass-error runs per plan, besides the nominal run
      mass_error: 0.10           # their true mass is m (1 + u), u uniform in [-e, e]
      seed: 0
      unloaded: false            # also run every plan with no payload
      stop_on_failure: false     # end a run at its first failure (same verdict and time, faster)

The grid is tasks x waypoints x methods x masses x runs. One plan is made per
``(task, waypoints, method, mass)`` (a :class:`PlanGroup`, the unit of work), and each of its
runs is a :class:`Cell`: the nominal simulation (``run = "nominal"``, trial 0), the mass-error
trials ``1..trials`` (``"mass-error"``), the run without payload (``"no-payload"``), or, without
simulation, the plan alone (``"plan-only"``).

Trial ``k`` of mass ``m`` draws ``u`` from a generator seeded with ``(seed, k, round(m 1e6))``: the
same draw for every task and method (the methods are compared on the same true masses) and
independent of the order in which cells run.

A cell's id is the first 16 hex digits of the SHA-256 of its key (:func:`cell_key`): the task
file as written and the SHA-256 of its bytes, the robot's fingerprint
(:attr:`~forte.model.robot.MobileManipulator.fingerprint`: the URDF's bytes and every model
setting, so an edited URDF the task points to changes it), waypoints, method, mass, run, trial and
the simulation settings the run depends on. The versions of forte and of its libraries are not
part of it: a sweep directory resumed after an upgrade keeps its finished cells (start a new
directory to recompute them).
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from forte.exceptions import InvalidInputError
from forte.experiments.common import MASS_ERROR
from forte.planning.methods.catalog import METHODS
from forte.planning.methods.plugins import load_plugins
from forte.planning.planner import methods_for
from forte.planning.tasks.schema import Reader
from forte.planning.tasks.tasks import Task, read_yaml, task_from_dict
from forte.validation import MAX_HOLD_S, MAX_WAYPOINTS, payload_mass

#: Version of the cell key and cell file layout (part of every cell id). 2: the key holds the robot.
CELL_FORMAT = 2
#: Largest grid a sweep file may describe (forte's documented bound).
MAX_CELLS = 100_000
#: Largest number of mass-error trials per plan.
MAX_TRIALS = 1000
RUNS = ("plan-only", "nominal", "mass-error", "no-payload")


@dataclass(frozen=True)
class Simulation:
    """How every plan of a sweep is simulated (see the module docstring)."""

    hold: float = 1.0
    trials: int = 0
    mass_error: float = MASS_ERROR
    seed: int = 0
    unloaded: bool = False
    stop_on_failure: bool = False


@dataclass(frozen=True)
class TaskEntry:
    """A task file of the sweep: as written, where it is, its bytes' digest and its parsed YAML."""

    name: str
    written: str
    path: Path
    sha256: str
    data: Any


@dataclass(frozen=True)
class SweepSpec:
    """A validated sweep file."""

    name: str
    source: Path
    tasks: tuple[TaskEntry, ...]
    waypoints: tuple[int | None, ...]
    methods: tuple[str, ...] | None  # None: every method that applies to a task
    masses: tuple[float, ...] | None  # None: each task file's own payload
    simulation: Simulation | None

    def describe(self) -> dict[str, Any]:
        """The spec as plain data (recorded in ``sweep.json``)."""
        sim = self.simulation
        return {"name": self.name, "file": str(self.source),
                "tasks": [{"file": t.written, "name": t.name, "sha256": t.sha256} for t in self.tasks],
                "waypoints": list(self.waypoints), "methods": "all" if self.methods is None else list(self.methods),
                "masses": None if self.masses is None else list(self.masses),
                "simulation": None if sim is None else sim.__dict__.copy()}


class Cell(NamedTuple):
    """One row of the results table: one run of one plan."""

    id: str
    task: str
    task_file: str
    waypoints: int | None
    method: str
    mass: float | None
    run: str
    trial: int
    true_mass: float | None
    key: dict[str, Any]


class PlanGroup(NamedTuple):
    """The unit of work: one plan and the cells (runs) to compute from it.

    Everything a worker needs travels with it (the task file's parsed YAML, not its path), so a
    group runs on any machine with forte installed.
    """

    task_data: Any
    task_path: str
    waypoints: int | None  # the sweep's value (None: the task file's own, and for hold tasks)
    n: int  # the task's waypoints at that value: the table's ``waypoints`` column
    method: str
    mass: float | None
    simulation: Simulation | None
    cells: tuple[Cell, ...]


def read_sweep(path: str | Path) -> SweepSpec:
    """Read and validate a sweep file (errors: :class:`~forte.exceptions.TaskFileError`, one line)."""
    path = Path(path)
    r = Reader(read_yaml(path, "sweep file"), path)
    r.unknown({"name", "tasks", "waypoints", "methods", "masses", "simulation"})
    name = r.get("name", path.stem)
    if not isinstance(name, str) or not name or "/" in name or name.startswith("."):
        raise r.error("name", f"expected a plain name (no '/', not starting with '.'), got {name!r}")
    return SweepSpec(name=name, source=path, tasks=_tasks(r, path), waypoints=_waypoints(r),
                     methods=_methods(r), masses=_masses(r), simulation=_simulation(r))


def _list(r: Reader, name: str, required: bool = True) -> list[Any] | None:
    value = r.get(name)
    if value is None and not required:
        return None
    if not isinstance(value, list) or not value:
        raise r.error(name, f"expected a non-empty list, got {value!r}")
    return value


def _tasks(r: Reader, path: Path) -> tuple[TaskEntry, ...]:
    entries = []
    for i, item in enumerate(_list(r, "tasks") or []):
        if not isinstance(item, str) or not item:
            raise r.error(f"tasks[{i}]", f"expected a task file path, got {item!r}")
        located = Path(item) if Path(item).is_absolute() else path.parent / item
        if not located.is_file():
            raise r.error(f"tasks[{i}]", f"{located}: task file does not exist")
        data = read_yaml(located, "task file")  # checks size and encoding first
        digest = hashlib.sha256(located.read_bytes()).hexdigest()
        name = data.get("name", located.stem) if isinstance(data, dict) else located.stem
        entries.append(TaskEntry(str(name), item, located, digest, data))
    if len({e.written for e in entries}) != len(entries):
        raise r.error("tasks", "lists a task file twice; expected each once")
    seen: dict[str, TaskEntry] = {}
    for e in entries:  # the table's task column and the figures tell tasks apart by name
        if e.name in seen:
            raise r.error("tasks", f"task files {seen[e.name].written} and {e.written} are both named {e.name!r}; "
                          "expected distinct task names (set name: in one of them)")
        seen[e.name] = e
    return tuple(entries)


def _waypoints(r: Reader) -> tuple[int | None, ...]:
    value = r.get("waypoints")
    if value is None:
        return (None,)
    items = value if isinstance(value, list) else [value]
    for i, n in enumerate(items):
        if isinstance(n, bool) or not isinstance(n, int) or not 2 <= n <= MAX_WAYPOINTS:
            where = f"waypoints[{i}]" if isinstance(value, list) else "waypoints"
            raise r.error(where, f"expected an integer from 2 to {MAX_WAYPOINTS}, got {n!r}")
    if not items or len(set(items)) != len(items):
        raise r.error("waypoints", f"expected an integer or a list of distinct integers, got {value!r}")
    return tuple(items)


def _methods(r: Reader) -> tuple[str, ...] | None:
    if r.get("methods") == "all":
        return None
    items = _list(r, "methods")
    load_plugins()  # a method from an installed package (forte.planning.methods.plugins) is a method too
    for i, m in enumerate(items or []):
        if m not in METHODS:
            raise r.error(f"methods[{i}]", f"expected one of {', '.join(METHODS)} (or methods: all), got {m!r}")
    if len(set(items or [])) != len(items or []):
        raise r.error("methods", "lists a method twice; expected each once")
    return tuple(items or [])


def _masses(r: Reader) -> tuple[float, ...] | None:
    items = _list(r, "masses", required=False)
    if items is None:
        return None
    out = []
    for i, m in enumerate(items):
        try:
            out.append(payload_mass(m, f"masses[{i}]"))
        except InvalidInputError as exc:
            raise r.error(f"masses[{i}]", str(exc).split(": ", 1)[1]) from None
    if len(set(out)) != len(out):
        raise r.error("masses", "lists a mass twice; expected each once")
    return tuple(out)


def _simulation(r: Reader) -> Simulation | None:
    value = r.get("simulation")
    if value is None or value is False:
        return None
    if value is True:
        return Simulation()
    s = r.sub("simulation")
    s.unknown({"hold", "trials", "mass_error", "seed", "unloaded", "stop_on_failure"})
    flags = {}
    for flag in ("unloaded", "stop_on_failure"):
        flags[flag] = s.get(flag, False)
        if not isinstance(flags[flag], bool):
            raise s.error(flag, f"expected true or false, got {flags[flag]!r}")
    error = s.number("mass_error", MASS_ERROR, nonnegative=True)
    if error >= 1.0:
        raise s.error("mass_error", f"expected a fraction in [0, 1), got {error:g}")
    return Simulation(hold=s.number("hold", 1.0, nonnegative=True, maximum=MAX_HOLD_S, unit=" s"),
                      trials=s.integer("trials", 0, minimum=0, maximum=MAX_TRIALS), mass_error=error,
                      seed=s.integer("seed", 0, minimum=0, maximum=2**63 - 1), **flags)


# -- the grid ----------------------------------------------------------------------------------
def load_entry(entry: TaskEntry, waypoints: int | None, mass: float | None) -> Task:
    """The task of ``entry`` at ``waypoints`` carrying ``mass`` (None: the file's)."""
    return task_from_dict(entry.data, entry.path, mass=mass, waypoints=waypoints)


def plan_groups(spec: SweepSpec) -> list[PlanGroup]:
    """Every plan of the grid with its cells, in grid order; each task is loaded and checked here.

    Raises :class:`~forte.exceptions.TaskFileError` / ``InvalidInputError`` (one line naming the
    sweep file's field) for a method that does not apply to a task, masses given for a task with
    a force profile, mass-error trials without a mass, or a grid larger than :data:`MAX_CELLS`.
    """
    r = Reader({}, spec.source)
    groups: list[PlanGroup] = []
    count = 0
    for entry in spec.tasks:
        base = task_from_dict(entry.data, entry.path)
        waypoints = spec.waypoints if base.mode == "trajectory" else (None,)
        methods = spec.methods if spec.methods is not None else methods_for(base)
        for m in methods:
            if not METHODS[m].applies_to(base):
                raise r.error("methods", f"'{m}' does not apply to task {entry.written} ({base.mode} mode); "
                              f"expected methods among {', '.join(methods_for(base))}")
        masses = _task_masses(spec, entry, base, r)
        robot = base.robot.fingerprint
        for w in waypoints:
            n = load_entry(entry, w, None).n  # also checks the waypoints against the task
            for method in methods:
                for mass in masses:
                    cells = tuple(_cells(spec, entry, robot, w, method, mass))
                    count += len(cells)
                    if count > MAX_CELLS:
                        raise r.error("", f"the grid has more than {MAX_CELLS} cells (forte's documented bound); "
                                      "split it into several sweeps")
                    groups.append(PlanGroup(entry.data, str(entry.path), w, n, method, mass, spec.simulation, cells))
    return groups


def _task_masses(spec: SweepSpec, entry: TaskEntry, task: Task, r: Reader) -> tuple[float | None, ...]:
    if task.force_profile is not None:
        if spec.masses is not None:
            raise r.error("masses", f"task {entry.written} has a force profile (no payload); expected no masses "
                          "(put it in a sweep of its own)")
        if spec.simulation is not None and (spec.simulation.trials or spec.simulation.unloaded):
            raise r.error("simulation", f"task {entry.written} has no payload; expected trials: 0 and unloaded: "
                          "false")
        return (None,)
    if spec.masses is not None:
        return spec.masses
    if task.payload.mass is None:
        raise r.error("masses", f"task {entry.written} has no payload mass (it would be estimated); "
                      "expected masses: [KG, ...]")
    return (float(task.payload.mass),)


def _cells(spec: SweepSpec, entry: TaskEntry, robot: str, waypoints: int | None, method: str,
           mass: float | None) -> list[Cell]:
    sim = spec.simulation
    runs: list[tuple[str, int, float | None]]
    if sim is None:
        runs = [("plan-only", 0, mass)]
    else:
        runs = [("nominal", 0, mass)]
        runs += [("mass-error", k, trial_mass(mass, k, sim)) for k in range(1, sim.trials + 1)]
        if sim.unloaded:
            runs.append(("no-payload", 0, 0.0))
    out = []
    for run, trial, true_mass in runs:
        key = cell_key(entry, robot, waypoints, method, mass, run, trial, sim)
        out.append(Cell(cell_id(key), entry.name, entry.written, waypoints, method, mass, run, trial, true_mass, key))
    return out


def trial_mass(mass: float | None, trial: int, sim: Simulation) -> float:
    """The true payload mass of mass-error trial ``trial`` (see the module docstring)."""
    if mass is None:
        raise ValueError("mass-error trials need a payload mass")
    rng = np.random.default_rng([sim.seed, trial, int(round(mass * 1e6))])
    return float(mass * (1.0 + rng.uniform(-sim.mass_error, sim.mass_error)))


def cell_key(entry: TaskEntry, robot: str, waypoints: int | None, method: str, mass: float | None, run: str,
             trial: int, sim: Simulation | None) -> dict[str, Any]:
    """What a cell's result depends on (hashed into its id); ``robot``: the task's robot fingerprint."""
    key: dict[str, Any] = {"format": CELL_FORMAT, "task_file": entry.written, "task_sha256": entry.sha256,
                           "robot": robot, "waypoints": waypoints, "method": method, "mass": mass, "run": run,
                           "trial": trial}
    if sim is not None:
        key["simulation"] = {"hold": sim.hold, "stop_on_failure": sim.stop_on_failure}
        if run == "mass-error":
            key["simulation"] |= {"mass_error": sim.mass_error, "seed": sim.seed}
    return key


def cell_id(key: dict[str, Any]) -> str:
    """The first 16 hex digits of the SHA-256 of ``key`` as canonical JSON."""
    text = json.dumps(key, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(text.encode()).hexdigest()[:16]
