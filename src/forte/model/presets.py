"""Robot presets: a registry of named robots, like the methods' (``robot: {preset: NAME}``).

Each preset is a :class:`RobotPreset`: a name, one line of description, and the arguments of
:class:`~forte.model.robot.MobileManipulator` (or the built-in variants of
:func:`~forte.model.robot.default_robot`). A task's other ``robot:`` fields override them.

Built in:

- ``authors`` (default) and ``moca-like``: the MOCA's Franka Panda (:func:`default_robot`);
- ``ur5``: Universal Robots' UR5 (example-robot-data, ``tool0``) on the built-in base at the
  authors' mount, torque limits from its URDF (150/150/150/28/28/28 Nm);
- ``kinova``: Kinova's 6-DoF Jaco 2 (``j2s6s200``, its continuous joints planned within two turns
  each way, :mod:`forte.model.urdf_loading`) on the built-in base at the authors' mount;
- ``tiago``: PAL's TIAGo without hand: its torso lift (prismatic) and 7-DoF arm, planned as one
  chain on its own differential-drive base (``base: differential``; the URDF's ``base_footprint``
  is the base frame, so no mount), tool ``arm_tool_link``.

Every preset states its base's support (:mod:`forte.model.base_support`): the ur5 and kinova stand
on the built-in MOCA base (``AUTHORS_BASE``), TIAGo on its own (``TIAGO_BASE``, its URDF's wheels).

Homes are postures away from singularities and joint limits (a URDF carries none): the UR5's
and TIAGo's a usual ready pose, the Kinova's the posture forte's planner settled in from its
ready pose (its 0.63 rad/s joint speed limits made the move there the plan's bottleneck); a
task's ``initial_configuration`` replaces them.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import numpy as np

from forte.exceptions import InvalidInputError
from forte.model.base_support import AUTHORS_BASE, TIAGO_BASE
from forte.model.description import AUTHORS_MOUNT, TORQUE_LIMIT_SETS
from forte.model.robot import MobileManipulator, default_robot, robot_from_description


@dataclass(frozen=True)
class RobotPreset:
    """A named robot: ``variant`` of :func:`default_robot`, or ``arguments`` of MobileManipulator."""

    name: str
    description: str
    arguments: Mapping[str, Any] = field(default_factory=dict)
    variant: str | None = None

    def build(self, **overrides: Any) -> MobileManipulator:
        """The robot, with ``overrides`` (a task's ``robot:`` fields) on top."""
        if self.variant is not None:
            return default_robot(variant=self.variant, **overrides)
        arguments = dict(self.arguments)
        if "urdf" in overrides:  # another arm than the preset's: its own values do not apply
            for key in ("arm_joints", "home_arm", "acceleration_limits", "torque_limits"):
                arguments.pop(key, None)
        return MobileManipulator(**(arguments | {"name": self.name} | overrides))


#: The registry: preset name -> preset, in registration order.
ROBOT_PRESETS: dict[str, RobotPreset] = {}


def register_robot_preset(preset: RobotPreset, *, replace: bool = False) -> RobotPreset:
    """Add ``preset`` to :data:`ROBOT_PRESETS`."""
    if preset.name in ROBOT_PRESETS and not replace:
        raise InvalidInputError(f"robot preset '{preset.name}' is already registered")
    ROBOT_PRESETS[preset.name] = preset
    return preset


def preset_robot(name: str, **overrides: Any) -> MobileManipulator:
    """The robot of preset ``name`` with ``overrides``."""
    if name not in ROBOT_PRESETS:
        raise InvalidInputError(f"preset: expected one of {', '.join(ROBOT_PRESETS)}, got {name!r}")
    return ROBOT_PRESETS[name].build(**overrides)


for _preset in (
    RobotPreset("authors", "the authors' MOCA: Franka Panda on the holonomic base (default)", variant="authors"),
    RobotPreset("moca-like", "forte's earlier MOCA estimate (Panda, panda_hand_tcp, a tool box)", variant="moca-like"),
    RobotPreset("ur5", "Universal Robots UR5 on the holonomic base", MappingProxyType({
        "urdf": "erd:ur_description/urdf/ur5_robot.urdf", "ee_frame": "tool0", "mount": np.array(AUTHORS_MOUNT),
        "home_arm": (0.0, -1.75, 1.85, -1.67, -1.57, 0.0), "base_support": AUTHORS_BASE})),
    RobotPreset("kinova", "Kinova Jaco 2, 6 DoF (j2s6s200), on the holonomic base", MappingProxyType({
        "urdf": "erd:kinova_description/robots/kinova.urdf", "ee_frame": "j2s6s200_end_effector",
        "mount": np.array(AUTHORS_MOUNT), "home_arm": (1.09, 3.67, 2.38, 3.33, 2.35, 1.49),
        "base_support": AUTHORS_BASE})),
    RobotPreset("tiago", "PAL TIAGo (no hand): torso lift and 7-DoF arm on its differential base", MappingProxyType({
        "urdf": "erd:tiago_description/robots/tiago_no_hand.urdf", "ee_frame": "arm_tool_link",
        "arm_joints": ("torso_lift_joint", *(f"arm_{i}_joint" for i in range(1, 8))), "base": "differential",
        "home_arm": (0.2, 1.6, 0.3, -1.2, 1.9, -1.57, 1.0, 0.0), "base_support": TIAGO_BASE})),
):
    register_robot_preset(_preset)


def with_torque_limits(robot: MobileManipulator, limits: Any) -> MobileManipulator:
    """``robot`` with other torque limits: Nm (one value for every arm joint, or one per joint), or
    ``None`` for the efforts of its URDF."""
    if limits is not None:
        limits = [float(v) for v in np.broadcast_to(np.asarray(limits, dtype=float), (robot.n_arm,))]
    return robot_from_description({**robot.describe(), "torque_limits": limits})


def torque_limit_name(robot: MobileManipulator) -> str:
    """The set of :data:`~forte.model.description.TORQUE_LIMIT_SETS` that ``robot``'s limits equal
    (``paper`` first), else ``custom``."""
    for name, limits in TORQUE_LIMIT_SETS.items():
        values = robot.model.effortLimit if limits is None else limits
        if len(values) == robot.n_arm and np.array_equal(robot.torque_limits, np.asarray(values, dtype=float)):
            return name
    return "custom"
