"""Reference trajectories for the controllers: how the planned waypoints become ``q(t)``.

Two interpolations of the same waypoints ``q_k`` at times ``t_k``:

- ``spline`` (default): a clamped cubic spline, C2, zero velocity at the first and last waypoint
  (:func:`forte.execution.control.interpolate_plan`). Its velocities and accelerations at the
  waypoints are the spline's, not the plan's.
- ``plan``: the plan's own derivatives. The planner evaluates the dynamics (RNEA, hence the
  residual force polytope) at every waypoint with the backward differences
  ``v_k = (q_k - q_{k-1}) / dt_k`` and ``a_k = (v_k - v_{k-1}) / dt_k``, starting at rest
  (:func:`forte.model.trajectory.backward_differences`). This reference is the quintic Hermite
  interpolant that passes through every ``q_k`` with exactly that velocity and acceleration at
  ``t_k``: the controller is asked for the motion whose torques the plan checked. It is C2 and
  ends at rest when the plan does (a plan that ends at rest holds its last pose over two steps).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from forte.exceptions import InvalidInputError
from forte.execution.control import Reference, interpolate_force, interpolate_plan
from forte.model.trajectory import backward_differences, quintic_hermite
from forte.validation import as_array, check_times

#: The reference kinds of ``forte simulate --reference``.
REFERENCE_KINDS: tuple[str, ...] = ("spline", "plan")


def plan_reference(t_plan: Any, q_plan: Any, times: Any, force_t: Any = None, force: Any = None,
                   kind: str = "spline", moment: Any = None, limits: tuple[Any, Any] | None = None) -> Reference:
    """The controller's reference of a plan, sampled at ``times`` (``kind``: module docstring); the
    task ``moment`` (N x 3 at ``force_t``, or None) linear in time as the force."""
    ref = _reference(t_plan, q_plan, times, force_t, force, kind, limits)
    return ref if moment is None else replace(ref, m=interpolate_force(ref.t, force_t, moment))


def _reference(t_plan: Any, q_plan: Any, times: Any, force_t: Any, force: Any, kind: str,
               limits: tuple[Any, Any] | None = None) -> Reference:
    if kind not in REFERENCE_KINDS:
        raise InvalidInputError(f"reference: expected one of {', '.join(REFERENCE_KINDS)}, got {kind!r}")
    tp = check_times(t_plan, "t")
    if kind == "spline" or tp.size == 1:
        return interpolate_plan(t_plan, q_plan, times, force_t, force, limits)
    ts = as_array(times, "times", (None,))
    qp = as_array(q_plan, "q", (tp.size, None)).copy()
    qp[:, 2] = np.unwrap(qp[:, 2])  # as the spline: never turn the long way round
    v, a = backward_differences(qp, tp, "q")
    q, dq, ddq = quintic_hermite(tp, qp, v, a, ts)
    return Reference(ts, q, dq, ddq, interpolate_force(ts, force_t, force))
