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

from forte.planning.ik import initial_guess
from forte.planning.optimizer import TrajectoryOptimizer
from forte.planning.planner import plan
from forte.planning.tasks import load_task
from forte.settings import SolverOptions

LIFT = Path(__file__).resolve().parents[1] / "examples" / "tasks" / "lift.yaml"


def compare(n: int = 25, max_iter: int = 300) -> None:
    task = load_task(LIFT, waypoints=n)
    force = task.force()
    opt = TrajectoryOptimizer(task.robot, n, "forte", task.weights, options=SolverOptions(codegen=False),
                              limits=task.limits)
    p = opt.parameters(task.t, task.targets, force.f, force.r)
    oracle = opt.solver.oracle()
    fixed = task.q_init

    def full(z: np.ndarray) -> np.ndarray:
        return np.concatenate([fixed, z])

    def cost(z: np.ndarray) -> float:
        return float(oracle(x=full(z), p=p)["f"])

    n_pose = 6 * (n - 1)
    bounds = opt.bounds(task.t, task.q_init)  # the rows after the pose rows: kinematic (and lifting) rows
    lower_g, upper_g = bounds.lbg[n_pose:], bounds.ubg[n_pose:]

    def rows(z: np.ndarray) -> np.ndarray:
        return np.array(oracle(x=full(z), p=p)["g"]).ravel()

    def equalities(z: np.ndarray) -> np.ndarray:
        return rows(z)[:n_pose]

    def inequalities(z: np.ndarray) -> np.ndarray:
        g = rows(z)[n_pose:]
        return np.concatenate([upper_g - g, g - lower_g])

    guess = initial_guess(task)[1:].ravel()
    lower = np.tile(np.r_[np.full(3, -np.inf), task.robot.lower], n - 1)
    upper = np.tile(np.r_[np.full(3, np.inf), task.robot.upper], n - 1)
    start = time.perf_counter()
    res = minimize(cost, guess, method="SLSQP", bounds=list(zip(lower, upper, strict=True)),
                   constraints=[{"type": "eq", "fun": equalities}, {"type": "ineq", "fun": inequalities}],
                   options={"maxiter": max_iter, "ftol": 1e-6})
    slsqp_time = time.perf_counter() - start
    viol = max(np.abs(equalities(res.x)).max(), np.maximum(-inequalities(res.x), 0).max())

    ours = plan(task, "forte")
    print(f"\nN = {n}: SciPy SLSQP (finite differences): {slsqp_time:.1f} s, {res.nit} iterations, "
          f"objective {res.fun:.2f}, max constraint violation {viol:.1e}, success={res.success} ({res.message})")
    print(f"N = {n}: forte (IPOPT, exact derivatives, compiled kernels): {ours.solver['solve_time_s']:.3f} s, "
          f"{ours.solver['iterations']} iterations, objective {ours.solver['objective']:.2f}")
    print(f"speed-up: {slsqp_time / ours.solver['solve_time_s']:.0f}x")


if __name__ == "__main__":
    compare()
