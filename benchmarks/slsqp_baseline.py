"""A naive baseline for the benchmark only: SciPy SLSQP with finite-difference gradients.

Same NLP as forte's (cost, every constraint row and bound, q_1 fixed), evaluated with the same
CasADi functions, but SLSQP estimates every gradient and constraint Jacobian by finite
differences, as one would without automatic differentiation.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
from scipy.optimize import minimize

from forte.planning.nlp.optimizer import TrajectoryOptimizer
from forte.planning.planner import plan
from forte.planning.tasks.ik import initial_guess
from forte.planning.tasks.tasks import load_task
from forte.settings import SolverOptions

LIFT = Path(__file__).resolve().parents[1] / "examples" / "tasks" / "lift.yaml"


def compare(n: int = 25, max_iter: int = 300) -> None:
    task = load_task(LIFT, waypoints=n)
    force = task.force()
    opt = TrajectoryOptimizer(task.robot, n, "forte", task.weights, options=SolverOptions(codegen=False),
                              limits=task.limits, settings=task.settings)
    p = opt.parameters(task.t, task.targets, force.f, force.r)
    oracle = opt.solver.oracle()
    # The NLP's own bounds decide everything, whatever the layout (pinned start, end-at-rest rows,
    # lifted J5 variables): variables with lbx == ubx are fixed, rows with lbg == ubg are equalities.
    lbx, ubx, lbg, ubg = opt.bounds(task.t, task.q_init)
    x0 = opt.full_x(np.clip(initial_guess(task).ravel(), lbx[: n * task.robot.nq], ubx[: n * task.robot.nq]))
    free = lbx < ubx
    eq = lbg == ubg
    has_lo, has_hi = ~eq & np.isfinite(lbg), ~eq & np.isfinite(ubg)

    def full(z: np.ndarray) -> np.ndarray:
        x = np.where(free, 0.0, lbx)
        x[free] = z
        return x

    def cost(z: np.ndarray) -> float:
        return float(oracle(x=full(z), p=p)["f"])

    def rows(z: np.ndarray) -> np.ndarray:
        return np.array(oracle(x=full(z), p=p)["g"]).ravel()

    def equalities(z: np.ndarray) -> np.ndarray:
        return rows(z)[eq] - lbg[eq]

    def inequalities(z: np.ndarray) -> np.ndarray:
        g = rows(z)
        return np.concatenate([ubg[has_hi] - g[has_hi], g[has_lo] - lbg[has_lo]])

    bounds = [(lo if np.isfinite(lo) else None, hi if np.isfinite(hi) else None)
              for lo, hi in zip(lbx[free], ubx[free], strict=True)]
    start = time.perf_counter()
    res = minimize(cost, x0[free], method="SLSQP", bounds=bounds,
                   constraints=[{"type": "eq", "fun": equalities}, {"type": "ineq", "fun": inequalities}],
                   options={"maxiter": max_iter, "ftol": 1e-6})
    slsqp_time = time.perf_counter() - start
    viol = max(np.abs(equalities(res.x)).max(initial=0.0), np.maximum(-inequalities(res.x), 0).max(initial=0.0))

    ours = plan(task, "forte")
    print(f"\nN = {n}: {int(free.sum())} free variables, {int(eq.sum())} equality and "
          f"{int(has_lo.sum() + has_hi.sum())} inequality rows")
    print(f"N = {n}: SciPy SLSQP (finite differences): {slsqp_time:.1f} s, {res.nit} iterations, "
          f"objective {res.fun:.2f}, max constraint violation {viol:.1e}, success={res.success} ({res.message})")
    print(f"N = {n}: forte (IPOPT, exact derivatives, compiled kernels): {ours.solver['solve_time_s']:.3f} s, "
          f"{ours.solver['iterations']} iterations, objective {ours.solver['objective']:.2f}")
    print(f"speed-up: {slsqp_time / ours.solver['solve_time_s']:.0f}x")


if __name__ == "__main__":
    compare()
