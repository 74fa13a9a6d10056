"""Feasibility matrix (issue 36, item 9): robots x reaches x payloads x resolutions, every plan
judged and every feasible one executed in MuJoCo.

Robots: every preset (``authors``, ``moca-like``, ``ur5``, ``kinova``, ``tiago`` and the authors'
Panda on a fixed base) and the same arms from their raw example-robot-data URDFs (``erd:`` path,
``ee_frame``, a mount where the arm has no base of its own) started from a posture that is not the
preset's home (:data:`ROBOTS`: each offset is written there). Each raw URDF is paired with a preset
of the same arm: "the preset version of the same task" is that preset with the same reach, payload
and resolution.

Reaches (relative to the start pose, orientation held): ``forward`` (+x), ``sideways`` (+y),
``down`` (-z) and ``out-and-back`` (+x at half time, back at the end), of 0.1 m in 3 s, 0.3 m in
5 s and 0.5 m in 8 s. Payloads 0 (a zero force profile, no payload body), 0.5 and 1.5 kg.
Resolutions: the path's ``samples`` (21 and 41).

Each plan is ``forte.plan(task)`` (method forte); a feasible one is written and run with
``simulate_plan(dir, hold=0.3)``. A task forte refuses before planning (an unreachable pose: exit 2
from the CLI) is a row with verdict ``error``. Each row says whether its start posture can carry
its load at all (``start_carries_load``: :func:`forte.planning.verdict.start_load.start_load`, the
start at rest on the capacity requirement; a start that cannot fails every plan from it). Prints
one row per cell to stderr, then the table per robot: planned, feasible, infeasible by first
failed requirement, failing at the start, start posture cannot carry the load, simulated, MuJoCo
agreement and the fraction feasible where the preset version of the same task is feasible, both
over all such rows and over those whose start posture can carry the load. Writes
``rows.csv``, ``rows.json`` and ``table.md`` to ``--out`` (a fresh directory, or one this script
made earlier: it holds ``.feasibility_matrix``), and ``rows.jsonl`` row by row as the cells finish.
``--tables DIR ...`` prints the table of earlier runs together (e.g. the matrix run in halves).

    python benchmarks/feasibility_matrix.py --quick --out /tmp/fm-quick   # 20 cells, 19-51 s on 2 shared cores
    python benchmarks/feasibility_matrix.py --out /tmp/fm-full            # 720 cells, ~15 min (348 s + 543 s
                                                                          # as its 21- and 41-sample halves)
    python benchmarks/feasibility_matrix.py --sizes 0.3 --payloads 1.5 --samples 31 --out /tmp/fm
"""

from __future__ import annotations

import argparse
import csv
import json
import sys
import tempfile
import time
from collections import Counter
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any, NamedTuple

MARKER = ".feasibility_matrix"
KINDS = ("forward", "sideways", "down", "out-and-back")
#: reach distance (m) -> its duration (s)
SIZES = {0.1: 3.0, 0.3: 5.0, 0.5: 8.0}
PAYLOADS = (0.0, 0.5, 1.5)
SAMPLES = (21, 41)
MOUNT = {"xyz": [0.2575, 0.0, 0.52]}  # the authors' mount, on the built-in base
TIAGO_JOINTS = ["torso_lift_joint", *(f"arm_{i}_joint" for i in range(1, 8))]


class RobotCase(NamedTuple):
    """A robot of the matrix: its ``robot:`` block, its start arm posture (``None``: the preset's
    home) and the preset case of the same arm (itself for a preset)."""

    name: str
    robot: dict[str, Any]
    start: tuple[float, ...] | None
    preset: str

    @property
    def raw(self) -> bool:
        return self.name != self.preset


#: The robots. Raw URDF start postures (arm joints, rad; TIAGo's first value is the torso lift, m):
#: ur5-urdf: the preset's home (0, -1.75, 1.85, -1.67, -1.57, 0) + (0.3, 0.15, -0.2, 0.1, 0, 0.3);
#: panda-urdf: the Panda's ready pose (moca-like's home) + (0.2, 0.2, 0, 0.2, 0, -0.1, 0);
#: kinova-urdf and tiago-urdf: the users' own postures of issue 36 (the Kinova's preset home is
#: (1.09, 3.67, 2.38, 3.33, 2.35, 1.49), TIAGo's (0.2, 1.6, 0.3, -1.2, 1.9, -1.57, 1.0, 0)).
#: Each is within the URDF's limits (TIAGo's arm_6_joint 0.044 rad below its upper limit, the rest
#: farther) and free of self-collision (tests/test_feasibility_matrix.py).
ROBOTS: dict[str, RobotCase] = {case.name: case for case in (
    RobotCase("authors", {"preset": "authors"}, None, "authors"),
    RobotCase("moca-like", {"preset": "moca-like"}, None, "moca-like"),
    RobotCase("panda-fixed", {"preset": "authors", "base": "fixed"}, None, "panda-fixed"),
    RobotCase("ur5", {"preset": "ur5"}, None, "ur5"),
    RobotCase("kinova", {"preset": "kinova"}, None, "kinova"),
    RobotCase("tiago", {"preset": "tiago"}, None, "tiago"),
    RobotCase("panda-urdf", {"urdf": "erd:panda_description/urdf/panda.urdf", "ee_frame": "panda_hand_tcp",
                             "mount": MOUNT}, (0.2, -0.585398, 0.0, -2.156194, 0.0, 1.470796, 0.785398), "moca-like"),
    RobotCase("ur5-urdf", {"urdf": "erd:ur_description/urdf/ur5_robot.urdf", "ee_frame": "tool0", "mount": MOUNT},
              (0.3, -1.6, 1.65, -1.57, -1.57, 0.3), "ur5"),
    RobotCase("kinova-urdf", {"urdf": "erd:kinova_description/robots/kinova.urdf",
                              "ee_frame": "j2s6s200_end_effector", "mount": MOUNT},
              (4.80, 2.92, 1.00, 4.20, 1.44, 1.32), "kinova"),
    RobotCase("tiago-urdf", {"urdf": "erd:tiago_description/robots/tiago.urdf", "ee_frame": "arm_tool_link",
                             "base": "differential", "arm_joints": TIAGO_JOINTS},
              (0.15, 0.2, -1.34, -0.2, 1.94, -1.57, 1.37, 0.0), "tiago"),
)}


class Reach(NamedTuple):
    """A reach relative to the start pose: ``kind`` of :data:`KINDS`, ``distance`` m in ``duration`` s."""

    kind: str
    distance: float
    duration: float

    def waypoints(self) -> list[dict[str, Any]]:
        d, T = self.distance, self.duration
        end = {"forward": [d, 0.0, 0.0], "sideways": [0.0, d, 0.0], "down": [0.0, 0.0, -d],
               "out-and-back": [0.0, 0.0, 0.0]}[self.kind]
        middle = [{"t": T / 2, "position": [d, 0.0, 0.0]}] if self.kind == "out-and-back" else []
        return [{"t": 0.0, "position": [0.0, 0.0, 0.0]}, *middle, {"t": T, "position": end}]


class Cell(NamedTuple):
    """One task of the matrix."""

    robot: str
    reach: Reach
    payload: float
    samples: int

    @property
    def task_key(self) -> tuple:
        """The task without the robot: the preset version of a raw cell has the same key."""
        return self.reach, self.payload, self.samples


def task_dict(cell: Cell) -> dict[str, Any]:
    """The task file of ``cell`` as a dict (for :func:`forte.planning.tasks.tasks.task_from_dict`)."""
    case = ROBOTS[cell.robot]
    task: dict[str, Any] = {
        "name": f"{cell.robot}-{cell.reach.kind}-{cell.reach.distance:g}m", "robot": dict(case.robot),
        "path": {"kind": "waypoints", "relative": True, "samples": cell.samples, "waypoints": cell.reach.waypoints()}}
    if case.start is not None:
        task["initial_configuration"] = [0.0, 0.0, 0.0, *case.start]
    if cell.payload > 0:
        task["payload"] = {"mass": cell.payload}
    else:  # forte's payload mass is positive: no payload is a zero force
        task["force"] = {"kind": "constant", "vector": [0.0, 0.0, 0.0]}
    return task


def build_matrix(robots: list[str], kinds: list[str], sizes: list[float], payloads: list[float],
                 samples: list[int]) -> list[Cell]:
    """Every combination, presets first (a raw URDF's row is compared with its preset's)."""
    order = sorted(robots, key=lambda name: ROBOTS[name].raw)
    return [Cell(robot, Reach(kind, size, SIZES[size]), payload, n) for robot in order for kind in kinds
            for size in sizes for payload in payloads for n in samples]


def run_cell(cell: Cell) -> dict[str, Any]:
    """Plan, judge and (when feasible, or ``simulate`` asks) simulate one cell: its result row."""
    import forte
    from forte.exceptions import ForteError
    from forte.execution.run import simulate_plan
    from forte.io.plandir import write_plan
    from forte.planning.tasks.tasks import task_from_dict
    from forte.planning.verdict.start_load import start_load

    row: dict[str, Any] = {"robot": cell.robot, "raw_urdf": ROBOTS[cell.robot].raw, "preset": ROBOTS[cell.robot].preset,
                           "reach": cell.reach.kind, "distance_m": cell.reach.distance,
                           "duration_s": cell.reach.duration, "payload_kg": cell.payload, "samples": cell.samples,
                           "verdict": "error", "failed": "", "first_failed": "", "at_start": "",
                           "start_carries_load": True, "reason": "",
                           "sim": "not run", "sim_reason": "", "plan_s": 0.0, "sim_s": 0.0}
    start = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        try:
            task = task_from_dict(task_dict(cell), Path(tmp) / "task.yaml")
            row["start_carries_load"] = start_load(task) is None  # else no plan from this start carries it
            plan = forte.plan(task)
        except ForteError as exc:  # refused before planning (what the CLI answers with exit 2)
            row |= {"first_failed": "error", "reason": str(exc).splitlines()[0][:300],
                    "plan_s": round(time.perf_counter() - start, 2)}
            return row
        failed = plan.verdict.failed
        at_start = [v.requirement for v in plan.verdict.violations if 0 in v.waypoints]  # no plan can change q_0
        row |= {"verdict": plan.verdict.label, "failed": ";".join(failed), "first_failed": failed[0] if failed else "",
                "at_start": ";".join(at_start),
                "reason": "" if plan.feasible else plan.verdict.reason().splitlines()[0][:300],
                "plan_s": round(time.perf_counter() - start, 2)}
        if plan.feasible:
            start = time.perf_counter()
            result = simulate_plan(write_plan(plan, Path(tmp) / "plan", figures=False), hold=0.3, write=False)
            row |= {"sim": "success" if result.success else "failure", "sim_reason": result.reason or "",
                    "sim_s": round(time.perf_counter() - start, 2)}
    return row


def _preset_feasible(rows: list[dict[str, Any]]) -> dict[tuple, bool]:
    return {(r["robot"], r["reach"], r["distance_m"], r["payload_kg"], r["samples"]): r["verdict"] == "feasible"
            for r in rows if not r["raw_urdf"]}


def carries(row: dict[str, Any]) -> bool:
    """Whether the row's start posture carries its load (rows of runs before that column: a
    capacity failure at the start says it does not)."""
    return bool(row.get("start_carries_load", "capacity" not in row["at_start"].split(";")))


def versus_preset(rows: list[dict[str, Any]], carrying: bool = False) -> tuple[int, int]:
    """Raw-URDF rows whose preset version is feasible: (feasible ones, all such); ``carrying``: only
    the rows whose start posture can carry the load (:func:`carries`)."""
    preset = _preset_feasible(rows)
    paired = [r for r in rows if r["raw_urdf"] and (carries(r) or not carrying)
              and preset.get((r["preset"], r["reach"], r["distance_m"], r["payload_kg"], r["samples"]))]
    return sum(r["verdict"] == "feasible" for r in paired), len(paired)


def _share(k: int, n: int) -> str:
    return f"{k} of {n} ({100 * k / n:.0f} %)" if n else "none paired"


HEADER = ("| robot | source | planned | feasible | not feasible: first failed requirement | of them, failing at the "
          "start posture | start posture cannot carry the load | simulated | feasible & MuJoCo success | "
          "feasible & MuJoCo failure | feasible where the preset's is: all rows / rows whose start carries the load |")


def table(rows: list[dict[str, Any]]) -> str:
    """The summary table per robot (Markdown), and the totals. The target fraction is given both
    ways: over every raw row whose preset version is feasible, and over those whose start posture
    can carry the load (a start that cannot is no plan's doing: it has its own column)."""
    lines = [HEADER, "|---|---|---|---|---|---|---|---|---|---|---|"]
    for name in dict.fromkeys(r["robot"] for r in rows):
        mine = [r for r in rows if r["robot"] == name]
        first = Counter(r["first_failed"] for r in mine if r["verdict"] != "feasible")
        ok = sum(r["verdict"] == "feasible" and r["sim"] == "success" for r in mine)
        bad = sum(r["verdict"] == "feasible" and r["sim"] == "failure" for r in mine)
        if mine[0]["raw_urdf"]:
            both = mine + [r for r in rows if r["robot"] == mine[0]["preset"]]
            (k, n), (kc, nc) = versus_preset(both), versus_preset(both, carrying=True)
            paired = f"{k} of {n} / {kc} of {nc}" if n else "-"
        else:
            paired = "(preset)"
        lines.append(f"| {name} | {'URDF, own start' if mine[0]['raw_urdf'] else 'preset'} | {len(mine)} | "
                     f"{sum(r['verdict'] == 'feasible' for r in mine)} | "
                     f"{', '.join(f'{k} {v}' for k, v in first.most_common()) or '-'} | "
                     f"{sum(bool(r['at_start']) for r in mine)} | {sum(not carries(r) for r in mine)} | "
                     f"{sum(r['sim'] != 'not run' for r in mine)} | {ok} | {bad} | {paired} |")
    feasible = sum(r["verdict"] == "feasible" for r in rows)
    failing = sum(r["verdict"] == "feasible" and r["sim"] == "failure" for r in rows)
    lines += ["", f"{feasible} of {len(rows)} plans feasible; {failing} feasible plans fail in MuJoCo; "
              f"raw URDFs feasible where the preset's version is: {_share(*versus_preset(rows))} of all such rows, "
              f"{_share(*versus_preset(rows, carrying=True))} of those whose start posture can carry the load"]
    return "\n".join(lines)


def out_dir(path: Path) -> Path:
    """``path`` made by this script (fresh, or holding its marker); anything else is refused."""
    if path.exists() and not (path / MARKER).is_file() and (not path.is_dir() or any(path.iterdir())):
        sys.exit(f"feasibility_matrix: error: {path}: exists and was not made by this script; give a fresh --out")
    path.mkdir(parents=True, exist_ok=True)
    (path / MARKER).write_text("made by benchmarks/feasibility_matrix.py\n")
    return path


def write_rows(rows: list[dict[str, Any]], out: Path) -> None:
    """``rows.csv``, ``rows.json`` and ``table.md`` in ``out``."""
    with (out / "rows.csv").open("w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    (out / "rows.json").write_text(json.dumps(rows, indent=1))
    (out / "table.md").write_text(table(rows) + "\n")


def parse(argv: list[str] | None = None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true",
                    help="every robot x forward and sideways 0.3 m in 5 s x 1.5 kg x 31 samples (20 cells)")
    ap.add_argument("--robots", nargs="+", choices=list(ROBOTS), default=list(ROBOTS))
    ap.add_argument("--kinds", nargs="+", choices=KINDS, default=list(KINDS))
    ap.add_argument("--sizes", nargs="+", type=float, choices=list(SIZES), default=list(SIZES))
    ap.add_argument("--payloads", nargs="+", type=float, default=list(PAYLOADS))
    ap.add_argument("--samples", nargs="+", type=int, default=list(SAMPLES))
    ap.add_argument("--jobs", type=int, default=1, help="worker processes (default 1)")
    ap.add_argument("--out", type=Path, help="a fresh directory for rows.csv, rows.json, table.md")
    ap.add_argument("--tables", type=Path, nargs="+", metavar="DIR",
                    help="plan nothing: print the table of the rows.json of earlier runs' --out, together")
    args = ap.parse_args(argv)
    if (args.out is None) == (args.tables is None):
        ap.error("give --out (run the matrix) or --tables (print earlier runs' table)")
    if args.quick:
        args.kinds, args.sizes, args.payloads, args.samples = ["forward", "sideways"], [0.3], [1.5], [31]
    return args


def main(argv: list[str] | None = None) -> int:
    args = parse(argv)
    if args.tables:
        rows = [row for directory in args.tables for row in json.loads((directory / "rows.json").read_text())]
        print(table(rows))
        return 0
    out = out_dir(args.out)
    (out / "rows.jsonl").unlink(missing_ok=True)
    cells = build_matrix(args.robots, args.kinds, args.sizes, args.payloads, args.samples)
    print(f"{len(cells)} cells", file=sys.stderr)
    start, rows = time.perf_counter(), []

    def report(row: dict[str, Any]) -> None:
        rows.append(row)
        with (out / "rows.jsonl").open("a") as handle:  # kept when the run is interrupted
            handle.write(json.dumps(row) + "\n")
        print(f"[{len(rows)}/{len(cells)} {time.perf_counter() - start:5.0f} s] {row['robot']:11s} "
              f"{row['reach']:12s} {row['distance_m']:.1f} m {row['payload_kg']:.1f} kg N={row['samples']:2d}: "
              f"{row['verdict']:13s} {row['failed'] or '-':22s} sim {row['sim']} {row['sim_reason']} "
              f"{row['reason'][:90] if row['verdict'] != 'feasible' else ''}", file=sys.stderr, flush=True)

    if args.jobs > 1:
        with ProcessPoolExecutor(args.jobs) as pool:
            for row in pool.map(run_cell, cells):
                report(row)
    else:
        for cell in cells:
            report(run_cell(cell))
    write_rows(rows, out)
    print(table(rows))
    print(f"\n({len(cells)} cells, {time.perf_counter() - start:.0f} s wall, --jobs {args.jobs}; rows in {out})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
