"""Planning: from a task file to a judged whole-body trajectory, in rooms that follow the data flow.

- :mod:`~forte.planning.terms`: the cost terms (the registry and the built-in terms);
- :mod:`~forte.planning.tasks`: task files read into a :class:`~forte.planning.tasks.tasks.Task`;
- :mod:`~forte.planning.methods`: the paper's method and baselines as tables of terms, and plugins;
- :mod:`~forte.planning.nlp`: the transcription (variables, rows, compiled kernels), the
  :class:`~forte.planning.nlp.optimizer.TrajectoryOptimizer` and its solvers;
- :mod:`~forte.planning.verdict`: what a plan is worth and whether it can be executed;
- :mod:`~forte.planning.search`: a collision-free whole-body path in configuration space (OMPL)
  and its time-optimal law (toppra);
- :mod:`~forte.planning.scene`: getting around the world (a clear start, re-solves with rows,
  naming what is in the way);
- :mod:`~forte.planning.solve`: solving a task with an optimized method (initial guess,
  coarse-to-fine, clearance rows, several starts for a hold);
- :mod:`~forte.planning.rounds`: the verdict of a solve and the rounds for a plan that fails it
  (its own force, self-collision rows, refinement, a slower route, the route as the plan);
- :mod:`~forte.planning.planner`: the entry point (:func:`~forte.planning.planner.plan`: solve,
  judge, refine);
- :mod:`~forte.planning.online`: re-planning while the robot moves;
- :mod:`~forte.planning.bounds`: the largest payload a task could carry.

A room imports only the rooms above it in this list (``tests/test_architecture.py``).
"""
