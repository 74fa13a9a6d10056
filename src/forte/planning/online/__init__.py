"""Re-planning while the robot moves: :class:`~forte.planning.online.replan.Replanner` and the
real-time iteration (:mod:`~forte.planning.online.realtime`)."""
