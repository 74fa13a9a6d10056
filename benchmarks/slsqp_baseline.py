"""A naive baseline for the benchmark only: SciPy SLSQP with finite-difference gradients.

Same NLP as forte's (cost, pose equality constraints, joint bounds, q_1 fixed), evaluated with
the same CasADi functions, but SLSQP estimates every gradient and constraint Jacobian by finite
differences, as one would without automatic differentiation.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
from scipy.optimize import minimize

from forte.optimizer import SolverOptions, TrajectoryOptimizer
from forte.planner import initial_guess, plan
from forte.tasks import load_task

LIFT = Path(__file__).resolve().parents[1] / "examples" / "tasks" / "lift.yaml"


def compare(n: int = 25, max_iter: int = 300) -> None:
    task = load_task(LIFT, waypoints=n)
    force = task.force()
    opt = TrajectoryOptimizer(task.robot, n, "forte", task.weights, options=SolverOptions(codegen=False))
    p = opt.parameters(task.t, task.targets, force.f, force.r)
    oracle = opt.solver.oracle()
    nq = task.robot.nq
    fixed = task.q_init

    def full(z: np.ndarray) -> np.ndarray:
        return np.concatenate([fixed, z])

    def cost(z: np.ndarray) -> float:
        return float(oracle(x=full(z), p=p)["f"])

    def constraints(z: np.ndarray) -> np.ndarray:
        return np.array(oracle(x=full(z), p=p)["g"]).ravel()

    guess = initial_guess(task)[1:].ravel()
    lower = np.tile(np.r_[np.full(3, -np.inf), task.robot.lower], n - 1)
    upper = np.tile(np.r_[np.full(3, np.inf), task.robot.upper], n - 1)
    start = time.perf_counter()
    res = minimize(cost, guess, method="SLSQP", bounds=list(zip(lower, upper, strict=True)),
                   constraints=[{"type": "eq", "fun": constraints}], options={"maxiter": max_iter, "ftol": 1e-6})
    slsqp_time = time.perf_counter() - start
    viol = np.abs(constraints(res.x)).max()

    ours = plan(task, "forte")
    print(f"\nN = {n}: SciPy SLSQP (finite differences): {slsqp_time:.1f} s, {res.nit} iterations, "
          f"objective {res.fun:.2f}, max constraint violation {viol:.1e}, success={res.success} ({res.message})")
    print(f"N = {n}: forte (IPOPT, exact derivatives, compiled kernels): {ours.solver['solve_time_s']:.3f} s, "
          f"{ours.solver['iterations']} iterations, objective {ours.solver['objective']:.2f}")
    print(f"speed-up: {slsqp_time / ours.solver['solve_time_s']:.0f}x")
    _ = nq


if __name__ == "__main__":
    compare()
