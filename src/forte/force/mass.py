"""What a payload mass estimate is (paper, Section 4.1): the objects, their total and its interval.

Every estimator (:mod:`~forte.force.offline`, :mod:`~forte.force.vlm`) returns a
:class:`MassEstimate`; :mod:`~forte.force.estimate` picks which one runs. These types sit below
all of them, so that none has to import the module that chooses between them.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

from forte.exceptions import EstimationError
from forte.force.images import ImageInput

#: Plausible payload masses (kg): answers outside are rejected as hallucinations.
MIN_MASS_KG = 1e-3
MAX_MASS_KG = 500.0
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
