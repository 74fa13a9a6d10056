"""Cost terms: the registry (:mod:`~forte.planning.terms.costs`) and the built-in terms.

Importing this package registers the built-in terms (their modules import the registry; the
registry imports none of them, so there is no import circle).
"""

from forte.planning.terms import capability_terms, motion_terms, tipover_terms, wrench_terms  # noqa: F401
