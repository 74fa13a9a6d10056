"""forte: task-adaptive force-capability trajectory optimization for mobile manipulators.

The data flow, one module per stage:

- :mod:`forte.model.robot`: the mobile manipulator (Pinocchio) and its built-in default;
- :mod:`forte.model.twin`: the same kinematics and dynamics as CasADi expressions;
- :mod:`forte.model.trajectory`: backward finite differences and quintic paths;
- :mod:`forte.force.taskforce`: desired task forces ``f_k = m (p''_k - g)`` and their uncertainty;
- :mod:`forte.capability.polytope`: the dynamic residual force polytope and its geometry;
- :mod:`forte.capability.metrics`: the force-capability metric ``J1`` and manipulability.
"""

__version__ = "0.1.0"
