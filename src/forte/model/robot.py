"""Robot model: a holonomic base ``q_b = [x, y, yaw]`` carrying a fixed-base URDF arm.

The whole-body configuration is ``q = [q_b, q_a]``. The arm is loaded with Pinocchio; joints
that are not on the kinematic chain of the end-effector frame (the Panda's fingers) are locked.
The base-to-arm mounting transform is folded into the arm's root joint placement, so the arm
model lives in the *base frame* (z up, gravity ``[0, 0, -g]``) and every world-frame quantity is
the base-frame quantity rotated by ``R_z(yaw)`` and shifted by ``[x, y, 0]``.

Two ways to account for what the end effector carries besides the payload:

- ``tool``: a rigid load added to the inertia of the joint that carries the end-effector frame,
  so it is part of the arm dynamics (the ``moca-like`` preset: a 0.8 kg basket-and-camera box);
- ``tool_force_mass``: a mass (kg) added to the payload in the *required force*
  ``f = (m_payload + m_tool) (a - g)`` and not to the arm dynamics (the authors' setup: the
  Franka end-effector load ``m_total``, 1.146 kg identified).
The payload itself always enters through the desired task force (paper, Section 5).
The built-in default (:func:`default_robot`, preset ``authors``) is the authors' description:
Panda base at (0.2575, 0, 0.52) m, end-effector frame = flange (``panda_link8``) rotated -45 deg
about z plus 0.10 m along z (``ee_offset`` on the URDF's ``panda_hand`` frame, which is exactly
the flange rotated -45 deg), the hand link's mass set to 0.54 kg, torque limits 60/12 Nm and
``tool_force_mass`` 1.146 kg (the authors' public code).
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from forte.exceptions import InvalidInputError, RobotModelError
from forte.model.base_support import AUTHORS_BASE, check_support
from forte.model.description import (
    AUTHORS_EE_OFFSET,
    AUTHORS_HAND_MASS,
    AUTHORS_HOME,
    AUTHORS_MOUNT,
    AUTHORS_TOOL_FORCE_MASS,
    EE_FRAME_NAME,
    KNOWN_ARMS,
    MOCA_MOUNT,
    MOCA_TOOL,
    N_BASE,
    PANDA_ACCELERATION_LIMITS,
    PANDA_ARM_JOINTS,
    PANDA_HOME,
    PAPER_TORQUE_LIMITS,
    STANDARD_GRAVITY,
    ToolLoad,
    example_robot_data_dir,
    resolve_urdf,
    urdf_reference,
)
from forte.model.urdf_loading import check_locked, load_model, reduce_to_arm, set_link_mass
from forte.validation import FloatArray, as_array, as_positive, as_vector

#: How the base may move: ``holonomic`` (the default), ``differential`` (no lateral velocity), ``fixed``.
BASE_MODES: tuple[str, ...] = ("holonomic", "differential", "fixed")


@dataclass
class MobileManipulator:
    """A planar holonomic base (x, y, yaw) with a URDF arm mounted on it.

    Args:
        urdf: Path to the arm URDF, or ``erd:<path>`` inside example-robot-data.
        ee_frame: Name of the end-effector frame in the URDF.
        arm_joints: Actuated arm joints, root to tip; default: the joints supporting
            ``ee_frame``. Every other joint is locked at its neutral value, or:
        locked_joints: ``{name: value}`` of joints that are not planned (the Panda's fingers),
            held at these values (kept even beyond the URDF's range: a locked joint is geometry).
        mount: 4x4 homogeneous transform from the base frame to the arm's root frame.
        tool: Load rigidly attached to the end effector, part of the arm dynamics.
        torque_limits: Symmetric limits tau_max per arm joint (Nm); default: the URDF efforts.
        gravity: Gravitational acceleration magnitude (m/s^2), acting along -z.
        name: A label for reports.
        home_arm: Arm part of :meth:`home` (rad); default: the known arm's home pose, else
            the neutral configuration clipped to the joint range.
        acceleration_limits: Arm joint acceleration limits (rad/s^2) used by the planner's
            kinematic limits; default: the known arm's, else none.
        ee_offset: 4x4 transform from ``ee_frame`` to the end effector; when given, a frame
            ``forte_ee`` is added there and used as the end effector.
        hand_mass: Mass (kg) given to the URDF link ``hand_link`` (its inertia about the centre
            of mass scaled by the same ratio, centre of mass kept); ``None``: the URDF's.
        hand_link: The URDF link ``hand_mass`` applies to.
        tool_force_mass: Mass (kg) added to the payload in the required force
            ``f = (m_payload + m_tool)(a - g)``, not in the arm dynamics.
        base: How the base moves (:data:`BASE_MODES`): ``holonomic`` (x, y, yaw free),
            ``differential`` (no lateral velocity in the base frame) or ``fixed`` (it stays at
            the initial configuration's base). Not part of the kinematics or the kernels: the
            planner imposes it with bounds and rows (:mod:`forte.planning.nlp.base_rows`).
        base_support: The base's support polygon, mass and centre of mass
            (:class:`~forte.model.base_support.BaseSupport`, or its dict); ``None``: not stated
            (no tip-over margin, :mod:`forte.model.stability`).
    """

    urdf: str | Path
    ee_frame: str
    arm_joints: tuple[str, ...] | None = None
    mount: Any = field(default_factory=lambda: np.eye(4))
    tool: ToolLoad | None = None
    torque_limits: Any = None
    gravity: float = STANDARD_GRAVITY
    name: str = "robot"
    home_arm: Any = None
    acceleration_limits: Any = None
    ee_offset: Any = None
    hand_mass: float | None = None
    hand_link: str = "panda_hand"
    tool_force_mass: float = 0.0
    base: str = "holonomic"
    base_support: Any = None
    locked_joints: Any = None

    def __post_init__(self) -> None:
        if self.base not in BASE_MODES:
            raise InvalidInputError(f"base: expected one of {', '.join(BASE_MODES)}, got {self.base!r}")
        self.urdf_path = resolve_urdf(self.urdf)
        self.gravity = as_positive(self.gravity, "gravity")
        mount = as_array(self.mount, "mount", (4, 4))
        if not np.allclose(mount[3], [0, 0, 0, 1]) or not np.allclose(
            mount[:3, :3] @ mount[:3, :3].T, np.eye(3), atol=1e-9
        ):
            raise InvalidInputError("mount: expected a 4x4 rigid transform (orthonormal rotation)")
        self.mount = mount
        if self.ee_offset is not None:
            offset = as_array(self.ee_offset, "ee_offset", (4, 4))
            if not np.allclose(offset[3], [0, 0, 0, 1]) or not np.allclose(
                    offset[:3, :3] @ offset[:3, :3].T, np.eye(3), atol=1e-9):
                raise InvalidInputError("ee_offset: expected a 4x4 rigid transform (orthonormal rotation)")
            self.ee_offset = offset
        self.tool_force_mass = as_positive(self.tool_force_mass, "tool_force_mass", allow_zero=True)
        self.base_support = check_support(self.base_support)
        if self.hand_mass is not None:
            self.hand_mass = as_positive(self.hand_mass, "hand_mass")
        try:
            full = load_model(self.urdf_path)
        except Exception as exc:  # Pinocchio raises plain RuntimeError/ValueError
            raise RobotModelError(f"urdf: cannot parse {self.urdf_path}: {exc}") from exc
        if not full.existFrame(self.ee_frame):
            names = ", ".join(f.name for f in full.frames if f.type == pin.FrameType.BODY)
            raise RobotModelError(
                f"ee_frame: no frame '{self.ee_frame}' in {self.urdf_path.name}; bodies: {names}"
            )
        if self.hand_mass is not None:
            set_link_mass(full, self.urdf_path, self.hand_link, self.hand_mass)
        chain = self._supporting_joints(full)
        joints = tuple(self.arm_joints) if self.arm_joints is not None else chain
        for j in joints:
            if not full.existJointName(j):
                raise RobotModelError(
                    f"arm_joints: no joint '{j}' in {self.urdf_path.name}; joints: "
                    + ", ".join(full.names[1:])
                )
            jid = full.getJointId(j)
            if full.joints[jid].nq != 1 or full.joints[jid].nv != 1:
                raise RobotModelError(f"arm_joints: joint '{j}' is not a 1-DoF joint")
        self.arm_joints = joints
        self.locked_joints = check_locked(full, self.urdf_path.name, joints, self.locked_joints)
        self.model = reduce_to_arm(full, joints, self.mount, self.ee_frame, self.ee_offset, self.tool,
                                   self.locked_joints)
        self.model.gravity = pin.Motion(np.array([0, 0, -self.gravity, 0, 0, 0]))
        self.data = self.model.createData()
        if self.ee_offset is not None:
            base = self.model.frames[self.model.getFrameId(self.ee_frame)]
            placement = base.placement * pin.SE3(self.ee_offset[:3, :3].copy(), self.ee_offset[:3, 3].copy())
            self.model.addFrame(pin.Frame(EE_FRAME_NAME, base.parentJoint, self.model.getFrameId(self.ee_frame),
                                          placement, pin.FrameType.OP_FRAME))
            self.data = self.model.createData()
        self.ee_frame_id = self.model.getFrameId(EE_FRAME_NAME if self.ee_offset is not None else self.ee_frame)
        self.n_arm = self.model.nq
        self.nq = N_BASE + self.n_arm
        self.lower = np.array(self.model.lowerPositionLimit, dtype=float)
        self.upper = np.array(self.model.upperPositionLimit, dtype=float)
        if self.torque_limits is None:
            limits = np.array(self.model.effortLimit, dtype=float)
        else:
            limits = as_vector(self.torque_limits, "torque_limits", self.n_arm)
        if np.any(limits <= 0):
            raise InvalidInputError(f"torque_limits: expected every limit > 0 Nm, got {limits}")
        self.torque_limits = limits
        self._apply_arm_defaults()

    # -- construction -------------------------------------------------------------------
    def _apply_arm_defaults(self) -> None:
        """Home pose and acceleration limits: given, from :data:`KNOWN_ARMS`, or none."""
        known: dict[str, tuple[float, ...]] = {}
        try:
            shipped = self.urdf_path.resolve().relative_to(example_robot_data_dir().resolve()).as_posix()
        except ValueError:  # not one of example-robot-data's descriptions
            shipped = ""
        if self.n_arm == 7:
            known = KNOWN_ARMS.get(shipped, {})
        home = self.home_arm if self.home_arm is not None else known.get("home")
        if home is None:
            home = np.clip(pin.neutral(self.model), self.lower, self.upper)
        self.home_arm = as_vector(home, "home_arm", self.n_arm)
        acc = self.acceleration_limits if self.acceleration_limits is not None else known.get("acceleration_limits")
        if acc is not None:
            acc = as_vector(acc, "acceleration_limits", self.n_arm)
            if np.any(acc <= 0):
                raise InvalidInputError(f"acceleration_limits: expected every limit > 0 rad/s^2, got {acc}")
        self.acceleration_limits = acc

    def _supporting_joints(self, full: pin.Model) -> tuple[str, ...]:
        parent = full.frames[full.getFrameId(self.ee_frame)].parentJoint
        return tuple(full.names[j] for j in full.supports[parent][1:])

    # -- description --------------------------------------------------------------------
    def describe(self) -> dict[str, Any]:
        """Everything needed to rebuild this model (for plan.json and cache keys)."""
        return {
            "name": self.name,
            "urdf": urdf_reference(self.urdf_path),  # erd:<path> for example-robot-data's: portable
            "urdf_sha256": hashlib.sha256(self.urdf_path.read_bytes()).hexdigest(),
            "ee_frame": self.ee_frame,
            "arm_joints": list(self.arm_joints or ()),
            "mount": self.mount.tolist(),
            "tool": self.tool.to_dict() if self.tool else None,
            "torque_limits": self.torque_limits.tolist(),
            "gravity": self.gravity,
            "joint_lower": self.lower.tolist(),
            "joint_upper": self.upper.tolist(),
            "home_arm": self.home_arm.tolist(),
            "acceleration_limits": None if self.acceleration_limits is None else self.acceleration_limits.tolist(),
            "ee_offset": None if self.ee_offset is None else self.ee_offset.tolist(),
            "hand_mass": self.hand_mass,
            "hand_link": self.hand_link if self.hand_mass is not None else None,  # only what it names
            "tool_force_mass": self.tool_force_mass,
            "base": self.base,
            "base_support": None if self.base_support is None else self.base_support.to_dict(),
            "locked_joints": dict(self.locked_joints),
        }

    @cached_property
    def fingerprint(self) -> str:
        """Short hash of :meth:`describe`, used to key caches of generated code."""
        desc = self.describe()
        desc.pop("urdf")
        desc.pop("base")  # the base mode is bounds and rows outside the compiled kernels
        if not desc["locked_joints"]:  # the keys of the robots that lock nothing stay as they were
            desc.pop("locked_joints")
        return hashlib.sha256(repr(sorted(desc.items())).encode()).hexdigest()[:16]

    # -- configuration helpers ----------------------------------------------------------
    def check_configuration(self, q: Any, name: str = "q") -> FloatArray:
        """A finite whole-body configuration of length ``3 + n_arm``."""
        return as_vector(q, name, self.nq)

    def split(self, q: FloatArray) -> tuple[FloatArray, FloatArray]:
        """``(q_b, q_a)`` of a whole-body configuration."""
        return q[:N_BASE], q[N_BASE:]

    def home(self, base: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> FloatArray:
        """The whole-body home configuration: ``base`` and :attr:`home_arm`."""
        return np.concatenate([np.asarray(base, dtype=float), self.home_arm])

    @staticmethod
    def base_transform(q_b: FloatArray) -> FloatArray:
        """4x4 world pose of the base frame: ``Rot_z(yaw)`` at ``[x, y, 0]``."""
        T = np.eye(4)
        T[:3, :3] = pin.rpy.rpyToMatrix(0.0, 0.0, float(q_b[2]))
        T[:2, 3] = q_b[:2]
        return T

    # -- kinematics ---------------------------------------------------------------------
    def arm_ee_pose(self, q_a: FloatArray) -> FloatArray:
        """4x4 pose of the end-effector frame in the base frame (the mount included) at arm
        configuration ``q_a``: :meth:`ee_pose` without the base's transform."""
        pin.framesForwardKinematics(self.model, self.data, q_a)
        return self.data.oMf[self.ee_frame_id].homogeneous

    def ee_pose(self, q: Any) -> FloatArray:
        """4x4 world-frame pose of the end-effector frame."""
        q = self.check_configuration(q)
        q_b, q_a = self.split(q)
        return self.base_transform(q_b) @ self.arm_ee_pose(q_a)

    def ee_position(self, q: Any) -> FloatArray:
        return self.ee_pose(q)[:3, 3]

    def arm_jacobian(self, q: Any) -> FloatArray:
        """World-frame translational Jacobian ``J_t`` (3 x n_arm) with the base held fixed."""
        return self.arm_jacobians(self.check_configuration(q)[None])[0]

    def whole_body_jacobian(self, q: Any) -> FloatArray:
        """World-frame 6 x nq Jacobian (linear; angular) of the end effector w.r.t. ``q``."""
        q = self.check_configuration(q)
        q_b, q_a = self.split(q)
        R = pin.rpy.rpyToMatrix(0.0, 0.0, float(q_b[2]))
        J_arm = pin.computeFrameJacobian(
            self.model, self.data, q_a, self.ee_frame_id, pin.LOCAL_WORLD_ALIGNED
        )
        p_rel = R @ self.data.oMf[self.ee_frame_id].translation
        J = np.zeros((6, self.nq))
        J[0, 0] = J[1, 1] = 1.0
        J[:3, 2] = [-p_rel[1], p_rel[0], 0.0]
        J[5, 2] = 1.0
        J[:3, N_BASE:] = R @ J_arm[:3]
        J[3:, N_BASE:] = R @ J_arm[3:]
        return J

    def rnea(self, q_a: Any, dq_a: Any, ddq_a: Any) -> FloatArray:
        """Arm inverse dynamics ``tau = M(q) ddq + C(q, dq) dq + g(q)`` (base held fixed)."""
        q_a, dq_a, ddq_a = (as_vector(x, name, self.n_arm) for x, name in ((q_a, "q_a"), (dq_a, "dq_a"),
                                                                            (ddq_a, "ddq_a")))
        return np.array(pin.rnea(self.model, self.data, q_a, dq_a, ddq_a))

    def rnea_along(self, q_a: Any, dq_a: Any, ddq_a: Any) -> FloatArray:
        """:meth:`rnea` at each row of K x n_arm arrays (checked once, not per row)."""
        q_a = as_array(q_a, "q_a", (None, self.n_arm))
        dq_a, ddq_a = as_array(dq_a, "dq_a", q_a.shape), as_array(ddq_a, "ddq_a", q_a.shape)
        return np.array([pin.rnea(self.model, self.data, *row) for row in zip(q_a, dq_a, ddq_a, strict=True)])

    def arm_jacobians(self, q: Any) -> FloatArray:
        """:meth:`arm_jacobian` at each row of K x nq configurations (K x 3 x n_arm): the arm's
        Jacobian in its mount frame rotated by the base yaw."""
        q = as_array(q, "q", (None, self.nq))
        J = np.array([pin.computeFrameJacobian(self.model, self.data, qa, self.ee_frame_id, pin.LOCAL_WORLD_ALIGNED)[:3]
                      for qa in q[:, N_BASE:]])
        c, s = np.cos(q[:, 2])[:, None], np.sin(q[:, 2])[:, None]
        return np.stack([c * J[:, 0] - s * J[:, 1], s * J[:, 0] + c * J[:, 1], J[:, 2]], axis=1)


def default_robot(torque_limits: Any = PAPER_TORQUE_LIMITS, variant: str = "authors",
                  **overrides: Any) -> MobileManipulator:
    """A built-in robot: holonomic base + Franka Panda (example-robot-data, fingers locked).

    ``variant``:

    - ``"authors"`` (default): the authors' description (the authors' public code): mount
      (0.2575, 0, 0.52) m, end effector ``panda_hand`` (the flange rotated -45 deg about z) plus
      0.10 m along z, hand 0.54 kg, no tool in the dynamics, ``tool_force_mass`` 1.146 kg in the
      required force, home = the authors' taught home;
    - ``"moca-like"``: forte's earlier estimate: ``panda_hand_tcp``, :data:`MOCA_MOUNT`, the
      :data:`MOCA_TOOL` box in the arm dynamics, the Panda's ready pose as home.

    Both use the paper's torque limits (60 Nm joints 1-4, 12 Nm joints 5-7) and stand on the authors'
    MOCA base (:data:`~forte.model.base_support.AUTHORS_BASE`: support polygon, 151 kg).

    Examples:
        >>> import forte
        >>> robot = forte.default_robot()
        >>> robot.nq, robot.torque_limits.tolist(), robot.tool_force_mass
        (10, [60.0, 60.0, 60.0, 60.0, 12.0, 12.0, 12.0], 1.146)
    """
    common: dict[str, Any] = {
        "urdf": "erd:panda_description/urdf/panda.urdf", "arm_joints": PANDA_ARM_JOINTS,
        "torque_limits": torque_limits, "acceleration_limits": PANDA_ACCELERATION_LIMITS,
        "base_support": AUTHORS_BASE,
    }
    if variant == "authors":
        kwargs = common | {
            "ee_frame": "panda_hand", "ee_offset": np.array(AUTHORS_EE_OFFSET), "mount": np.array(AUTHORS_MOUNT),
            "tool": None, "name": "moca-panda-authors", "home_arm": AUTHORS_HOME,
            "hand_mass": AUTHORS_HAND_MASS, "tool_force_mass": AUTHORS_TOOL_FORCE_MASS,
        }
    elif variant == "moca-like":
        kwargs = common | {"ee_frame": "panda_hand_tcp", "mount": np.array(MOCA_MOUNT), "tool": MOCA_TOOL,
                           "name": "moca-panda", "home_arm": PANDA_HOME}
    else:
        raise InvalidInputError(f"robot preset: expected one of authors, moca-like, got {variant!r}")
    if "urdf" in overrides:  # another arm: the Panda's own values do not apply
        for key in ("home_arm", "acceleration_limits", "hand_mass", "arm_joints"):
            kwargs.pop(key, None)
    kwargs.update(overrides)
    return MobileManipulator(**kwargs)


def robot_from_description(desc: dict[str, Any]) -> MobileManipulator:
    """Rebuild a robot from :meth:`MobileManipulator.describe` output (e.g. from plan.json)."""
    try:
        tool = desc.get("tool")
        return MobileManipulator(
            urdf=desc["urdf"],
            ee_frame=desc["ee_frame"],
            arm_joints=tuple(desc["arm_joints"]) or None,
            mount=np.array(desc["mount"], dtype=float),
            tool=None if tool is None else ToolLoad(
                mass=tool["mass"], com=tuple(tool["com"]),
                inertia=tuple(tuple(row) for row in tool["inertia"]),
            ),
            torque_limits=desc["torque_limits"],
            gravity=desc.get("gravity", STANDARD_GRAVITY),
            name=desc.get("name", "robot"),
            home_arm=desc.get("home_arm"),
            acceleration_limits=desc.get("acceleration_limits"),
            ee_offset=None if desc.get("ee_offset") is None else np.array(desc["ee_offset"], dtype=float),
            hand_mass=desc.get("hand_mass"),
            hand_link=desc.get("hand_link") or "panda_hand",
            tool_force_mass=desc.get("tool_force_mass", 0.0),
            base=desc.get("base", "holonomic"),
            base_support=desc.get("base_support"),
            locked_joints=desc.get("locked_joints") or None,
        )
    except KeyError as exc:
        raise RobotModelError(f"robot description: missing field {exc}") from exc
