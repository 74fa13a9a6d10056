"""Core benchmark (issue 2): the numeric metric per waypoint and the CasADi J1 with its gradient.

Run: python benchmarks/bench_core.py        (prints its figures; nothing is asserted)

Targets: numeric metric <= 20 us per waypoint vectorized over N = 1000; CasADi J1 gradient at
N = 100 <= 5 ms.
"""

from __future__ import annotations

import tempfile
import time

import casadi as ca
import numpy as np

from forte.capability.metrics import CapabilityParameters, capability_margin, capability_penalty, normalization
from forte.capability.polytope import trajectory_rfp
from forte.model.robot import default_robot
from forte.model.twin import CasadiTwin
from forte.planning.methods.catalog import get_method
from forte.planning.nlp.kernels import load_kernels, stage_terms
from forte.planning.terms.reference import capability_stage
from forte.settings import CostWeights, SolverOptions


def best_of(fn, repeat: int = 7, number: int = 1) -> float:
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        for _ in range(number):
            fn()
        times.append((time.perf_counter() - start) / number)
    return min(times)


def main() -> None:
    robot = default_robot()
    params = CapabilityParameters()
    rng = np.random.default_rng(0)
    n = 1000
    t = np.linspace(0, 10, n)
    q = np.tile(robot.home(), (n, 1))
    q[:, 3:] += 0.3 * np.sin(np.linspace(0, 2 * np.pi, n))[:, None] * rng.uniform(0.5, 1, 7)
    f = np.column_stack([np.zeros(n), np.zeros(n), np.full(n, 30.0)]) + rng.normal(size=(n, 3))
    r = np.full(n, 10.0)

    rfp = trajectory_rfp(robot, q, t, alpha=params.alpha)

    def metric() -> float:
        d = capability_margin(rfp.A, rfp.b, f, r)
        return float(np.sum(capability_penalty(d, normalization(f, r), params.kappa, params.max_exponent)))

    per = best_of(metric, number=20) / n
    print(f"numeric metric (d_k, c_k, J1) from A_k, b_k, vectorized over N = {n}: {per * 1e6:.2f} us per waypoint")

    def pipeline() -> float:
        rfp2 = trajectory_rfp(robot, q, t, alpha=params.alpha)
        d = capability_margin(rfp2.A, rfp2.b, f, r)
        return float(np.sum(capability_penalty(d, normalization(f, r))))

    per_full = best_of(pipeline, repeat=3) / n
    print(f"full numeric pipeline incl. Pinocchio RNEA + Jacobian per waypoint, N = {n}: {per_full * 1e6:.2f} us"
          " per waypoint")

    # CasADi J1 (smooth surrogate) and its gradient at N = 100, from the twin
    N = 100
    dt = 0.1
    mapped = capability_stage(CasadiTwin(robot), params).map(N)
    xm, fm, rm = ca.MX.sym("x", robot.nq, N), ca.MX.sym("f", 3, N), ca.MX.sym("r", 1, N)
    prevm = ca.horzcat(xm[:, 0], xm[:, : N - 1])
    prev2m = ca.horzcat(xm[:, 0], xm[:, 0], xm[:, : N - 2])
    j1 = ca.sum2(mapped(prev2m, prevm, xm, dt, dt, fm, rm))
    J1 = ca.Function("J1", [xm, fm, rm], [j1])
    dJ1 = ca.Function("dJ1", [xm, fm, rm], [j1, ca.gradient(j1, xm)])
    qN = q[:N].T
    fN = f[:N].T
    rN = r[None, :N]
    print(f"CasADi J1 value, N = {N} (virtual machine): {best_of(lambda: J1(qN, fN, rN)) * 1e3:.2f} ms")
    print(f"CasADi J1 value + gradient, N = {N} (virtual machine): {best_of(lambda: dJ1(qN, fN, rN)) * 1e3:.2f} ms")

    # the same through the compiled per-waypoint kernels used by the optimizer
    with tempfile.TemporaryDirectory() as cache:
        start = time.perf_counter()
        kern = load_kernels(robot, "forte", CostWeights(), SolverOptions(cache_dir=cache))
        print(f"compiling the forte kernels (first use only): {time.perf_counter() - start:.1f} s")
        z = np.vstack([np.hstack([qN[:, :1], qN[:, :1], qN[:, : N - 2]]), np.hstack([qN[:, :1], qN[:, : N - 1]]), qN])
        names = [term.name for term in stage_terms(get_method("forte"), CostWeights())]
        w = np.tile(np.array([[1.0 if name == "capability" else 0.0] for name in names]), (1, N))  # J1 alone
        grad_map = kern.grad.map(N)
        cost_map = kern.cost.map(N)
        args = (z, np.ones((1, N)) * dt, np.ones((1, N)) * dt, fN, rN, qN, w)  # qN: the nominal trajectory
        value = best_of(lambda: cost_map(*args))
        both = best_of(lambda: (cost_map(*args), grad_map(*args)))
        print(f"compiled J1 value, N = {N}: {value * 1e3:.3f} ms; value + stage gradients: {both * 1e3:.3f} ms")


if __name__ == "__main__":
    main()
