"""Desired task force (paper, Section 4.1).

The force the manipulator must apply to carry a payload of mass ``m`` along the end-effector
trajectory is ``f_k = m (p''_k - g)`` with ``g = [0, 0, -9.81]``: the inertial force plus the
upward gravity compensation. Each ``f_k`` is the centre of an uncertainty ball of radius
``r_k`` (10 N in the paper).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from forte.exceptions import InvalidInputError
from forte.model.robot import STANDARD_GRAVITY
from forte.model.trajectory import StartMotion, backward_differences, quintic_blend
from forte.validation import FloatArray, as_array, as_positive, check_times

#: The paper's task-force uncertainty radius (N).
DEFAULT_RADIUS = 10.0


@dataclass(frozen=True)
class TaskForce:
    """Desired forces ``f`` (N x 3, world frame, N) and ball radii ``r`` (N) at times ``t``.

    A payload with an offset centre of mass or an inertia also needs a moment (a *wrench*
    requirement, :mod:`forte.force.wrench`): ``m`` (N x 3, world frame, N m, at the end effector),
    the moment ball's radius ``r_m = lever r`` and the metric's moment scale ``L``
    (:mod:`forte.capability.wrench`). ``m is None``: a force alone (the paper).
    """

    t: FloatArray
    f: FloatArray
    r: FloatArray
    m: FloatArray | None = None
    lever: float = 0.0
    moment_scale: float = 0.0

    def __post_init__(self) -> None:
        n = check_times(self.t).size
        as_array(self.f, "force", (n, 3))
        radius = as_array(self.r, "radius", (n,))
        if np.any(radius < 0):
            k = int(np.flatnonzero(radius < 0)[0])
            raise InvalidInputError(f"radius[{k}]: expected >= 0 N, got {radius[k]}")
        if self.m is not None:
            as_array(self.m, "moment", (n, 3))
        for name in ("lever", "moment_scale"):
            as_positive(getattr(self, name), name, allow_zero=True)

    @property
    def has_moment(self) -> bool:
        """A wrench requirement (a moment is required, even where it is zero)."""
        return self.m is not None

    @property
    def r_m(self) -> FloatArray:
        """Radii of the moment ball ``r_m = lever r`` (N m)."""
        return self.lever * np.asarray(self.r, dtype=float)

    @property
    def wrench(self) -> FloatArray:
        """``(f, m)`` per sample (N x 6); ``m = 0`` for a force alone."""
        return np.hstack([self.f, np.zeros_like(self.f) if self.m is None else self.m])

    @property
    def magnitude(self) -> FloatArray:
        return np.linalg.norm(self.f, axis=1)

    @property
    def direction(self) -> FloatArray:
        """Unit force directions (straight up where the force vanishes)."""
        return force_directions(self.f)


def force_directions(f: FloatArray) -> FloatArray:
    """Unit directions of forces ``f`` (K x 3), straight up where a force vanishes."""
    mag = np.linalg.norm(f, axis=1)[:, None]
    return np.where(mag > 1e-12, f / np.maximum(mag, 1e-12), np.array([0.0, 0.0, 1.0]))


def _radii(radius: Any, n: int) -> FloatArray:
    if np.ndim(radius) == 0:
        return np.full(n, as_positive(radius, "radius", allow_zero=True))
    return as_array(radius, "radius", (n,))


def payload_force(
    t: Any,
    positions: Any,
    mass: Any,
    radius: Any = DEFAULT_RADIUS,
    gravity: float = STANDARD_GRAVITY,
    start: StartMotion | None = None,
) -> TaskForce:
    """``f_k = m (p''_k - g)`` from end-effector positions (N x 3) at times ``t``.

    Accelerations are the paper's backward differences with the trajectory starting at rest, or
    with the end effector's ``start`` motion (see :func:`forte.model.trajectory.backward_differences`).
    """
    m = as_positive(mass, "mass", allow_zero=True)  # 0: an empty hand without a tool load
    times = check_times(t)
    pos = as_array(positions, "positions", (times.size, 3))
    _, acc = backward_differences(pos, times, "positions", start)
    g = np.array([0.0, 0.0, -gravity])
    return TaskForce(times, m * (acc - g), _radii(radius, times.size))


def attached_from(force: TaskForce, payload_share: Any, step: int) -> TaskForce:
    """The force of a payload picked up at waypoint ``step`` (0-based): before it the hand carries
    only the rest of ``force`` (the robot's own tool load), ``f_k - f^p_k`` with ``f^p_k`` the
    payload's share (N x 3), no ball (``r_k = 0``: the radius covers the payload's mass) and no
    moment; from ``step`` on ``force`` unchanged. The mass switches at ``step``: a step in the force."""
    before = np.arange(len(force.t)) < int(step)
    f = np.where(before[:, None], force.f - np.asarray(payload_share, dtype=float), force.f)
    m = None if force.m is None else np.where(before[:, None], 0.0, force.m)
    return TaskForce(force.t, f, np.where(before, 0.0, force.r), m, force.lever, force.moment_scale)


#: Which desired force a payload task uses (task field ``force_model``): ``paper`` (the text,
#: :func:`payload_force`) or ``authors`` (the authors' lift code, :func:`authors_force`).
FORCE_MODELS: tuple[str, ...] = ("paper", "authors")

#: The authors' blend time of the desired force (s; their ``desired_force_ramp_time_sec``).
AUTHORS_FORCE_RAMP_S = 1.0


def authors_force(
    t: Any,
    mass: Any,
    radius: Any = DEFAULT_RADIUS,
    gravity: float = STANDARD_GRAVITY,
    ramp: float = AUTHORS_FORCE_RAMP_S,
    elapsed: float = 0.0,
) -> TaskForce:
    """The authors' desired force: the static load blended in from zero.

    ``f_k = s((t_k - t_1 + elapsed) / T) m g e_z`` with ``s(x) = 10 x^3 - 15 x^4 + 6 x^5`` on
    ``x`` clipped to [0, 1], ``T = ramp`` and ``e_z`` up. Their lift samples carry no
    acceleration, so the force is ``m g`` (no ``m p''`` term), and it is blended in from the
    force published before the run (zero) over ``T`` = 1 s; the radii are not blended.
    ``ramp = 0`` gives the static force with no blend (their single-point holding).
    ``elapsed`` is the blend time already passed at ``t_1`` (a receding-horizon shift).
    """
    m = as_positive(mass, "mass")
    times = check_times(t)
    T = as_positive(ramp, "ramp", allow_zero=True)
    scale = np.ones(times.size)
    if T > 0:
        scale = quintic_blend(np.clip((times - times[0] + float(elapsed)) / T, 0.0, 1.0))
    f = np.zeros((times.size, 3))
    f[:, 2] = scale * m * gravity
    return TaskForce(times, f, _radii(radius, times.size))


def given_force(t: Any, forces: Any, radius: Any = DEFAULT_RADIUS) -> TaskForce:
    """A force profile given directly (N x 3), e.g. the continuous experiment of Section 5.2."""
    times = check_times(t)
    f = as_array(forces, "force", (times.size, 3))
    return TaskForce(times, f, _radii(radius, times.size))


#: How the uncertainty radius ``r_k`` is set: ``fixed`` (the authors' 10 N at every waypoint) or
#: ``mass-range`` (from the mass estimate's range, :func:`mass_range_radius`).
RADIUS_RULES: tuple[str, ...] = ("fixed", "mass-range")


def mass_range_radius(force: TaskForce, total_mass: float, mass: float, mass_range: Any,
                      floor: float) -> TaskForce:
    """The force ball that covers every payload mass of the estimate's range.

    With ``f_k = M (p''_k - g)`` (``M = total_mass``, the payload ``mass`` plus the known tool
    load) a payload of ``mass + dm`` needs ``f_k + dm (p''_k - g)``, so the ball of radius
    ``r_k = max(floor, dm_max |f_k| / M)``, ``dm_max = max(high - mass, mass - low)``, contains
    the force of every mass in ``[low, high]`` (with ``floor``, never less than the fixed
    margin). Returns ``force`` with those radii.
    """
    low, high = (float(v) for v in mass_range)
    if not (0.0 <= low <= mass <= high):
        raise InvalidInputError(f"mass range: expected low <= mass <= high, got [{low:g}, {high:g}] for {mass:g} kg")
    spread = max(high - mass, mass - low)
    r = np.maximum(float(floor), spread * force.magnitude / as_positive(total_mass, "mass"))
    return TaskForce(force.t, force.f, r)
