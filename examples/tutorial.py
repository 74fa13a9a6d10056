"""A walk through forte's Python API, stage by stage (run: python examples/tutorial.py).

1. the robot and its residual force polytope at one configuration;
2. the desired task force along a path, and the capability margin d_k;
3. planning the lifting task with FORTE and with the manipulability baseline;
4. reading the plan's metrics.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from forte.capability.metrics import CapabilityParameters, capability_margin, manipulability
from forte.capability.polytope import directional_capacity, halfspaces, residual_margins, vertices
from forte.force.taskforce import payload_force
from forte.model.robot import default_robot
from forte.planning.planner import plan
from forte.planning.tasks import load_task

HERE = Path(__file__).parent

# 1. The built-in MOCA-like robot: base (x, y, yaw) + Franka Panda, paper torque limits.
robot = default_robot()
q = robot.home()
zeros = np.zeros(robot.n_arm)
tau_gravity = robot.rnea(q[3:], zeros, zeros)  # nominal torque of a static pose
J = robot.arm_jacobian(q)  # world-frame translational Jacobian, 3 x 7
A, b = halfspaces(J, *residual_margins(tau_gravity, robot.torque_limits))  # RFP: A f <= b
print(f"RFP at home: {len(vertices(A, b))} vertices, "
      f"{directional_capacity(A, b, [0, 0, 1]):.1f} N available straight up")

# 2. Holding a 2.7 kg payload still needs f = m (0 - g) = 26.5 N up; the uncertainty ball has r = 10 N.
task_force = payload_force([0.0], [robot.ee_position(q)], mass=2.7)
alpha = CapabilityParameters().alpha
A_alpha, b_alpha = halfspaces(J, *residual_margins(tau_gravity, robot.torque_limits), alpha=alpha)
d = capability_margin(A_alpha, b_alpha, task_force.f[0], task_force.r[0])
print(f"margin d = {d:.1f} N (> 0: the whole force ball fits), manipulability {manipulability(J):.3f}")

# 3. Plan the lifting task (Section 5.3) with FORTE and with manipulability only.
task = load_task(HERE / "tasks" / "lift.yaml", waypoints=30)
ours = plan(task, "forte")
baseline = plan(task, "manipulability")

# 4. Per-waypoint metrics are exact (no smoothing): compare the force margins and manipulability.
for result in (ours, baseline):
    m = result.metrics
    print(f"{result.method:>15}: {result.status}; capacity − (|f| + r) >= {m['capacity_margin'].min():6.1f} N, "
          f"mean manipulability {m['manipulability'].mean():.3f}")
