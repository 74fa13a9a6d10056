"""Executing a plan in simulation: the paper's Section 3.1 controllers in a MuJoCo model.

* :mod:`forte.execution.control`: joint impedance (arm) and admittance (base) control laws, the
  reference they track, and the sampled-loop stability check;
* :mod:`forte.execution.gains`: controller gains for any arm (bandwidth rule, ``controller:`` mapping);
* :mod:`forte.execution.model`: the MuJoCo model built from the robot's URDF
  (:mod:`forte.execution.arm_spec` prepares the arm, :mod:`forte.execution.model_parts` adds the
  world, base, end effector and actuators, :mod:`forte.execution.sim_model` holds the compiled
  model and its indices);
* :mod:`forte.execution.judge`: failure criteria and the verdict of a run;
* :mod:`forte.execution.render`: offscreen frames (PNG files, mp4 video) and the interactive viewer;
* :mod:`forte.execution.run`: :func:`~forte.execution.run.simulate_plan` (plan directory in,
  ``sim.csv`` and ``sim.json`` out).
"""
