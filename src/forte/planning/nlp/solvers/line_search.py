"""IPOPT's filter line search, simplified, for the stagewise interior-point method.

With ``theta = |c|_1 + |A y + b - s|_1`` the constraint violation and ``phi = f - mu sum log(slack)``
the barrier objective, a trial point ``y + alpha dy`` is accepted (Waechter and Biegler 2006)

- by the Armijo condition ``phi <= phi0 + eta alpha grad phi^T d`` when the step is a descent
  direction that dominates the violation (the switching condition
  ``alpha (-grad phi^T d)^2.3 > theta0^1.1``) and the violation is small; or
- when it decreases ``theta`` by a factor ``1 - 1e-5`` or ``phi`` by ``1e-8 theta0``, and no
  entry of the filter (pairs ``(theta, phi)`` of earlier steps of this barrier problem)
  dominates it; the step then adds the current point's envelope to the filter.

On the first rejection with a growing violation one second-order correction of the pose rows
(Maratos effect): ``dy + Y R^-T (-c(y + alpha dy)) / alpha``, the slacks following it. What is
left out of IPOPT's: the restoration phase (the smallest step is taken when every trial fails;
the solve then ends by its iteration limit, unconverged, never reported as a success).
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

from forte.validation import FloatArray


class Trial(NamedTuple):
    """An accepted trial point and what was evaluated there."""

    y: FloatArray
    f: float
    c: FloatArray
    data: Any
    alpha: float
    dy: FloatArray


def barrier_objective(f: float, s: FloatArray, data: Any, mu: float) -> float:
    """``f - mu sum log(slack)`` over the finite bounds (``inf`` outside them)."""
    lo, up = data.lo, data.up
    sl, su = (s - data.lower)[lo], (data.upper - s)[up]
    if (sl <= 0).any() or (su <= 0).any():
        return np.inf
    return f - mu * (np.log(sl).sum() + np.log(su).sum())


class FilterLineSearch:
    """The filter of one barrier problem and the backtracking over a Newton step."""

    def __init__(self, problem: Any) -> None:
        self.pb = problem
        self.reset()

    def reset(self) -> None:
        self.entries: list[tuple[float, float]] = []
        self.mu, self.theta_max = -1.0, np.inf

    def search(self, it: Any, ev: Any, data: Any, dy: FloatArray, ds: FloatArray, parts: tuple, a_max: float
               ) -> tuple[float, FloatArray, Trial | None]:
        """``(alpha, step, trial)``: the accepted step length, the step (``dy`` or its second-order
        correction) and the accepted plain trial point (None for a correction)."""
        pb, mu = self.pb, it.mu
        _, _, _, sl, su, lo, up, Y, R = parts
        theta0 = float(np.abs(ev.c).sum() + np.abs(ev.rA).sum())
        phi0 = barrier_objective(ev.f, it.s, data, mu)
        slope = float(ev.grad @ dy - mu * (ds[lo] / sl[lo]).sum() + mu * (ds[up] / su[up]).sum())
        if self.mu != mu:  # a new barrier problem: a new filter
            self.entries, self.mu, self.theta_max = [], mu, 1e4 * max(1.0, theta0)
        ref = (theta0, phi0, slope)
        alpha, soc_tried = a_max, False
        for _ in range(30):
            y = it.y + alpha * dy
            c = pb.pose(y, data)
            f = it.scale * pb.objective(y, data)
            theta = float(np.abs(c).sum() + (1 - alpha) * np.abs(ev.rA).sum())
            if self._accept(theta, barrier_objective(f, it.s + alpha * ds, data, mu), ref, alpha):
                return alpha, dy, Trial(y, f, c, data, alpha, dy)
            if not soc_tried and theta >= theta0:
                soc_tried = True
                corr = np.zeros((pb.blocks, pb.nq))
                corr[pb.posed_block] = np.einsum(
                    "pij,pj->pi", Y, -np.linalg.solve(R.transpose(0, 2, 1), c[..., None])[..., 0])
                dy2 = dy + corr.ravel() / max(alpha, 1e-12)
                y2 = it.y + alpha * dy2
                theta2 = float(np.abs(pb.pose(y2, data)).sum() + (1 - alpha) * np.abs(ev.rA).sum())
                ds2 = pb.A @ dy2 + ev.rA  # the slacks follow the corrected step
                phi2 = barrier_objective(it.scale * pb.objective(y2, data), it.s + alpha * ds2, data, mu)
                if self._accept(theta2, phi2, ref, alpha):
                    return alpha, dy2, None
            alpha /= 2
            if alpha < 1e-10:
                break
        return alpha, dy, None

    def _accept(self, theta: float, phi: float, ref: tuple[float, float, float], alpha: float) -> bool:
        """Whether the trial is acceptable (a filter step also adds the current point's envelope)."""
        theta0, phi0, slope = ref
        if not np.isfinite(phi) or theta >= self.theta_max:
            return False
        if any(theta >= t and phi >= f for t, f in self.entries):
            return False
        switching = slope < 0 and alpha * (-slope) ** 2.3 > theta0 ** 1.1
        armijo = phi <= phi0 + 1e-4 * alpha * slope
        if switching and theta0 <= 1e-4 * max(1.0, self.theta_max / 1e4):
            return armijo
        if theta <= (1 - 1e-5) * theta0 or phi <= phi0 - 1e-8 * theta0:
            if not (switching and armijo):
                self.entries.append((0.99999 * theta0, phi0 - 1e-8 * theta0))
            return True
        return False
