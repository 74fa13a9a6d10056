"""Sweep benchmark (issue 15, item 3): one grid on 1 and on N local workers (and on local Ray).

Run: python benchmarks/bench_sweep.py [SWEEP.yaml] [--workers N] [--ray]
     (default: examples/sweeps/demo.yaml, N = the CPUs available; prints its figures, asserts
     nothing but that every run gives the same results.csv)

Each run writes into a fresh temporary directory, so every cell is computed. Wall times include
starting the workers (spawned processes import forte: about a second each) and, with --ray,
starting a local Ray instance. Run it on a quiet machine: on a shared one the figures are noise.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

from forte.experiments.sweep.executors import default_workers
from forte.experiments.sweep.run import run_sweep

ROOT = Path(__file__).resolve().parents[1]


def timed(sweep: Path, out: Path, workers: int, ray: str | None) -> tuple[float, bytes, float]:
    """Wall time, results.csv and the summed plan + simulation seconds of the cells."""
    start = time.perf_counter()
    result = run_sweep(sweep, out, workers=workers, ray=ray, figures=False)
    wall = time.perf_counter() - start
    assert result.status == "complete", result
    timings = [json.loads(p.read_text())["timing"] for p in (out / "cells").iterdir()]
    plans = {(t["worker"], t["plan_s"]) for t in timings}  # one plan per group, repeated in its cells
    busy = sum(p for _, p in plans) + sum(t["sim_s"] for t in timings)
    return wall, (out / "results.csv").read_bytes(), busy


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("sweep", nargs="?", type=Path, default=ROOT / "examples" / "sweeps" / "demo.yaml")
    parser.add_argument("--workers", type=int, default=default_workers())
    parser.add_argument("--ray", action="store_true", help="also run on a local Ray instance")
    args = parser.parse_args()
    runs = [("pool", 1, None), ("pool", args.workers, None)] + ([("ray", args.workers, "local")] if args.ray else [])
    tables = set()
    with tempfile.TemporaryDirectory() as tmp:
        for i, (name, workers, ray) in enumerate(runs):
            wall, table, busy = timed(args.sweep, Path(tmp) / f"run{i}", workers, ray)
            tables.add(table)
            cells = table.count(b"\n") - 1
            print(f"{name:4s} {workers:3d} worker(s): {wall:7.1f} s wall for {cells} cells "
                  f"({busy:.1f} s of planning and simulation in the workers)")
    print("results.csv identical across runs:", len(tables) == 1)
    assert len(tables) == 1


if __name__ == "__main__":
    main()
