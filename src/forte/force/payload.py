"""The payload a task force is computed for: a typed value instead of a loose dictionary.

Its mass comes from the task file (``given``), the command line (``cli``) or an estimator
(``vlm:<model>``, ``offline``); a payload that only has a description and/or an image is
resolved by :func:`forte.planning.planner.resolve_payload` before planning.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from forte.exceptions import InvalidInputError
from forte.validation import payload_mass

#: The largest centre-of-mass offset (m) a payload may have from the end effector (forte's bound).
MAX_COM_OFFSET_M = 2.0
#: The largest principal moment of inertia (kg m^2) a payload may have (forte's bound).
MAX_INERTIA_KG_M2 = 100.0


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
        com: centre of mass in the end-effector frame (m); ``None``: at the end effector. An
            offset makes the task a wrench (:mod:`forte.force.wrench`).
        inertia: rotational inertia about the centre of mass, end-effector axes (kg m^2, 3 x 3);
            ``None``: a point mass (no rotational terms).
        moment_scale: the length ``L`` (m) that scales moments against forces in the wrench
            metric (:mod:`forte.capability.wrench`); ``None``: ``|com|``.
    """

    mass: float | None = None
    source: str = "given"
    description: str | None = None
    image: str | None = None
    mass_range: tuple[float, float] | None = None
    estimate: Mapping[str, Any] | None = None
    com: tuple[float, float, float] | None = None
    inertia: tuple[tuple[float, float, float], ...] | None = None
    moment_scale: float | None = None

    def __post_init__(self) -> None:
        if self.mass is not None:
            payload_mass(self.mass, "payload.mass", allow_zero=True)  # 0: an empty hand
        if self.com is not None:
            object.__setattr__(self, "com", tuple(float(v) for v in check_com(self.com)))
        if self.inertia is not None:
            object.__setattr__(self, "inertia", tuple(tuple(float(v) for v in row)
                                                      for row in check_inertia(self.inertia)))
        if self.moment_scale is not None:
            x = self.moment_scale
            if isinstance(x, bool) or not isinstance(x, int | float) or not 0 < x <= MAX_COM_OFFSET_M:
                raise InvalidInputError(f"payload.moment_scale: expected a number > 0 and <= {MAX_COM_OFFSET_M:g} m, "
                                        f"got {x!r}")
            object.__setattr__(self, "moment_scale", float(x))

    @property
    def lever(self) -> float:
        """``|c|`` (m): the distance of the centre of mass from the end effector."""
        return 0.0 if self.com is None else float(np.linalg.norm(self.com))

    @property
    def has_moment(self) -> bool:
        """The task needs a moment at the end effector: an offset centre of mass or an inertia."""
        return self.lever > 0 or (self.inertia is not None and bool(np.any(np.asarray(self.inertia))))

    @property
    def length_scale(self) -> float:
        """``L`` (m): :attr:`moment_scale` when given, else ``|c|``."""
        return self.lever if self.moment_scale is None else float(self.moment_scale)

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
                "estimate": None if self.estimate is None else dict(self.estimate)} | self._geometry()

    def _geometry(self) -> dict[str, Any]:
        """``com``, ``inertia`` and the ``moment_scale`` in use (m), when the payload has a geometry."""
        if self.com is None and self.inertia is None:
            return {}
        return {"com": None if self.com is None else list(self.com),
                "inertia": None if self.inertia is None else [list(row) for row in self.inertia],
                "moment_scale": self.length_scale, "moment_scale_given": self.moment_scale is not None}


def check_com(value: Any, name: str = "payload.com") -> np.ndarray:
    """A centre-of-mass offset: 3 finite numbers (m), at most :data:`MAX_COM_OFFSET_M` from the
    end effector (``InvalidInputError`` naming ``name``)."""
    if not isinstance(value, list | tuple | np.ndarray) or len(value) != 3 or any(
            isinstance(v, bool) or not isinstance(v, int | float | np.integer | np.floating) for v in value):
        raise InvalidInputError(f"{name}: expected a list of 3 numbers (m, end-effector frame), got {value!r}")
    c = np.asarray(value, dtype=float)
    if not np.all(np.isfinite(c)) or np.linalg.norm(c) > MAX_COM_OFFSET_M:
        raise InvalidInputError(f"{name}: expected finite numbers at most {MAX_COM_OFFSET_M:g} m from the end "
                                f"effector, got {list(value)!r}")
    return c


def check_inertia(value: Any, name: str = "payload.inertia") -> np.ndarray:
    """A rotational inertia about the centre of mass (kg m^2): 3 principal moments (the diagonal)
    or a symmetric 3 x 3 matrix, positive semi-definite, whose principal moments satisfy the
    triangle inequality ``I_1 + I_2 >= I_3`` of a rigid body."""
    try:
        I = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        I = np.full(1, np.nan)
    if I.shape == (3,):
        I = np.diag(I)
    if I.shape != (3, 3) or not np.all(np.isfinite(I)) or isinstance(value, str):
        raise InvalidInputError(f"{name}: expected 3 principal moments or a 3x3 matrix of numbers (kg m^2), "
                                f"got {value!r}")
    if not np.allclose(I, I.T, atol=1e-12):
        raise InvalidInputError(f"{name}: expected a symmetric matrix")
    e = np.linalg.eigvalsh(I)
    if e.min() < -1e-12:
        raise InvalidInputError(f"{name}: expected moments >= 0 (positive semi-definite), got eigenvalues "
                                f"{', '.join(f'{v:g}' for v in e)}")
    if e.max() > MAX_INERTIA_KG_M2:
        raise InvalidInputError(f"{name}: expected moments <= {MAX_INERTIA_KG_M2:g} kg m^2, got {e.max():g}")
    if e[0] + e[1] < e[2] - 1e-9 * max(1.0, e[2]):
        raise InvalidInputError(f"{name}: principal moments {', '.join(f'{v:g}' for v in e)} break the "
                                "triangle inequality I1 + I2 >= I3 of a rigid body")
    return I
