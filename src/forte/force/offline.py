"""Offline payload mass: what the task description states, read with tables; no model, no network."""

from __future__ import annotations

from forte.exceptions import EstimationError
from forte.force.images import ImageInput
from forte.force.mass import MAX_MASS_KG, MIN_MASS_KG, MassEstimate, ObjectEstimate
from forte.force.quantities import Quantity, parse_items, parse_quantities


class OfflineEstimator:
    """Payload mass from the description alone; the image is not used.

    The estimate is the sum over the stated quantities
    (:func:`~forte.force.quantities.parse_quantities`) and the named objects of known classes
    (:func:`~forte.force.quantities.parse_items`), and so is its interval; each one is listed in
    :attr:`MassEstimate.objects`. When nothing can be inferred it refuses with
    :class:`EstimationError` rather than guess.

    Args:
        stated_masses: read masses stated in the description ("a 2 kg dumbbell"). A user planning
            a task states the mass on purpose; a benchmark must pass False, or an estimator that
            reads the answer off the description would be scored as if it had estimated it.
    """

    name = "offline"
    version = "quantity-table-v2"

    def __init__(self, stated_masses: bool = True) -> None:
        self.stated_masses = stated_masses

    def estimate(self, description: str | None, image: ImageInput | None = None) -> MassEstimate:
        if not description or not description.strip():
            raise EstimationError(
                ("the offline estimator reads no image; it " if image is not None else "the offline estimator ")
                + "needs a task description with a stated quantity "
                "(e.g. 'two 1.5 L bottles'); give the mass with --mass or configure a VLM"
            )
        quantities = parse_quantities(description, stated_masses=self.stated_masses)
        found = sorted(quantities + parse_items(description, [q.span for q in quantities]), key=lambda q: q.span)
        if not found:
            looked = "g, kg, lb, oz, " if self.stated_masses else ""
            raise EstimationError(
                f"no mass or volume stated, and no known object named, in the description {description!r} "
                f"(looked for {looked}mL, L, fl oz, gal and counted objects such as 'four apples'); "
                "give the mass with --mass or configure a VLM (--vlm-base-url)"
            )
        rationale = "; ".join(q.explanation for q in found)
        estimate = MassEstimate.from_objects(map(_as_object, found), f"{self.name}:{self.version}", rationale)
        if not MIN_MASS_KG <= estimate.mass_kg <= MAX_MASS_KG:
            raise EstimationError(
                f"the stated quantities add up to {estimate.mass_kg:g} kg, outside the plausible payload range "
                f"[{MIN_MASS_KG:g}, {MAX_MASS_KG:g}] kg; give the mass with --mass"
            )
        return estimate


def _as_object(quantity: Quantity) -> ObjectEstimate:
    return ObjectEstimate(quantity.explanation, "", quantity.mass_kg, quantity.low_kg, quantity.high_kg)
