"""The trajectory NLP: its variables (:mod:`~forte.planning.nlp.layout`), its rows (poses,
bounds, base modes, clearance), its compiled kernels, the
:class:`~forte.planning.nlp.optimizer.TrajectoryOptimizer` that owns it, and the solvers
(:mod:`~forte.planning.nlp.solvers`: IPOPT's interface and a stagewise interior point)."""
