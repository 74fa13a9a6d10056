"""Controller gains for any arm: a bandwidth rule, and the ``controller:`` mapping that overrides it.

Rule. With the desired inertia equal to the arm inertia (``M_d = M_a``, paper Section 3.1), and
the inertia taken as diagonal, joint ``i`` of the impedance law behaves like

    M_ii e'' + D_i e' + K_i e = 0.

For a natural frequency ``omega = 2 pi f`` (``f``: bandwidth in Hz) and damping ratio ``zeta``:

    K_i = M_ii omega^2,        D_i = 2 zeta sqrt(K_i M_ii)   (= 2 zeta M_ii omega for the rule's K_i),

where ``M_ii`` is the diagonal of ``M_a(q_a0) + diag(armature)``: the nominal arm inertia (tool
included, payload excluded, as in the controller) plus the joints' rotor inertia, at the start
configuration ``q_a0``. Defaults: ``f`` = :data:`DEFAULT_BANDWIDTH_HZ` (4 Hz), ``zeta`` =
:data:`DEFAULT_DAMPING_RATIO` (1). On the Panda the rule gives K = (448, 1109, 745, 788, 110,
122, 70) Nm/rad and D = (36, 88, 59, 63, 8.8, 9.7, 5.6) Nm s/rad at the lift task's start, and
tracks the quintic lift of ``examples/tasks/lift.yaml`` (2.7 kg) as well as Franka's gains: 3.4 mm
vs 3.5 mm largest end-effector error. (The authors' released controller configuration, stiffness
(100, 200, 200, 100, 30, 30, 30) Nm/rad with damping ratio 1, gives 7.8 mm there.)

Stability at 1 kHz. The sampled loop needs ``dt * max eig(M^-1 D) < 2`` (see
:func:`forte.execution.control.sampled_loop_spectral_radius`). With ``M >= armature * I`` this
holds everywhere when ``2 zeta omega max_i M_ii(q_a0) / armature < 2 / dt`` (``eig(M^-1 D) <=
max_i D_i / min eig(M)``; sufficient, not necessary: the Panda meets it with 0.88 / 2, the
stretched-out UR5 does not, 2.25 / 2, yet is far from the limit). Measured with the
default rule over 2000 random configurations (gains fixed at the start configuration): largest
``dt * eig(M^-1 D)`` 0.46 (Panda) and 0.60 (UR5 stretched out at the start, ``M_11`` = 4.5
kg m^2), spectral radius at most 0.9965 and 0.9885.

Which gains. The arm gains are, in this order:

* ``K_a`` / ``D_a`` when the mapping gives them;
* for the Franka Panda, when the mapping names none of ``K_a``, ``D_a``, ``bandwidth_hz``,
  ``damping_ratio``: Franka's pair :data:`forte.execution.control.DEFAULT_K_A` /
  :data:`forte.execution.control.DEFAULT_D_A` (so earlier results do not move);
* otherwise the rule: ``K_i = M_ii omega^2`` when ``K_a`` is absent, ``D_i = 2 zeta
  sqrt(K_i M_ii)`` when ``D_a`` is absent (so ``K_a`` alone plus ``damping_ratio`` gives the
  damping of that stiffness).

The base gains (``M_b``, ``B_b``, ``K_b``, ``D_b``) and the two feedforward switches default to
:class:`forte.execution.control.ControlGains`'s values; they do not depend on the arm.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields, replace
from typing import Any

import numpy as np
import pinocchio as pin

from forte.exceptions import InvalidInputError
from forte.execution.control import DEFAULT_D_A, DEFAULT_K_A, ControlGains, sampled_loop_spectral_radius
from forte.execution.model import ARM_ARMATURE, armature_vector
from forte.model.robot import N_BASE, PANDA_ARM_JOINTS, MobileManipulator
from forte.validation import FloatArray, as_vector, unknown_field

#: Default bandwidth of the gain rule (Hz): about Franka's gains on the Panda (3-6 Hz per joint).
DEFAULT_BANDWIDTH_HZ = 4.0
#: Default damping ratio of the gain rule (critical damping).
DEFAULT_DAMPING_RATIO = 1.0

#: Base fields of a ``controller:`` mapping: name -> (unit, whether 0 is excluded).
_BASE_FIELDS = {"M_b": ("kg, kg m^2", True), "B_b": ("N s/m, Nm s/rad", False),
                "K_b": ("N/m, Nm/rad", False), "D_b": ("N s/m, Nm s/rad", False)}
_ARM_FIELDS = {"K_a": "Nm/rad", "D_a": "Nm s/rad"}
_FLAGS = ("base_feedforward", "force_feedforward", "base_coupling", "force_along_reference")
_RULE_FIELDS = ("bandwidth_hz", "damping_ratio")
#: Every field a ``controller:`` mapping may hold.
CONTROLLER_FIELDS: tuple[str, ...] = (*_RULE_FIELDS, *_ARM_FIELDS, *_BASE_FIELDS, *_FLAGS)


@dataclass(frozen=True)
class GainRule:
    """The bandwidth rule: natural frequency ``bandwidth_hz`` (Hz) and ``damping_ratio`` per joint."""

    bandwidth_hz: float = DEFAULT_BANDWIDTH_HZ
    damping_ratio: float = DEFAULT_DAMPING_RATIO

    @property
    def omega(self) -> float:
        """Natural frequency in rad/s, ``2 pi bandwidth_hz``."""
        return 2.0 * np.pi * self.bandwidth_hz

    def stiffness(self, m_diag: FloatArray) -> FloatArray:
        """``K_i = M_ii omega^2`` (Nm/rad)."""
        return m_diag * self.omega**2

    def damping(self, stiffness: FloatArray, m_diag: FloatArray) -> FloatArray:
        """``D_i = 2 zeta sqrt(K_i M_ii)`` (Nm s/rad)."""
        return 2.0 * self.damping_ratio * np.sqrt(stiffness * m_diag)


def joint_inertia_diagonal(robot: MobileManipulator, q_a: Any = None, armature: Any = ARM_ARMATURE) -> FloatArray:
    """Diagonal of ``M_a(q_a) + diag(armature)`` (kg m^2): Pinocchio's ``crba`` on the nominal arm.

    ``q_a`` defaults to the arm part of ``robot.home()``.
    """
    q_a = robot.home()[N_BASE:] if q_a is None else as_vector(q_a, "q_a", robot.n_arm)
    M = pin.crba(robot.model, robot.data, q_a)  # upper triangle; the diagonal is what we need
    return np.diag(M).copy() + armature_vector(armature, robot.n_arm)


def default_gains(robot: MobileManipulator, q_a: Any = None, armature: Any = ARM_ARMATURE) -> ControlGains:
    """The gains used when none are given: Franka's on the Panda, the default rule on other arms."""
    return gains_from_mapping({}, robot, q_a=q_a, armature=armature)


def gains_from_mapping(
    mapping: Mapping[str, Any] | None,
    robot: MobileManipulator,
    *,
    q_a: Any = None,
    armature: Any = ARM_ARMATURE,
    prefix: str = "controller.",
) -> ControlGains:
    """Controller gains from a ``controller:`` mapping (see the module docstring for the rules).

    Fields (all optional): ``bandwidth_hz`` (> 0), ``damping_ratio`` (> 0); ``K_a``, ``D_a``
    (>= 0, one number per arm joint or one number for all); ``M_b`` (> 0), ``B_b``, ``K_b``,
    ``D_b`` (>= 0, three numbers ``[x, y, yaw]`` or one for all); ``base_feedforward``,
    ``force_feedforward`` (true/false).

    Args:
        mapping: The fields above (None or empty: the defaults).
        robot: The robot the gains are for (number of arm joints, inertia).
        q_a: Arm configuration of the rule's inertia (the plan's start; default ``robot.home()``).
        armature: Rotor inertia per arm joint (kg m^2), as in the simulation model.
        prefix: Prefix of the field names in error messages (``controller.K_a: ...``).

    Raises:
        InvalidInputError: one line naming the field, the expected shape or range and the value.
    """
    mapping = _check_mapping(mapping, prefix)
    rule = GainRule(**{k: _positive(mapping[k], prefix + k) for k in _RULE_FIELDS if k in mapping})
    given = {k: _vector(mapping[k], prefix + k, robot.n_arm, unit, positive=False, joints="arm joint")
             for k, unit in _ARM_FIELDS.items() if k in mapping}
    values: dict[str, Any] = {k: _vector(mapping[k], prefix + k, 3, unit, positive=strict, joints="base axis")
                              for k, (unit, strict) in _BASE_FIELDS.items() if k in mapping}
    values.update({k: _flag(mapping[k], prefix + k) for k in _FLAGS if k in mapping})
    names_arm = any(k in mapping for k in (*_ARM_FIELDS, *_RULE_FIELDS))
    if robot.arm_joints == PANDA_ARM_JOINTS and not names_arm:
        values.update(K_a=DEFAULT_K_A, D_a=DEFAULT_D_A)
    else:
        m_diag = joint_inertia_diagonal(robot, q_a, armature)
        K = given.get("K_a", rule.stiffness(m_diag))
        D = given.get("D_a", rule.damping(K, m_diag))
        values.update(K_a=_floats(K), D_a=_floats(D))
    return ControlGains(**values)


def _check_mapping(mapping: Mapping[str, Any] | None, prefix: str) -> Mapping[str, Any]:
    name = prefix.rstrip(" .:") or "controller"
    if mapping is None:
        return {}
    if not isinstance(mapping, Mapping):
        raise InvalidInputError(f"{name}: expected a mapping of gains, got {type(mapping).__name__}")
    for key in mapping:
        if key not in CONTROLLER_FIELDS:
            raise InvalidInputError(
                f"{prefix}{key}: {unknown_field(key, CONTROLLER_FIELDS)}")
    return mapping


def _floats(values: Any) -> tuple[float, ...]:
    return tuple(float(v) for v in np.asarray(values, dtype=float))


def _is_number(value: Any) -> bool:
    return isinstance(value, int | float | np.integer | np.floating) and not isinstance(value, bool)


def _positive(value: Any, name: str) -> float:
    if not _is_number(value) or not np.isfinite(value) or value <= 0:
        raise InvalidInputError(f"{name}: expected a number > 0, got {value!r}")
    return float(value)


def _vector(value: Any, name: str, size: int, unit: str, *, positive: bool, joints: str) -> tuple[float, ...]:
    """``size`` finite numbers (one number is repeated), each > 0 (``positive``) or >= 0."""
    bound = "> 0" if positive else ">= 0"
    expected = f"expected {size} numbers {bound} ({unit}, one per {joints}) or one number"
    items = [value] if _is_number(value) else value
    if not isinstance(items, list | tuple) or not all(_is_number(v) for v in items):
        raise InvalidInputError(f"{name}: {expected}, got {value!r}")
    if len(items) not in (1, size):
        raise InvalidInputError(f"{name}: {expected}, got {len(items)} numbers")
    arr = np.broadcast_to(np.asarray(items, dtype=float), (size,))
    if not np.all(np.isfinite(arr)) or np.any(arr <= 0 if positive else arr < 0):
        raise InvalidInputError(f"{name}: {expected}, got {list(items)}")
    return _floats(arr)


def _flag(value: Any, name: str) -> bool:
    if not isinstance(value, bool):
        raise InvalidInputError(f"{name}: expected true or false, got {value!r}")
    return value


def describe_gains(gains: ControlGains) -> dict[str, Any]:
    """The gains as a JSON-ready mapping with the ``controller:`` field names."""
    out: dict[str, Any] = {}
    for f in fields(gains):
        value = getattr(gains, f.name)
        out[f.name] = [float(v) for v in value] if isinstance(value, tuple) else value
    return out


def sampled_loop_radius_at(robot: MobileManipulator, gains: ControlGains, q_a: Any, armature: Any,
                           dt: float) -> float:
    """Spectral radius of the sampled impedance loop at ``q_a`` (below 1: stable at period ``dt``).

    Uses the full inertia ``M_a(q_a) + diag(armature)``, see
    :func:`forte.execution.control.sampled_loop_spectral_radius`.
    """
    M = pin.crba(robot.model, robot.data, as_vector(q_a, "q_a", robot.n_arm))
    M = np.triu(M) + np.triu(M, 1).T + np.diag(armature_vector(armature, robot.n_arm))
    return sampled_loop_spectral_radius(M, gains.K_a, gains.D_a, dt)


def resolve_gains(gains: ControlGains | Mapping[str, Any] | None, sim: Any, q_a0: FloatArray,
                   force_feedforward: bool) -> ControlGains:
    """Gains object, mapping or default, with the force feedforward switched off if asked."""
    if gains is None:
        gains = default_gains(sim.robot, q_a0, sim.armature)
    elif isinstance(gains, Mapping):
        gains = gains_from_mapping(gains, sim.robot, q_a=q_a0, armature=sim.armature)
    elif not isinstance(gains, ControlGains):
        raise InvalidInputError(f"gains: expected ControlGains or a mapping, got {type(gains).__name__}")
    gains.check(sim.robot.n_arm)
    return gains if force_feedforward else replace(gains, force_feedforward=False)
