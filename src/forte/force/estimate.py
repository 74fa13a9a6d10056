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
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
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


#: Confidence levels a VLM may give an object.
CONFIDENCE_LEVELS: tuple[str, ...] = ("low", "medium", "high")


def _check_interval(mass: float, low: float, high: float, where: str = "") -> None:
    """Finite positive masses with ``low <= mass <= high``, or an :class:`EstimationError`."""
    for name, value in (("mass_kg", mass), ("low_kg", low), ("high_kg", high)):
        if not isinstance(value, int | float) or isinstance(value, bool) or not math.isfinite(value):
            raise EstimationError(f"{where}{name}: expected a finite number, got {value!r}")
        if value <= 0:
            raise EstimationError(f"{where}{name}: expected a positive mass, got {value!r} kg")
    if not low <= mass <= high:
        raise EstimationError(
            f"{where}expected low_kg <= mass_kg <= high_kg, got {low!r} <= {mass!r} <= {high!r}"
        )


@dataclass(frozen=True)
class ObjectEstimate:
    """One object of the payload as a VLM sees it: what it is, its mass and plausible interval.

    ``confidence`` is ``"low"``, ``"medium"``, ``"high"`` or ``""`` (not stated); ``occluded`` is
    true for an object partly or fully hidden in the image (it is counted all the same).
    """

    description: str
    material: str
    mass_kg: float
    low_kg: float
    high_kg: float
    confidence: str = ""
    occluded: bool = False

    def __post_init__(self) -> None:
        _check_interval(self.mass_kg, self.low_kg, self.high_kg, f"object {self.description!r}: ")
        if self.confidence not in ("", *CONFIDENCE_LEVELS):
            raise EstimationError(f"object {self.description!r}: confidence must be low, medium or high")

    def to_dict(self) -> dict[str, Any]:
        return {
            "description": self.description, "material": self.material, "mass_kg": self.mass_kg,
            "low_kg": self.low_kg, "high_kg": self.high_kg, "confidence": self.confidence,
            "occluded": self.occluded,
        }  # fmt: skip

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> ObjectEstimate:
        return cls(
            str(data["description"]), str(data.get("material", "")), float(data["mass_kg"]),
            float(data["low_kg"]), float(data["high_kg"]), str(data.get("confidence", "")),
            bool(data.get("occluded", False)),
        )  # fmt: skip


@dataclass(frozen=True)
class MassEstimate:
    """A payload mass ``mass_kg`` with its plausible interval ``low_kg <= mass_kg <= high_kg``.

    ``source`` names the estimator and, for a VLM, the model (``"vlm:gpt-4o"``); ``rationale`` is
    a short human-readable justification; ``cached`` is true when a VLM answer came from disk.
    ``objects`` lists the objects the total is made of when the estimator reports them (a VLM
    does); then ``mass_kg`` is their total and ``[low_kg, high_kg]`` the total's interval, see
    :meth:`from_objects`. The planner uses ``mass_kg`` only.
    """

    mass_kg: float
    low_kg: float
    high_kg: float
    source: str
    rationale: str = ""
    cached: bool = False
    objects: tuple[ObjectEstimate, ...] = ()

    def __post_init__(self) -> None:
        _check_interval(self.mass_kg, self.low_kg, self.high_kg)

    @classmethod
    def from_objects(
        cls, objects: Iterable[ObjectEstimate], source: str, rationale: str = "", cached: bool = False
    ) -> MassEstimate:
        """The total over ``objects``, summed here rather than trusted from a model.

        ``mass = sum m_i``, ``low = sum low_i``, ``high = sum high_i``: the total's interval is the
        sum of the objects' intervals, the worst case where every object sits at the same end of
        its range. It assumes nothing about independence, so it never understates the
        uncertainty (an independent-errors rule would shrink it by up to ``sqrt(n)``).
        """
        items = tuple(objects)
        if not items:
            raise EstimationError("expected at least one object to sum")
        total = (math.fsum(o.mass_kg for o in items), math.fsum(o.low_kg for o in items),
                 math.fsum(o.high_kg for o in items))  # fmt: skip
        return cls(*total, source, rationale, cached, items)

    @property
    def total_kg(self) -> float:
        """The payload's total mass (the sum over :attr:`objects` when there are any)."""
        return self.mass_kg

    @property
    def range_kg(self) -> tuple[float, float]:
        """``(low_kg, high_kg)``."""
        return self.low_kg, self.high_kg

    @property
    def half_width_kg(self) -> float:
        """``(high - low) / 2``: the mass uncertainty that sets the force-ball radius."""
        return 0.5 * (self.high_kg - self.low_kg)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: the fields, with ``objects`` as a list of dicts."""
        return {
            "mass_kg": self.mass_kg, "low_kg": self.low_kg, "high_kg": self.high_kg, "source": self.source,
            "rationale": self.rationale, "cached": self.cached, "objects": [o.to_dict() for o in self.objects],
        }  # fmt: skip

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], cached: bool = False) -> MassEstimate:
        """The inverse of :meth:`to_dict` (``cached`` replaces the stored flag)."""
        objects = tuple(ObjectEstimate.from_dict(o) for o in data.get("objects") or ())
        return cls(
            float(data["mass_kg"]), float(data["low_kg"]), float(data["high_kg"]), str(data["source"]),
            str(data.get("rationale", "")), cached, objects,
        )  # fmt: skip


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

    Examples:
        The offline estimator reads volumes and liquids from the description:

        >>> import forte
        >>> est = forte.estimate_payload("a 2.7 L pack of water bottles", None)
        >>> est.source.startswith("offline"), round(est.mass_kg, 1)  # water plus the bottles
        (True, 2.8)
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
