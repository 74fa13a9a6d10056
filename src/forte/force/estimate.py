"""Payload mass estimates (paper, Section 4.1) and the entry point that picks their source.

The paper's desired task force is ``f_k = m_hat (a_k - g)`` where ``m_hat = Phi_VLM(I, D)`` is the
mass of the object the end effector will carry, inferred by a vision-language model from an RGB
image ``I`` and a task description ``D``. :func:`estimate_payload` produces ``m_hat`` together
with an interval ``[low, high]`` that states its uncertainty, from one of three sources:

* ``user``: a mass given explicitly always wins (interval of zero width);
* ``vlm``: any OpenAI-compatible chat-completions server (GPT-4o as in the paper, a local Ollama
  or vLLM), see :class:`forte.force.vlm.VLMEstimator`;
* ``offline``: quantities stated in the description ("two 1.5 L bottles", "a 2 kg dumbbell")
  read with a small documented table, see :class:`forte.force.offline.OfflineEstimator`.

:func:`radius_from_estimate` is an opt-in rule that turns the interval into the radius of the
force uncertainty ball; the paper keeps that radius fixed at 10 N.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from forte.force.images import ImageInput
from forte.force.mass import CONFIDENCE_LEVELS as CONFIDENCE_LEVELS  # owned there, kept importable here
from forte.force.mass import MAX_MASS_KG as MAX_MASS_KG
from forte.force.mass import MIN_MASS_KG as MIN_MASS_KG
from forte.force.mass import MassEstimate as MassEstimate
from forte.force.mass import MassEstimator as MassEstimator
from forte.force.mass import ObjectEstimate as ObjectEstimate
from forte.force.offline import OfflineEstimator
from forte.force.vlm import VLMConfig, VLMEstimator
from forte.validation import FloatArray, as_array, as_positive

#: Gravity used by the paper (m/s^2), pointing along -z.
GRAVITY = np.array([0.0, 0.0, -9.81])
#: The paper's uncertainty radius (N), kept as the floor of :func:`radius_from_estimate`.
DEFAULT_R_MIN = 10.0


def user_estimate(mass: float) -> MassEstimate:
    """A mass given by the user, taken as exact (``low = mass = high``)."""
    m = float(as_positive(mass, "mass"))
    return MassEstimate(m, m, m, "user", "mass given explicitly")


def estimate_payload(
    description: str | None,
    image: ImageInput | None,
    mass: float | None = None,
    vlm: VLMConfig | None = None,
    cache_dir: Path | None = None,
) -> MassEstimate:
    """The payload mass to use for the task force.

    Priority: an explicit ``mass`` (source ``user``) always wins; otherwise the VLM when ``vlm``
    is given (answers cached under ``cache_dir`` when given); otherwise the offline estimator.

    Raises:
        EstimationError: no estimate could be obtained or the answer failed validation.
        InvalidInputError: a non-positive ``mass`` or an unreadable image.

    Examples:
        The offline estimator reads volumes and liquids from the description:

        >>> import forte
        >>> est = forte.estimate_payload("a 2.7 L pack of water bottles", None)
        >>> est.source.startswith("offline"), round(est.mass_kg, 1)  # water plus the bottles
        (True, 2.8)
    """
    if mass is not None:
        return user_estimate(mass)
    if vlm is not None:
        return VLMEstimator(vlm, cache_dir).estimate(description, image)
    return OfflineEstimator().estimate(description, image)


def radius_from_estimate(acc: Any, estimate: MassEstimate, r_min: float = DEFAULT_R_MIN) -> FloatArray:
    """Force-ball radii from the mass interval: ``r_k = max(r_min, |a_k - g| (high - low) / 2)``.

    Opt-in: the paper and its authors keep ``r_k = 10 N`` fixed whatever the estimate, and so
    does the planner unless a caller applies this rule. The task force is ``f_k = m (a_k - g)``
    with ``g = [0, 0, -9.81]``, so a mass known to within ``+-(high - low) / 2`` moves ``f_k`` by
    at most ``|a_k - g| (high - low) / 2`` (at rest: ``9.81 (high - low) / 2``); ``r_min`` (10 N
    in the paper) keeps the margin for everything else (model error, contacts). With a user-given
    mass the interval is empty and ``r_k = r_min``.

    Args:
        acc: end-effector accelerations, N x 3 (m/s^2, world frame).
        estimate: the mass estimate.
        r_min: floor of the radius (N), >= 0.
    """
    a = as_array(acc, "acc", (None, 3))
    floor = float(as_positive(r_min, "r_min", allow_zero=True))
    return np.maximum(floor, np.linalg.norm(a - GRAVITY, axis=1) * estimate.half_width_kg)
