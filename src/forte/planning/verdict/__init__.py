"""The verdict: can a plan be executed? Requirements checked on the executed (spline) motion,
their violations named by joint and waypoint, and the plan's metrics
(:mod:`~forte.planning.verdict.evaluation`)."""
