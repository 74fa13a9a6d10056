"""Task force (paper, Section 4.1): the payload mass estimate and the desired force it sets.

Modules: :mod:`~forte.force.mass` (what an estimate is), :mod:`~forte.force.estimate` (which
source makes it), :mod:`~forte.force.offline` and :mod:`~forte.force.quantities` (stated quantities),
:mod:`~forte.force.vlm`, :mod:`~forte.force.vlm_answer`, :mod:`~forte.force.vlm_cache` (a vision
chat model), :mod:`~forte.force.images`, :mod:`~forte.force.massbench` (the Image2Mass metrics)
and :mod:`~forte.force.taskforce` (the force along a trajectory).
"""

from forte.force.estimate import estimate_payload, radius_from_estimate
from forte.force.mass import MassEstimate
from forte.force.offline import OfflineEstimator
from forte.force.vlm import VLMConfig, VLMEstimator

__all__ = [
    "MassEstimate",
    "OfflineEstimator",
    "VLMConfig",
    "VLMEstimator",
    "estimate_payload",
    "radius_from_estimate",
]
