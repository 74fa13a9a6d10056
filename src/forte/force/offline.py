"""Offline payload mass: quantities stated in the task description, no model, no network."""

from __future__ import annotations

from forte.exceptions import EstimationError
from forte.force.estimate import MAX_MASS_KG, MIN_MASS_KG, MassEstimate
from forte.force.images import ImageInput
from forte.force.quantities import parse_quantities


class OfflineEstimator:
    """Payload mass from quantities stated in the description; the image is not used.

    The estimate is the sum over the stated quantities (see
    :func:`forte.force.quantities.parse_quantities`) and so is its interval. When nothing can be
    inferred it refuses with :class:`EstimationError` rather than guess.
    """

    name = "offline"
    version = "quantity-table-v1"

    def estimate(self, description: str | None, image: ImageInput | None = None) -> MassEstimate:
        if not description or not description.strip():
            raise EstimationError(
                "the offline estimator needs a task description with a stated quantity "
                "(e.g. 'two 1.5 L bottles'); give the mass with --mass or configure a VLM"
            )
        quantities = parse_quantities(description)
        if not quantities:
            raise EstimationError(
                f"no mass or volume stated in the description {description!r} (looked for g, kg, lb, "
                "oz, mL, L, fl oz, gal); give the mass with --mass or configure a VLM (--vlm-base-url)"
            )
        mass = sum(q.mass_kg for q in quantities)
        low = sum(q.low_kg for q in quantities)
        high = sum(q.high_kg for q in quantities)
        if not MIN_MASS_KG <= mass <= MAX_MASS_KG:
            raise EstimationError(
                f"the stated quantities add up to {mass:g} kg, outside the plausible payload range "
                f"[{MIN_MASS_KG:g}, {MAX_MASS_KG:g}] kg; give the mass with --mass"
            )
        rationale = "; ".join(q.explanation for q in quantities)
        return MassEstimate(mass, low, high, f"{self.name}:{self.version}", rationale)
