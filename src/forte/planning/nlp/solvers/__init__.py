"""Solvers of the trajectory NLP beside IPOPT (the reference, :mod:`forte.planning.nlp.optimizer`).

- :mod:`~forte.planning.nlp.solvers.stage_problem`: the NLP with its fixed and tied waypoints
  eliminated, evaluated with the optimizer's compiled kernels;
- :mod:`~forte.planning.nlp.solvers.interior_point`: a primal-dual interior-point method whose Newton
  step works in the null space of each waypoint's pose rows;
- :mod:`~forte.planning.nlp.solvers.stagewise`: that solver behind the optimizer's interface
  (``solver: {backend: stagewise}``);
- :mod:`~forte.planning.nlp.solvers.native`: the kernels called over a horizon without CasADi's
  per-call overhead;
- :mod:`~forte.planning.nlp.solvers.result`: what every solve returns.
"""
