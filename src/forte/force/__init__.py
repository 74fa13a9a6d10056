"""Task force (paper, Section 4.1): the payload mass estimate and the desired force it sets.

Modules: :mod:`~forte.force.estimate` (the estimate and where it comes from),
:mod:`~forte.force.offline` and :mod:`~forte.force.quantities` (stated quantities),
:mod:`~forte.force.vlm`, :mod:`~forte.force.vlm_answer`, :mod:`~forte.force.vlm_cache` (a vision
chat model), :mod:`~forte.force.images`, :mod:`~forte.force.massbench` (the Image2Mass metrics)
and :mod:`~forte.force.taskforce` (the force along a trajectory).
"""

from forte.force.estimate import MassEstimate, estimate_payload, radius_from_estimate
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
