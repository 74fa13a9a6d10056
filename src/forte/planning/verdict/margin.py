"""The executor's clearance margin: what a motion keeps from the scene beyond the asked clearance,
because the controllers that run it do not follow the spline exactly. One table,
:data:`EXECUTION_MARGINS`, per base kind; read by the verdict's clearance
(:class:`~forte.planning.verdict.requirements.Clearance`, through :func:`kept_clearance`), the
search's kept clearance (:func:`forte.planning.search.sampling.wanted`) and the goal IK (at rest,
:data:`REST_MARGIN`).

**Rule.** A base kind's margin bounds the hand's tracking error in MuJoCo (``forte simulate``,
kinematic base model) over the plans the sample calls feasible, where plans can keep that much; the
hand is the point farthest from every joint, so its error bounds the other links'.

**Measured** (``benchmarks/motionbenchmaker.py ... --route-first --workers 1``, problems 0003, 0017,
0029 of each scenario, ``sim_ee_error_m``: each run's largest; docs/experiments/motionbenchmaker/margin.md):

- fixed: 1.3 mm at most (median 0.8 mm): 2 mm. With 0, 4 of 302 plans keeping 0.02-0.9 mm touched.
- holonomic (``--base holonomic``, the authors' base), the paper's controllers: 24.2 mm at most
  (median 11.5 mm); with 2 mm one plan keeping 3.4 mm touched (table_pick 0003, ``panda_link5``).
  Where it comes from (that plan): the arm's joints lag 13 mrad (< 1 mrad on the fixed base), as
  the arm law's feedforward ``M_a(q_a) ddq_a + C_a + g`` leaves out the base's acceleration and
  yaw rate; the base's yaw lags 8 mrad (the velocity actuators' lag times the admittance's
  ``B_b / K_b``). Of the hand's 19 mm, 13 mm come from the arm's joints, 9 mm from the base.
  With ``controller.base_coupling`` (:mod:`forte.execution.base_coupling`): 13.5 mm at most
  (median 6.7 mm), the 18 plans called feasible all clean.
- A margin at the paper's controllers' bound, 25 mm for mobile bases, was measured too: 4 of 21
  problems then succeed (17 with 2 mm): routes keep the clearance at their states, the executed
  spline between them cuts 5-11 mm closer, and a goal closer than the margin sets what the whole
  motion keeps. So the mobile kinds keep the fixed base's 2 mm until the route keeps its clearance
  along the executed spline; their tracking is improved instead (``base_coupling``).
- differential: not measured separately; the holonomic's.

Where the motion's first or last sample is already closer than the margin (a start or a goal in
near contact), the motion keeps what its ends keep (:func:`kept_clearance`): a grasp's goal is meant
to be close. A configuration the robot holds at rest (a goal solved by the goal IK) needs only
:data:`REST_MARGIN`: at rest every base kind's error decays to the fixed arm's.
"""

from __future__ import annotations

from forte.exceptions import InvalidInputError
from forte.validation import FloatArray

#: The executor's margin (m) per base kind (module docstring: how each was measured).
EXECUTION_MARGINS: dict[str, float] = {"fixed": 0.002, "holonomic": 0.002, "differential": 0.002}
#: The margin (m) of a configuration held at rest, whatever the base kind: the fixed base's.
REST_MARGIN = EXECUTION_MARGINS["fixed"]


def execution_margin(base: str) -> float:
    """The least clearance (m) a motion of a robot with this base kind keeps whatever the task asks
    (:data:`EXECUTION_MARGINS`)."""
    if base not in EXECUTION_MARGINS:
        raise InvalidInputError(f"base: expected one of {', '.join(EXECUTION_MARGINS)}, got {base!r}")
    return EXECUTION_MARGINS[base]


def kept_clearance(asked: float, distance: FloatArray, base: str) -> float:
    """The distance a motion must keep: the asked one, raised to :func:`execution_margin` of
    ``base`` unless the motion's first or last sample (``distance[0]``, ``distance[-1]``) is already
    closer (a start or a goal in near contact stays plannable; the motion then keeps what its ends keep)."""
    return max(float(asked), min(execution_margin(base), float(distance[0]), float(distance[-1])))


def margin_note(asked: float, kept: float, base: str) -> str:
    """The verdict's words for a kept clearance above the asked one (empty when they are equal)."""
    if kept == asked:
        return ""
    return f" (the asked {asked:g} m raised to what execution needs on a {base} base)"
