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

import math
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

import numpy as np

from forte.exceptions import EstimationError
from forte.force.images import ImageInput
from forte.validation import FloatArray, as_array, as_positive

if TYPE_CHECKING:
    from forte.force.vlm import VLMConfig

#: Plausible payload masses (kg): answers outside are rejected as hallucinations.
MIN_MASS_KG = 1e-3
MAX_MASS_KG = 500.0
#: Gravity used by the paper (m/s^2), pointing along -z.
GRAVITY = np.array([0.0, 0.0, -9.81])
#: The paper's uncertainty radius (N), kept as the floor of :func:`radius_from_estimate`.
DEFAULT_R_MIN = 10.0


@dataclass(frozen=True)
class MassEstimate:
    """A payload mass ``mass_kg`` with its plausible interval ``low_kg <= mass_kg <= high_kg``.

    ``source`` names the estimator and, for a VLM, the model (``"vlm:gpt-4o"``); ``rationale`` is
    a short human-readable justification; ``cached`` is true when a VLM answer came from disk.
    """

    mass_kg: float
    low_kg: float
    high_kg: float
    source: str
    rationale: str = ""
    cached: bool = False

    def __post_init__(self) -> None:
        for name in ("mass_kg", "low_kg", "high_kg"):
            value = getattr(self, name)
            if not isinstance(value, int | float) or isinstance(value, bool) or not math.isfinite(value):
                raise EstimationError(f"{name}: expected a finite number, got {value!r}")
            if value <= 0:
                raise EstimationError(f"{name}: expected a positive mass, got {value!r} kg")
        if not self.low_kg <= self.mass_kg <= self.high_kg:
            raise EstimationError(
                f"expected low_kg <= mass_kg <= high_kg, got {self.low_kg!r} <= {self.mass_kg!r} "
                f"<= {self.high_kg!r}"
            )

    @property
    def half_width_kg(self) -> float:
        """``(high - low) / 2``: the mass uncertainty that sets the force-ball radius."""
        return 0.5 * (self.high_kg - self.low_kg)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


@runtime_checkable
class MassEstimator(Protocol):
    """Anything that turns a task description and an image into a :class:`MassEstimate`."""

    name: str

    def estimate(self, description: str | None, image: ImageInput | None) -> MassEstimate:
        """Estimate the payload mass; raise :class:`EstimationError` when it cannot."""
        ...


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
    """
    if mass is not None:
        return user_estimate(mass)
    # deferred: both estimators build on MassEstimate, defined here
    if vlm is not None:
        from forte.force.vlm import VLMEstimator

        return VLMEstimator(vlm, cache_dir).estimate(description, image)
    from forte.force.offline import OfflineEstimator

    return OfflineEstimator().estimate(description, image)


def radius_from_estimate(acc: Any, estimate: MassEstimate, r_min: float = DEFAULT_R_MIN) -> FloatArray:
    """Force-ball radii from the mass interval: ``r_k = max(r_min, |a_k - g| (high - low) / 2)``.

    The task force is ``f_k = m (a_k - g)`` with ``g = [0, 0, -9.81]``, so a mass known to within
    ``+-(high - low) / 2`` moves ``f_k`` by at most ``|a_k - g| (high - low) / 2``; ``r_min``
    (10 N in the paper) keeps the margin for everything else (model error, contacts). With a
    user-given mass the interval is empty and ``r_k = r_min``.

    Args:
        acc: end-effector accelerations, N x 3 (m/s^2, world frame).
        estimate: the mass estimate.
        r_min: floor of the radius (N), >= 0.
    """
    a = as_array(acc, "acc", (None, 3))
    floor = float(as_positive(r_min, "r_min", allow_zero=True))
    return np.maximum(floor, np.linalg.norm(a - GRAVITY, axis=1) * estimate.half_width_kg)
