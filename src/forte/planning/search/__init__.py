"""Getting from here to there: a collision-free whole-body path in configuration space and its time law.

- :mod:`~forte.planning.search.validity`: is a configuration free (forte's collision model, one
  C++ call per state), is a straight C-space segment free;
- :mod:`~forte.planning.search.sampling`: :func:`find_path`, OMPL's RRT-Connect, shortcut, checked densely;
- :mod:`~forte.planning.search.timing`: :func:`retime`, the time-optimal law along a path (toppra);
- :mod:`~forte.planning.search.goal_ik`: a pose goal's IK configuration clear of the scene;
- :mod:`~forte.planning.search.route`: :func:`~forte.planning.search.route.routed`, a goal task's route.

OMPL and toppra are dependencies of forte, imported when a search or a retiming runs (``forte plan``
of a task without a goal never loads them).
"""

from forte.planning.search.sampling import SearchResult, find_path
from forte.planning.search.timing import Timed, retime
from forte.planning.search.validity import StateChecker, segment_free

__all__ = ["SearchResult", "StateChecker", "Timed", "find_path", "retime", "segment_free"]
