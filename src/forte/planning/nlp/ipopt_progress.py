"""IPOPT's iterations on the progress line, through CasADi's ``iteration_callback`` option.

The callback is installed only while a progress reporter is active (:mod:`forte.progress`), so
the library API pays nothing by default. Per iteration it reads the objective and the constraint
values CasADi passes and reports ``iteration k: objective f, constraint violation v``, where
``v = max(lbg - g, g - ubg, 0)`` over the NLP's constraints (pose residuals and kinematic rows),
and the exact capability margin ``min_k d_k`` of the current iterate (about 1 ms at N = 41).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import casadi as ca
import numpy as np

from forte import progress


class IpoptProgress(ca.Callback):
    """A CasADi callback that reports each IPOPT iteration to the active reporter."""

    def __init__(self, nx: int, ng: int, npar: int) -> None:
        ca.Callback.__init__(self)
        self.nx, self.ng, self.npar = nx, ng, npar
        self.iteration = 0
        self.bounds: tuple[np.ndarray, np.ndarray] | None = None  # (lbg, ubg), set by each solve
        self.margin: Callable[[np.ndarray], float] | None = None  # x -> min_k d_k, set by each solve
        self.construct("forte_ipopt_progress", {})

    def get_n_in(self) -> int:
        return ca.nlpsol_n_out()

    def get_n_out(self) -> int:
        return 1

    def get_name_in(self, i: int) -> str:
        return ca.nlpsol_out(i)

    def get_name_out(self, i: int) -> str:
        return "ret"

    def get_sparsity_in(self, i: int) -> Any:
        n = ca.nlpsol_out(i)
        size = {"f": 1, "x": self.nx, "lam_x": self.nx, "g": self.ng, "lam_g": self.ng, "p": self.npar,
                "lam_p": self.npar}.get(n, 0)
        return ca.Sparsity.dense(size, 1)

    def start(self, lbg: np.ndarray, ubg: np.ndarray, margin: Callable[[np.ndarray], float] | None = None) -> None:
        """Before a solve: the constraint bounds, the margin function and the iteration count."""
        self.bounds, self.margin, self.iteration = (lbg, ubg), margin, 0

    def eval(self, arg: list[Any]) -> list[int]:
        names = [ca.nlpsol_out(i) for i in range(ca.nlpsol_n_out())]
        values = dict(zip(names, arg, strict=True))
        f = float(values["f"])
        text = f"IPOPT iteration {self.iteration}: objective {f:.6g}"
        if self.bounds is not None and self.ng:
            g = np.asarray(values["g"]).ravel()
            lbg, ubg = self.bounds
            violation = float(np.max(np.maximum(np.maximum(lbg - g, g - ubg), 0.0)))
            text += f", constraint violation {violation:.2e}"
        if self.margin is not None:
            text += f", min d {self.margin(np.asarray(values['x']).ravel()):.2f} N"
        progress.update(text)
        self.iteration += 1
        return [0]


def margin_of(robot: Any, n: int, t: np.ndarray, f: Any, r: Any, alpha: float) -> Callable[[np.ndarray], float]:
    """``x -> min_k d_k``, the exact capability margin of an iterate ``x`` (its first ``n nq``
    entries: the configurations) for the times ``t``, forces ``f`` and radii ``r``."""
    from forte.capability.metrics import min_margin

    f, r = np.asarray(f, dtype=float), np.asarray(r, dtype=float)
    times = t if n > 1 else np.zeros(1)

    def margin(x: np.ndarray) -> float:
        return min_margin(robot, x[: n * robot.nq].reshape(n, robot.nq), times, f, r, alpha)
    return margin
