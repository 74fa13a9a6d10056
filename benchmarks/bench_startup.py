"""Cold-start benchmark (issue 15, item 2). Prints its figures; nothing is asserted.

Run: python benchmarks/bench_startup.py [--runs 5] [--waypoints 100] [--compile] [--methods a,b]
     [--env KEY=VALUE ...]

1. ``forte plan examples/tasks/lift.yaml --waypoints 100`` in a fresh process with the kernels
   cached, without and with figures: median wall time of ``--runs`` runs (and its CPU time, user
   + system, which a busy machine inflates less);
2. the import time of ``forte.cli.main`` and of building the CLI parser (which imports every
   command module) in a fresh process;
3. with ``--compile``: the first-ever run of every optimized method (``--no-figures``, the task's
   own N) in a fresh, empty kernel cache: wall time and the build time the planner reports
   (kernel generation + C compilation + NLP construction).

``--env OPENBLAS_NUM_THREADS=2`` runs every process with that variable (e.g. to compare with the
CLI's single-threaded BLAS default). Timings depend on the machine and its load: run it on a
quiet machine and compare medians.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
LIFT = ROOT / "examples" / "tasks" / "lift.yaml"


def timed(cmd: list[str], env: dict[str, str]) -> tuple[float, float]:
    """(wall, cpu) seconds of one child process (cpu: user + system of the child and its children)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    proc = subprocess.run(cmd, env=env, capture_output=True, text=True, check=False)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode not in (0, 1):  # 1: a plan that ran (e.g. insufficient capacity) still counts
        raise SystemExit(f"{' '.join(cmd)} failed ({proc.returncode}): {proc.stderr.strip()[-500:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def plan_cmd(out: Path, waypoints: int | None, method: str, figures: bool) -> list[str]:
    cmd = [sys.executable, "-m", "forte.cli", "plan", str(LIFT), "--method", method, "--out", str(out), "--quiet"]
    if waypoints:
        cmd += ["--waypoints", str(waypoints)]
    return cmd + ([] if figures else ["--no-figures"])


def median_runs(runs: int, cmd: list[str], env: dict[str, str]) -> tuple[float, float, list[float]]:
    samples = [timed(cmd, env) for _ in range(runs)]
    walls = [w for w, _ in samples]
    return statistics.median(walls), statistics.median(c for _, c in samples), walls


def import_times(runs: int, env: dict[str, str]) -> tuple[float, float]:
    """Median seconds to import forte.cli.main, and to build the parser (every command module)."""
    code = ("import sys, time; t = time.perf_counter(); import forte.cli.main; a = time.perf_counter() - t; "
            "sys.modules['forte.cli.main'].build_parser(); print(a, time.perf_counter() - t)")
    rows = [subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                           check=True).stdout.split() for _ in range(runs)]
    return statistics.median(float(r[0]) for r in rows), statistics.median(float(r[1]) for r in rows)


def first_compile(method: str, env: dict[str, str]) -> tuple[float, float, float]:
    """(wall, cpu, build_time_s) of a run of ``method`` in an empty kernel cache."""
    with tempfile.TemporaryDirectory() as cache, tempfile.TemporaryDirectory() as out:
        target = Path(out) / "plan"
        wall, cpu = timed(plan_cmd(target, None, method, figures=False), dict(env, FORTE_CACHE=cache))
        solver = json.loads((target / "plan.json").read_text())["solver"]
        return wall, cpu, float(solver.get("build_time_s", float("nan")))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--waypoints", type=int, default=100)
    parser.add_argument("--method", default="forte", help="method of the cached-kernel runs (default forte)")
    parser.add_argument("--compile", action="store_true", help="also time first-ever compilation per method")
    parser.add_argument("--methods", help="comma-separated methods for --compile (default: every optimized one)")
    parser.add_argument("--env", action="append", default=[], metavar="KEY=VALUE")
    args = parser.parse_args()
    env = dict(os.environ)
    env.update(kv.split("=", 1) for kv in args.env)
    env.setdefault("PYTHONPATH", str(ROOT / "src"))
    print(f"python {sys.version.split()[0]}, {os.cpu_count()} CPUs, load average "
          f"{', '.join(f'{x:.2f}' for x in os.getloadavg())}" + (f", env {' '.join(args.env)}" if args.env else ""))

    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "plan"
        timed(plan_cmd(out, args.waypoints, args.method, figures=False), env)  # kernels cached, files warm
        for figures in (False, True):
            wall, cpu, walls = median_runs(args.runs, plan_cmd(out, args.waypoints, args.method, figures), env)
            label = "with figures   " if figures else "without figures"
            print(f"cold `forte plan lift.yaml --waypoints {args.waypoints} --method {args.method}` {label}: "
                  f"median {wall:.2f} s wall, {cpu:.2f} s CPU (runs {', '.join(f'{w:.2f}' for w in walls)})")
    imp, parser_time = import_times(args.runs, env)
    print(f"import forte.cli.main: {imp * 1e3:.0f} ms; + build_parser (every command module): "
          f"{parser_time * 1e3:.0f} ms")

    if args.compile:
        from forte.planning.methods.catalog import method_names

        methods = args.methods.split(",") if args.methods else method_names(optimized=True)
        print("\nfirst-ever run per method (empty kernel cache, lift.yaml, --no-figures):")
        print(f"{'method':>16} | wall (s) | CPU (s) | build incl. compile (s)")
        for method in methods:
            wall, cpu, build = first_compile(method, env)
            print(f"{method:>16} | {wall:8.2f} | {cpu:7.2f} | {build:8.2f}")


if __name__ == "__main__":
    main()
