"""Whole-body trajectory optimization (paper, Section 4.3) with IPOPT through CasADi.

    min_Q  sum_i w_i J_i(Q)
    s.t.   x(q_k) = x_k          (end-effector position and orientation), k = 2..N
           q_a^min <= q_a,k <= q_a^max
           q_1 = q_init          (trajectory mode; free in single-point holding mode)

Design (measured choices, see ``shared/NOTES.md`` and ``benchmarks/``):

- every per-waypoint term is one small SX ``casadi.Function`` ``map``-ped over the horizon,
  so the expression graph and the exact Hessian stay linear in N;
- all task data (time steps, forces, radii, target poses, cone rays) are NLP *parameters*: a
  problem is built once per (robot, N, method, weights) and reused for every task of that size;
- optionally the NLP functions are generated as C, compiled once and cached on disk
  (``~/.cache/forte`` or ``$FORTE_CACHE``), which makes a cold run fast;
- the orientation constraint is ``vee(R_d^T R - R^T R_d) / 2 = 0`` (three equations; the
  initial guess from IK is feasible, far from the 180-degree ambiguity).
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import casadi as ca
import numpy as np

from forte import __version__
from forte.costs import (
    N_CONE_RAYS,
    CostWeights,
    capability_stage,
    cone_stage,
    dct_penalty_matrix,
    inscribed_radius_stage,
    joint_limit_stage,
    manipulability_stage,
    smoothness_weights,
)
from forte.exceptions import InvalidInputError, SolverError
from forte.polytope import cone_directions
from forte.robot import N_BASE, MobileManipulator
from forte.twin import CasadiTwin
from forte.validation import FloatArray

#: Methods solved by this optimizer (the quintic and teaching baselines are not optimized).
OPTIMIZED_METHODS: tuple[str, ...] = ("forte", "manipulability", "rfp-radius", "rfp-cone")


@dataclass(frozen=True)
class SolverOptions:
    """IPOPT and build options.

    Attributes:
        max_iter: IPOPT iteration limit.
        tol: IPOPT convergence tolerance.
        constraint_tol: accepted constraint violation for a result to count as a success.
        codegen: generate, compile and cache C code for the NLP functions (needs a C compiler;
            falls back to the CasADi virtual machine when none is found).
        cache_dir: where compiled problems are kept; default ``$FORTE_CACHE`` or ``~/.cache/forte``.
        print_level: IPOPT verbosity (0 = silent).
    """

    max_iter: int = 300
    tol: float = 1e-6
    constraint_tol: float = 1e-6
    codegen: bool = True
    cache_dir: str | None = None
    print_level: int = 0
    extra: dict[str, Any] = field(default_factory=dict)


@dataclass
class Solution:
    """Result of one optimization."""

    q: FloatArray
    success: bool
    status: str
    iterations: int
    objective: float
    constraint_violation: float
    build_time: float
    solve_time: float
    codegen: str  # "compiled", "cached", "virtual-machine"


def cache_root(options: SolverOptions) -> Path:
    root = options.cache_dir or os.environ.get("FORTE_CACHE") or Path.home() / ".cache" / "forte"
    return Path(root)


def rotation_error_expr(R: Any, R_d: Any) -> Any:
    """``vee(R_d^T R - R^T R_d) / 2`` (zero iff R = R_d near the solution)."""
    E = R_d.T @ R - R.T @ R_d
    return ca.vertcat(E[2, 1], E[0, 2], E[1, 0]) / 2


class TrajectoryOptimizer:
    """The FORTE NLP (or a baseline) for one robot, horizon ``n`` and method.

    Args:
        robot: The mobile manipulator.
        n: Number of waypoints (1 gives single-point holding).
        method: One of :data:`OPTIMIZED_METHODS`.
        weights: Cost weights and term parameters.
        fix_initial: Fix ``q_1 = q_init`` (trajectory mode). With ``False`` (holding), the
            first configuration is free and ``q_init`` only seeds the solver.
        options: Solver and build options.
    """

    def __init__(
        self, robot: MobileManipulator, n: int, method: str = "forte",
        weights: CostWeights = CostWeights(), fix_initial: bool = True,
        options: SolverOptions = SolverOptions(),
    ) -> None:
        if method not in OPTIMIZED_METHODS:
            raise InvalidInputError(f"method: expected one of {', '.join(OPTIMIZED_METHODS)}, got '{method}'")
        if n < 1:
            raise InvalidInputError(f"waypoints: expected at least 1, got {n}")
        self.robot, self.n, self.method = robot, n, method
        self.weights, self.fix_initial, self.options = weights, fix_initial, options
        start = time.perf_counter()
        self._build()
        self.build_time = time.perf_counter() - start

    # -- construction -------------------------------------------------------------------
    def _parameter_layout(self) -> dict[str, tuple[int, int]]:
        n = self.n
        sizes = {"dt": n, "f": 3 * n, "r": n, "p_d": 3 * n, "R_d": 9 * n}
        if self.method == "rfp-cone":
            sizes["rays"] = 3 * N_CONE_RAYS * n
        layout, offset = {}, 0
        for name, size in sizes.items():
            layout[name] = (offset, size)
            offset += size
        return layout

    def _symbolic_problem(self) -> dict[str, Any]:
        robot, n, w = self.robot, self.n, self.weights
        nq = robot.nq
        twin = CasadiTwin(robot)
        self._layout = self._parameter_layout()
        P = ca.MX.sym("p", sum(size for _, size in self._layout.values()))

        def par(name: str, rows: int) -> ca.MX:
            off, size = self._layout[name]
            return ca.reshape(P[off:off + size], rows, size // rows)

        x = ca.MX.sym("x", nq * n)
        X = ca.reshape(x, nq, n)
        dt = par("dt", 1)
        f, r = par("f", 3), par("r", 1)
        prev = ca.horzcat(X[:, 0], X[:, : n - 1])
        prev2 = ca.horzcat(X[:, 0], X[:, 0], X[:, : max(n - 2, 0)])[:, :n]
        dt_prev = ca.horzcat(ca.MX(1), dt[:, : n - 1])
        tau_max = robot.torque_limits
        params = w.capability_params
        terms: dict[str, ca.MX] = {}
        if self.method == "forte":
            stage = capability_stage(twin, tau_max, params)
            terms["capability"] = ca.sum2(stage.map(n)(prev2, prev, X, dt_prev, dt, f, r))
        elif self.method == "rfp-radius":
            stage = inscribed_radius_stage(twin, tau_max, params)
            terms["capability"] = ca.sum2(stage.map(n)(prev2, prev, X, dt_prev, dt, f, r))
        elif self.method == "rfp-cone":
            stage = cone_stage(twin, tau_max, params)
            rays = par("rays", 3 * N_CONE_RAYS)
            # each column holds one waypoint's M x 3 rays, row-major
            cols = [ca.reshape(rays[:, k], 3, N_CONE_RAYS).T for k in range(n)]
            mapped = stage.map(n)
            terms["capability"] = ca.sum2(
                mapped(prev2, prev, X, dt_prev, dt, f, r, ca.horzcat(*cols))
            )
        terms["manipulability"] = ca.sum2(manipulability_stage(twin, w).map(n)(X))
        terms["joint_limits"] = ca.sum2(joint_limit_stage(robot.lower, robot.upper, w).map(n)(X))
        Ws = ca.DM(smoothness_weights(robot.n_arm, w))
        if n > 1:
            diffs = X[:, 1:] - X[:, :-1]
            terms["smoothness"] = 0.5 * ca.sumsqr(ca.repmat(Ws, 1, n - 1) * diffs)
            Pm = ca.DM(dct_penalty_matrix(n, w))
            terms["base_spectral"] = 0.5 * sum(
                eta * ca.bilin(Pm, X[i, :].T, X[i, :].T) for i, eta in enumerate(w.dct_axis)
            )
        weight_of = {"capability": w.capability, "manipulability": w.manipulability,
                     "joint_limits": w.joint_limits, "smoothness": w.smoothness,
                     "base_spectral": w.base_spectral}
        cost = sum(weight_of[k] * v for k, v in terms.items())
        # pose constraints
        q = ca.SX.sym("q", nq)
        pd, Rd = ca.SX.sym("p_d", 3), ca.SX.sym("R_d", 9)
        R, p = twin.ee_pose(q)
        pose = ca.Function("pose", [q, pd, Rd], [ca.vertcat(p - pd, rotation_error_expr(R, ca.reshape(Rd, 3, 3)))])
        first = 1 if self.fix_initial else 0
        g = pose.map(n)(X, par("p_d", 3), par("R_d", 9))[:, first:]
        self._terms = ca.Function("terms", [x, P], [ca.vertcat(*terms.values())])
        self._term_names = list(terms)
        return {"x": x, "p": P, "f": cost, "g": ca.vec(g)}

    def _key(self) -> str:
        text = repr((__version__, self.robot.fingerprint, self.n, self.method, self.weights,
                     self.fix_initial, ca.__version__, _source_digest()))
        return hashlib.sha256(text.encode()).hexdigest()[:20]

    def _ipopt_options(self) -> dict[str, Any]:
        o = self.options
        opts = {
            "ipopt.max_iter": o.max_iter, "ipopt.tol": o.tol, "ipopt.print_level": o.print_level,
            "ipopt.sb": "yes", "print_time": False, "ipopt.constr_viol_tol": o.constraint_tol,
            "ipopt.mu_strategy": "adaptive",
        }
        opts.update({k if "." in k else f"ipopt.{k}": v for k, v in o.extra.items()})
        return opts

    def _build(self) -> None:
        nlp = self._symbolic_problem()
        opts = self._ipopt_options()
        self.codegen = "virtual-machine"
        compiler = shutil.which("gcc") or shutil.which("cc")
        if self.options.codegen and compiler:
            lib = cache_root(self.options) / f"nlp_{self._key()}.so"
            if not lib.exists():
                self._compile(nlp, opts, lib, compiler)
                self.codegen = "compiled"
            else:
                self.codegen = "cached"
            self.solver = ca.nlpsol("forte", "ipopt", str(lib), opts)
        else:
            self.solver = ca.nlpsol("forte", "ipopt", nlp, opts)
        self._g = ca.Function("g", [nlp["x"], nlp["p"]], [nlp["g"]])

    def _compile(self, nlp: dict[str, Any], opts: dict[str, Any], lib: Path, compiler: str) -> None:
        lib.parent.mkdir(parents=True, exist_ok=True)
        solver = ca.nlpsol("forte", "ipopt", nlp, opts)
        with tempfile.TemporaryDirectory(dir=lib.parent) as tmp:
            cwd = os.getcwd()
            try:
                os.chdir(tmp)
                solver.generate_dependencies("nlp.c")
            finally:
                os.chdir(cwd)
            src, out = Path(tmp) / "nlp.c", Path(tmp) / "nlp.so"
            cmd = [compiler, "-O1", "-fPIC", "-shared", str(src), "-o", str(out), "-lm"]
            proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
            if proc.returncode != 0:
                raise SolverError(f"compiling the NLP failed: {proc.stderr[-2000:]}", status="codegen")
            os.replace(out, lib)  # atomic: concurrent runs never load a half-written library

    # -- solving ------------------------------------------------------------------------
    def parameters(self, t: FloatArray, targets: FloatArray, f: FloatArray, r: FloatArray) -> FloatArray:
        """Pack the task data into the NLP parameter vector."""
        n = self.n
        t = np.asarray(t, dtype=float)
        dt = np.ones(n)
        dt[1:] = np.diff(t)
        values = {
            "dt": dt,
            "f": np.asarray(f, dtype=float).T.ravel(order="F"),
            "r": np.asarray(r, dtype=float),
            "p_d": targets[:, :3, 3].T.ravel(order="F"),
            "R_d": np.concatenate([T[:3, :3].ravel(order="F") for T in targets]),
        }
        if "rays" in self._layout:
            dirs = []
            for fk in np.asarray(f, dtype=float):
                u = fk if np.linalg.norm(fk) > 1e-9 else np.array([0.0, 0.0, 1.0])
                dirs.append(cone_directions(u).ravel())  # row-major M x 3
            values["rays"] = np.concatenate(dirs)
        return np.concatenate([values[name] for name in self._layout])

    def solve(self, t: Any, targets: Any, f: Any, r: Any, q_init: FloatArray, q_guess: FloatArray) -> Solution:
        """Solve for the whole-body trajectory (N x nq) from the initial guess ``q_guess``."""
        n, nq = self.n, self.robot.nq
        targets = np.asarray(targets, dtype=float)
        p = self.parameters(t, targets, f, r)
        lbx = np.tile(np.r_[np.full(N_BASE, -np.inf), self.robot.lower], n)
        ubx = np.tile(np.r_[np.full(N_BASE, np.inf), self.robot.upper], n)
        if self.fix_initial:
            lbx[:nq] = ubx[:nq] = q_init
        x0 = np.clip(np.asarray(q_guess, dtype=float).ravel(), lbx, ubx)
        start = time.perf_counter()
        result = self.solver(x0=x0, p=p, lbx=lbx, ubx=ubx, lbg=0, ubg=0)
        solve_time = time.perf_counter() - start
        stats = self.solver.stats()
        x = np.array(result["x"]).ravel()
        g = np.array(self._g(x, p)).ravel()
        bounds = np.maximum(np.maximum(lbx - x, x - ubx), 0)
        violation = float(max(np.abs(g).max(initial=0.0), bounds.max(initial=0.0)))
        status = str(stats.get("return_status", "unknown"))
        success = bool(stats.get("success", False)) and violation <= max(1e-5, 10 * self.options.constraint_tol)
        return Solution(
            q=x.reshape(n, nq), success=success, status=status,
            iterations=int(stats.get("iter_count", -1)), objective=float(result["f"]),
            constraint_violation=violation, build_time=self.build_time, solve_time=solve_time,
            codegen=self.codegen,
        )

    def cost_terms(self, q: FloatArray, t: Any, targets: Any, f: Any, r: Any) -> dict[str, float]:
        """Unweighted values of each cost term (the capability term is the smooth surrogate)."""
        p = self.parameters(t, np.asarray(targets, dtype=float), f, r)
        values = np.array(self._terms(np.asarray(q, dtype=float).ravel(), p)).ravel()
        return dict(zip(self._term_names, map(float, values), strict=True))


def _source_digest() -> str:
    """Hash of the modules that define the NLP, so editing them invalidates the cache."""
    here = Path(__file__).parent
    digest = hashlib.sha256()
    for name in ("optimizer.py", "costs.py", "metrics.py", "twin.py"):
        digest.update((here / name).read_bytes())
    return digest.hexdigest()[:12]
