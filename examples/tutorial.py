"""A walk through forte's Python API, stage by stage (run: python examples/tutorial.py).

1. the robot and its residual force polytope at one configuration;
2. the desired task force, and the capability margin d_k;
3. planning the lifting task with FORTE and with the manipulability baseline;
4. reading the plan's metrics;
5. extending forte: a cost term of your own and a method that uses it, through the registries;
6. re-planning while the robot moves: a new mass, and a receding horizon that starts moving.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar

import casadi as ca

import forte

HERE = Path(__file__).parent

# 1. The built-in MOCA-like robot: base (x, y, yaw) + Franka Panda, paper torque limits.
robot = forte.default_robot()
q = robot.home()
rfp = forte.residual_force_polytope(robot, q)  # static pose: the nominal torque is gravity's
print(f"RFP at home: {len(rfp.vertices)} vertices, {rfp.capacity_along([0, 0, 1]):.1f} N available straight up")

# 2. Holding a 2.7 kg payload still needs f = (m + m_tool) (0 - g) = 37.7 N up: the robot's 1.146 kg
#    end-effector load counts too, as in every planned task; the uncertainty ball has r = 10 N.
task_force = forte.payload_force([0.0], [robot.ee_position(q)], mass=2.7 + robot.tool_force_mass)
alpha = forte.CapabilityParameters().alpha  # the metric shrinks the residual torque interval by alpha
shrunk = forte.residual_force_polytope(robot, q, alpha=alpha)
d = forte.capability_margin(shrunk.A, shrunk.b, task_force.f[0], task_force.r[0])
print(f"margin d = {d:.1f} N (> 0: the whole force ball fits)")

# 3. Plan the lifting task (Section 5.3) with FORTE and with manipulability only.
task = forte.load_task(HERE / "tasks" / "lift.yaml", waypoints=30)
ours = forte.plan(task, "forte")
baseline = forte.plan(task, "manipulability")

# 4. Per-waypoint metrics are exact (no smoothing): compare the force margins and manipulability.
for result in (ours, baseline):
    m = result.metrics
    print(f"{result.method:>15}: {result.status}; capacity − (|f| + r) >= {m['capacity_margin'].min():6.1f} N, "
          f"mean manipulability {m['manipulability'].mean():.3f}")


# 5. A cost term of your own: keep the base close to where it starts. A stage term gets the
#    waypoint's symbols (q_{k-2}, q_{k-1}, q_k, time steps, force, radius) and returns c_k; the
#    optimizer compiles it with the other terms and derives its gradient and Hessian.
@forte.register_term
@dataclass(frozen=True)
class BaseDistance(forte.CostTerm):
    """``c_k = x_k^2 + y_k^2``: the squared distance of the base from the origin."""

    name: ClassVar[str] = "base_distance"

    def stage(self, s: forte.Stage) -> ca.SX:
        return ca.sumsqr(s.q0[:2])


# A method is one registry entry: the paper's terms plus ours, with its weight.
forte.register_method(forte.Method(
    "forte-stay", "forte, with the base kept near its start",
    terms=(*forte.METHODS["forte"].terms, "base_distance"), weights={"base_distance": 100.0},
    style=forte.MethodStyle("tab:olive", "forte + base distance"),
))
stay = forte.plan(task, "forte-stay")  # `forte plan --method forte-stay` works too, in this process
travel = {r.method: float(abs(r.q[:, :2]).max()) for r in (ours, stay)}
print(f"largest base excursion: forte {travel['forte']:.3f} m, forte-stay {travel['forte-stay']:.3f} m")

# 6. Re-plan while the robot moves. A Replanner keeps the compiled problem and its last solution:
#    after a new mass it re-solves from there. A shift moves the horizon on by whole waypoints; its
#    new first waypoint moves as the plan did there (or give the measured q_now, v_now), so the
#    backward differences, the torques and the margins of the new plan start from that motion.
replanner = forte.Replanner(task)
heavier = replanner.replan(mass=3.3)
shifted = replanner.shift(4)
speed = float(abs(replanner.task.start_motion.velocity[3:]).max())
margin = shifted.plan.metrics["d"].min()
print(f"re-plan for 3.3 kg: {heavier.iterations} iterations, {1000 * heavier.latency_s:.0f} ms; shifted by 4 "
      f"waypoints, starting at up to {speed:.2f} rad/s: {shifted.plan.label}, min d {margin:.1f} N")
