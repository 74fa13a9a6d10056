"""The payload a task force is computed for: a typed value instead of a loose dictionary.

Its mass comes from the task file (``given``), the command line (``cli``) or an estimator
(``vlm:<model>``, ``offline``); a payload that only has a description and/or an image is
resolved by :func:`forte.planning.planner.resolve_payload` before planning.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

from forte.validation import payload_mass


@dataclass(frozen=True)
class Payload:
    """A payload: its mass (kg) and where the mass came from.

    Attributes:
        mass: kg, ``None`` until given or estimated.
        source: ``"given"`` (task file), ``"cli"`` (``--mass``), or the estimator's name
            (``"offline"``, ``"vlm:<model>"``).
        description: what the task says about it (input of the estimator).
        image: path of a photo of it (input of the estimator).
        mass_range: ``(low, high)`` kg when an estimator gave one.
        estimate: the estimator's full record (reported in plan.json).
    """

    mass: float | None = None
    source: str = "given"
    description: str | None = None
    image: str | None = None
    mass_range: tuple[float, float] | None = None
    estimate: Mapping[str, Any] | None = None

    def __post_init__(self) -> None:
        if self.mass is not None:
            payload_mass(self.mass, "payload.mass")

    @property
    def needs_estimate(self) -> bool:
        """True when the mass must still come from an estimator."""
        return self.mass is None

    def with_mass(self, mass: float, source: str = "cli") -> Payload:
        """The same payload with ``mass`` given directly (no estimate)."""
        return replace(self, mass=float(mass), source=source, mass_range=None, estimate=None)

    def with_estimate(self, estimate: Any) -> Payload:
        """The same payload with the mass of ``estimate`` (a :class:`~forte.force.MassEstimate`)."""
        return replace(self, mass=float(estimate.mass_kg), source=str(estimate.source),
                       mass_range=(float(estimate.low_kg), float(estimate.high_kg)), estimate=estimate.to_dict())

    def to_dict(self) -> dict[str, Any]:
        """The record written to plan.json."""
        return {"mass": self.mass, "source": self.source, "description": self.description, "image": self.image,
                "mass_range": None if self.mass_range is None else list(self.mass_range),
                "estimate": None if self.estimate is None else dict(self.estimate)}
