"""Methods: the paper's method and its baselines as tables of cost terms and weights
(:mod:`~forte.planning.methods.catalog`), and methods from installed packages
(:mod:`~forte.planning.methods.plugins`)."""
